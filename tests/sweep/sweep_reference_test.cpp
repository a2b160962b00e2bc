// The optimised sweep (sweep/src/sweep.cpp) against the slow reference it replaced
// (sweep_reference.cpp): the same light grids, up to float rounding, on material that exercises
// every path of the optimised loops (empty, full and partly dense cells, black and coloured ones,
// rows without material, a coarse parent's edges) under every option.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "drtv/sweep/sweep.h"
#include "sweep_reference.h"

namespace drtv::sweep {
namespace {

// A portable hash in [0, 1): the material must not depend on the standard library's distributions.
float hash01(uint32_t a, uint32_t b) {
  uint32_t h = a * 0x9e3779b1u ^ (b + 0x7f4a7c15u) * 0x85ebca77u;
  h ^= h >> 15;
  h *= 0x2c1b3c6du;
  h ^= h >> 12;
  h *= 0x297a2d39u;
  h ^= h >> 15;
  return float(h >> 8) * (1.f / 16777216.f);
}

// Ground (full cells, one transition cell of fractional density per column), crowns of partly
// dense cells above it, some of them black, some full, and clear levels on top: the optimised
// sweep's air rows, material rows, full cells and fractional ones all occur.
// `ground_cells`: the ground's least depth; deep enough (5), the cells under it are sealed (sweep.h)
// in long runs, which the optimised sweep does not sweep.
MaterialGrid mixedMaterial(const GridShape& s, uint32_t seed, float ground_cells = 1.f) {
  MaterialGrid m = MaterialGrid::clear(s);
  m.ground_z.resize(size_t(s.size.x) * size_t(s.size.y));
  for (int j = 0; j < s.size.y; ++j)
    for (int i = 0; i < s.size.x; ++i) {
      const uint32_t col = uint32_t(i + 1000 * j);
      const float ground = ground_cells + 2.5f * hash01(seed, col);  // cells
      m.ground_z[size_t(i) + size_t(s.size.x) * size_t(j)] = float(s.origin.z + ground * s.cell_m);
      for (int k = 0; k < s.size.z; ++k) {
        const size_t n = s.index(i, j, k);
        const float r = hash01(seed + 1, uint32_t(n));
        float d = std::clamp(ground - float(k), 0.f, 1.f);
        // Crowns between the ground and the clear top levels.
        if (k >= int(ground_cells) + 2 && k < s.size.z - 3 && r < 0.25f) d = r < 0.03f ? 1.f : 4.f * r;
        m.density[n] = d;
        const float c = hash01(seed + 2, uint32_t(n));
        m.reflectance[n] = c < 0.2f ? glm::vec3(0.f) : glm::vec3(c, 0.6f * c, 0.3f * c);
      }
    }
  return m;
}

SkyInput morningSky() {
  const Sky sky = Sky::tropicalDefault();
  return {skyLight(sky, 9.0), sunLight(sky, 9.0, 0.05)};
}

// The two compute each path's transmittance (1 - d)^len differently (a product of per-length
// factors against exp of the summed optical depth), which differs by a few float ulps (~1e-6
// relative) and compounds over the levels to well under 1e-4. A stored R11G11B10 channel therefore
// either has the same code or, lying near a rounding boundary, the neighbouring one (one step:
// 2^-6 relative, 2^-5 for blue), or flushes to 0 at the 2^-14 threshold where the other does not.
bool channelsAgree(uint32_t a, uint32_t b) {
  const int shift[3] = {0, 11, 22}, mant[3] = {6, 6, 5};
  for (int c = 0; c < 3; ++c) {
    const int mask = c == 2 ? 0x3ff : 0x7ff;
    const int ca = int((a >> shift[c]) & uint32_t(mask)), cb = int((b >> shift[c]) & uint32_t(mask));
    const int smallest = 1 << mant[c];  // 2^-14, the smallest stored value
    const bool flush = (ca == 0 && cb == smallest) || (cb == 0 && ca == smallest);
    if (std::abs(ca - cb) > 1 && !flush) return false;
  }
  return true;
}

// The dominant direction's snorm bytes: within one step (1/127) likewise.
bool snormAgree(uint32_t a, uint32_t b) {
  for (int c = 0; c < 4; ++c)
    if (std::abs(int(int8_t(a >> (8 * c))) - int(int8_t(b >> (8 * c)))) > 1) return false;
  return true;
}

// Neighbouring codes must stay the exception: the share of words (light and average) that differ
// at all. Measured: 0 or 1 word in 140 000-300 000 on these grids; 0.1 % leaves room for another
// compiler's rounding, while a real difference in the model (a wrong factor, a skipped cell)
// changes far more words than that.
constexpr double kMaxDifferingShare = 0.001;

// `lit_share`: the least share of the reference's light values that are not 0 (the grids must hold
// light, or agreeing would mean nothing): most of them for the ambient, a few for the sun's direct
// part, which only the 1-4 bins of the sun's disc carry.
void expectSameGrid(const LightGrid& got, const LightGrid& want, double lit_share, const std::string& what) {
  ASSERT_EQ(got.shape.size, want.shape.size) << what;
  ASSERT_EQ(got.light.size(), want.light.size()) << what;
  ASSERT_EQ(got.average.size(), want.average.size()) << what;
  ASSERT_EQ(got.dominant.size(), want.dominant.size()) << what;
  size_t differing = 0, nonzero = 0, failures = 0;
  for (size_t w = 0; w < want.light.size(); ++w) {
    nonzero += want.light[w] != 0;
    differing += got.light[w] != want.light[w];
    if (!channelsAgree(got.light[w], want.light[w]) && ++failures <= 5)
      ADD_FAILURE() << what << ": cell " << w / kDirections << " direction " << w % kDirections << ": " << std::hex
                    << got.light[w] << " against " << want.light[w];
  }
  for (size_t c = 0; c < want.average.size(); ++c) {
    differing += got.average[c] != want.average[c];
    if (!channelsAgree(got.average[c], want.average[c]) && ++failures <= 5)
      ADD_FAILURE() << what << ": average of cell " << c << ": " << std::hex << got.average[c] << " against " << want.average[c];
    if (!snormAgree(got.dominant[c], want.dominant[c]) && ++failures <= 5)
      ADD_FAILURE() << what << ": dominant direction of cell " << c << ": " << std::hex << got.dominant[c] << " against "
                    << want.dominant[c];
  }
  EXPECT_EQ(failures, 0u) << what;
  EXPECT_GT(double(nonzero), lit_share * double(want.light.size())) << what;
  EXPECT_LE(double(differing), kMaxDifferingShare * double(want.light.size() + want.average.size())) << what;
}

void expectSameSweep(const SweptGrid& got, const SweptGrid& want, const std::string& what) {
  EXPECT_EQ(got.light_has_direct, want.light_has_direct) << what;
  EXPECT_EQ(got.clear_z, want.clear_z) << what;
  expectSameGrid(got.light, want.light, 0.5, what);
  ASSERT_EQ(got.direct.has_value(), want.direct.has_value()) << what;
  if (want.direct) expectSameGrid(*got.direct, *want.direct, 0.02, what + " (direct)");
}

SweepOptions options(bool bottom_up, bool direct_sun, bool keep_direct) {
  SweepOptions o;
  o.bottom_up = bottom_up;
  o.direct_sun = direct_sun;
  o.keep_direct = keep_direct;
  return o;
}

TEST(SweepOptimised, AgreesWithTheReferenceUnderTheSkyWithEveryOption) {
  const GridShape s{{3.0, -7.0, 1.0}, 1.0, {23, 19, 12}};
  const MaterialGrid m = mixedMaterial(s, 11);
  const SkyInput sky = morningSky();
  for (const bool bottom_up : {false, true})
    for (const bool direct_sun : {false, true})
      for (const bool keep_direct : {false, true}) {
        const SweepOptions o = options(bottom_up, direct_sun, keep_direct);
        const std::string what = "bottom_up " + std::to_string(bottom_up) + " direct_sun " + std::to_string(direct_sun) +
                                 " keep_direct " + std::to_string(keep_direct);
        expectSameSweep(sweep(m, sky, nullptr, o), reference::sweepReference(m, sky, nullptr, o), what);
      }
}

// Under a hill: the levels under the ground are sealed cells, each row in one run that the
// optimised sweep skips, and short runs where the ground's surface is uneven. Every option, and
// a coarse parent.
TEST(SweepOptimised, AgreesWithTheReferenceUnderAHill) {
  const GridShape s{{3.0, -7.0, 1.0}, 1.0, {41, 19, 14}};
  const MaterialGrid m = mixedMaterial(s, 13, 5.f);
  size_t full = 0;
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < s.size.y; ++j)
      for (int i = 0; i < s.size.x; ++i) full += m.density[s.index(i, j, k)] >= 1.f;
  ASSERT_EQ(full, 5 * s.cellCount() / size_t(s.size.z)) << "levels 0-4 are full, so 0-3 are sealed";
  const SkyInput sky = morningSky();
  for (int i = 0; i < 8; ++i) {
    const SweepOptions o = options(i & 1, i & 2, i & 4);
    const SweptGrid got = sweep(m, sky, nullptr, o), want = reference::sweepReference(m, sky, nullptr, o);
    expectSameSweep(got, want, "options " + std::to_string(i));
    // The sealed cells store nothing, on the grid's sides too (the edges' light does not enter the
    // ground there); the ground's top cells, open to the air above, do.
    for (const int x : {0, 20, 40}) {
      EXPECT_EQ(got.light.dominant[s.index(x, 9, 1)], 0u) << "options " << i << " x " << x;
      // Physics' answer inside solid ground: no light at all, in any direction.
      EXPECT_EQ(got.light.average[s.index(x, 9, 1)], 0u) << "options " << i << " x " << x;
      for (int d = 0; d < kDirections; ++d)
        EXPECT_EQ(got.light.light[s.index(x, 9, 1) * kDirections + size_t(d)], 0u) << "options " << i << " x " << x << " direction " << d;
      EXPECT_NE(got.light.dominant[s.index(x, 9, 4)], 0u) << "options " << i << " x " << x;
    }
  }
  const GridShape coarse_s{{-64.0, -64.0, -8.0}, 8.0, {16, 16, 5}};
  const SweptGrid coarse = reference::sweepReference(mixedMaterial(coarse_s, 5), sky, nullptr, options(false, false, true));
  expectSameSweep(sweep(m, sky, &coarse, {}), reference::sweepReference(m, sky, &coarse, {}), "under a coarse grid");
}

TEST(SweepOptimised, AgreesWithTheReferenceUnderACoarseGrid) {
  const SkyInput sky = morningSky();
  const GridShape coarse_s{{-64.0, -64.0, -8.0}, 8.0, {16, 16, 5}};
  const MaterialGrid coarse_m = mixedMaterial(coarse_s, 5);
  const SweptGrid coarse = reference::sweepReference(coarse_m, sky, nullptr, options(false, false, true));
  const SweptGrid coarse_sun = reference::sweepReference(coarse_m, sky, nullptr, options(false, true, false));
  // A fine grid off the coarse cells' centres, reaching past the coarse grid's side.
  const GridShape fine_s{{-13.5, 40.25, -3.0}, 1.0, {30, 27, 14}};
  const MaterialGrid fine_m = mixedMaterial(fine_s, 7);
  for (const bool bottom_up : {false, true}) {
    const SweepOptions o = options(bottom_up, false, false);
    expectSameSweep(sweep(fine_m, sky, &coarse, o), reference::sweepReference(fine_m, sky, &coarse, o),
                    "parent keeps direct, bottom_up " + std::to_string(bottom_up));
    expectSameSweep(sweep(fine_m, sky, &coarse_sun, o), reference::sweepReference(fine_m, sky, &coarse_sun, o),
                    "parent with direct sun, bottom_up " + std::to_string(bottom_up));
  }
}

// FNV-1a (64 bits) over the bytes of every stored word, little-endian: light, average and dominant
// direction, then the direct grid's.
uint64_t hashWords(const Words& words, uint64_t h) {
  for (const uint32_t w : words)
    for (int i = 0; i < 4; ++i) {
      h ^= (w >> (8 * i)) & 0xffu;
      h *= 1099511628211ull;
    }
  return h;
}
uint64_t hashGrid(const SweptGrid& g) {
  uint64_t h = 14695981039346656037ull;
  for (const LightGrid* grid : {&g.light, g.direct ? &*g.direct : nullptr})
    if (grid) h = hashWords(grid->dominant, hashWords(grid->average, hashWords(grid->light, h)));
  return h;
}

// The stored words pinned: the hashes of main's sweep at 8d5a99d (8-lane AVX2 code), which the
// 16-lane AVX-512 code, the AVX2 code and the baseline code all reproduce (docs/sweep.md, third
// round), re-pinned when sealed cells stopped gathering light (docs/sweep.md, "Sealed cells"): on
// this grid 10 of its 5,244 cells changed, each to no light at all (243 light words, 10 averages
// and 10 directions; no other cell's word moved). A change to the model, or to the order of its
// float operations, changes them; re-pin only with the reason and the size of the difference (the
// test above bounds it). They also
// depend on libm's expf, log1pf and sqrtf (glibc here).
TEST(SweepOptimised, StoredWordsArePinnedUnderEveryOption) {
  const GridShape s{{3.0, -7.0, 1.0}, 1.0, {23, 19, 12}};
  const MaterialGrid m = mixedMaterial(s, 11);
  const SkyInput sky = morningSky();
  // Index: bottom_up + 2 direct_sun + 4 keep_direct.
  constexpr uint64_t kPinned[8] = {0x2bf853a8edea2a78ull, 0x4af42ef48e02662eull, 0xb8639457d6e10090ull, 0x5287545391a07704ull,
                                   0xfca2c1f2cc09c212ull, 0x33fd11dceab9a100ull, 0x00c86dd4f461a13aull, 0x6ff763ab94a39166ull};
  for (int i = 0; i < 8; ++i)
    EXPECT_EQ(hashGrid(sweep(m, sky, nullptr, options(i & 1, i & 2, i & 4))), kPinned[i]) << "options " << i;
  const GridShape coarse_s{{-64.0, -64.0, -8.0}, 8.0, {16, 16, 5}};
  const SweptGrid coarse = sweep(mixedMaterial(coarse_s, 5), sky, nullptr, options(false, false, true));
  const GridShape fine_s{{-13.5, 40.25, -3.0}, 1.0, {30, 27, 14}};
  EXPECT_EQ(hashGrid(sweep(mixedMaterial(fine_s, 7), sky, &coarse, {})), 0x7a6c060d7f92d150ull) << "under a coarse grid";
}

// keep_unpacked (the technique's storage=float, a measurement of the stored form): the words do not
// change, each word is its unpacked values packed (so the unpacked values are the ones the sweep
// stored, the sun's unscattered part taken off and clamped as the words have it), and what the
// lookups read from them is within the stored form's bound of what they read from the words:
// each of the 26 values within 2^-6 relative (2^-7 red and green, 2^-6 blue: half an ulp), or
// under the 2^-14 the form flushes to 0, and so the irradiance, a sum of them with weights in
// [0, 1]. Under every option, and in a fine grid whose edges read a coarse grid's unpacked values.
TEST(SweepOptimised, UnpackedValuesAreTheStoredWordsBeforePacking) {
  const GridShape s{{3.0, -7.0, 1.0}, 1.0, {23, 19, 12}};
  const MaterialGrid m = mixedMaterial(s, 11);
  const SkyInput sky = morningSky();
  auto check = [](const LightGrid& words, const LightGrid& kept, const std::string& what) {
    ASSERT_EQ(kept.unpacked.size(), kept.light.size()) << what;
    EXPECT_TRUE(words.unpacked.empty()) << what;
    EXPECT_TRUE(kept.light == words.light && kept.average == words.average && kept.dominant == words.dominant) << what;
    size_t failures = 0, lit = 0;
    for (size_t w = 0; w < kept.light.size(); ++w) {
      lit += kept.light[w] != 0;
      if (packR11G11B10(kept.unpacked[w]) != kept.light[w] && ++failures <= 5)
        ADD_FAILURE() << what << ": value " << w << " packs to " << std::hex << packR11G11B10(kept.unpacked[w]) << ", stored "
                      << kept.light[w];
    }
    EXPECT_EQ(failures, 0u) << what;
    EXPECT_GT(lit, kept.light.size() / 50) << what;
    // Lookups: irradiance on 6 normals at points between the cells' centres. Irradiance is
    // sum_k phi_k max(0, n . m_k), weights at most 1: a value flushed to 0 costs it at most 2^-14.
    constexpr float kFlushed = kDirections * 6.103515625e-05f;
    double worst = 0;
    for (int i = 0; i < 200; ++i) {
      const glm::dvec3 p = kept.shape.origin + glm::dvec3(hash01(91, uint32_t(i)), hash01(92, uint32_t(i)), hash01(93, uint32_t(i))) *
                                                   glm::dvec3(kept.shape.size) * kept.shape.cell_m;
      for (const glm::vec3 n : {glm::vec3(0, 0, 1), glm::vec3(0, 0, -1), glm::vec3(1, 0, 0), glm::vec3(0, -1, 0),
                                glm::normalize(glm::vec3(1, 1, 1)), glm::normalize(glm::vec3(-1, 0.3f, -0.5f))}) {
        const glm::vec3 a = kept.ambient(p, n), b = words.ambient(p, n);
        for (int c = 0; c < 3; ++c) {
          EXPECT_NEAR(b[c], a[c], a[c] / 64.f + kFlushed) << what << " point " << i << " channel " << c;
          if (a[c] > 1e-3f) worst = std::max(worst, std::abs(double(b[c]) / a[c] - 1.0));
        }
      }
    }
    EXPECT_GT(worst, 0.0) << what << ": the words and the unpacked values read the same everywhere";
  };
  for (int i = 0; i < 8; ++i) {
    SweepOptions o = options(i & 1, i & 2, i & 4);
    const SweptGrid words = sweep(m, sky, nullptr, o);
    o.keep_unpacked = true;
    const SweptGrid kept = sweep(m, sky, nullptr, o);
    const std::string what = "options " + std::to_string(i);
    check(words.light, kept.light, what);
    ASSERT_EQ(kept.direct.has_value(), words.direct.has_value()) << what;
    if (kept.direct) check(*words.direct, *kept.direct, what + " (direct)");
  }
  // Edges from a coarse grid's unpacked values (Edges reads LightGrid::cell): the words differ
  // from those read off the coarse words, within the bound.
  const GridShape coarse_s{{-64.0, -64.0, -8.0}, 8.0, {16, 16, 5}};
  SweepOptions co = options(false, false, true);
  const SweptGrid coarse = sweep(mixedMaterial(coarse_s, 5), sky, nullptr, co);
  co.keep_unpacked = true;
  const SweptGrid coarse_kept = sweep(mixedMaterial(coarse_s, 5), sky, nullptr, co);
  const GridShape fine_s{{-13.5, 40.25, -3.0}, 1.0, {30, 27, 14}};
  const MaterialGrid fine_m = mixedMaterial(fine_s, 7);
  SweepOptions fo;
  fo.keep_unpacked = true;
  const SweptGrid fine_kept = sweep(fine_m, sky, &coarse_kept, fo);
  const SweptGrid fine = sweep(fine_m, sky, &coarse, {});
  EXPECT_FALSE(fine_kept.light.light == fine.light.light) << "the edges read the coarse grid's words, not its unpacked values";
  // The edges' light differs by the coarse words' rounding (2^-6), the fine grid's own by its
  // words' (2^-6 again).
  for (int i = 0; i < 200; ++i) {
    const glm::dvec3 p = fine_s.origin + glm::dvec3(hash01(94, uint32_t(i)), hash01(95, uint32_t(i)), hash01(96, uint32_t(i))) *
                                             glm::dvec3(fine_s.size) * fine_s.cell_m;
    const glm::vec3 a = fine_kept.light.ambient(p, {0, 0, 1}), b = fine.light.ambient(p, {0, 0, 1});
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(b[c], a[c], a[c] / 32.f + 2 * kDirections * 6.103515625e-05f) << "under a coarse grid, point " << i << " channel " << c;
  }
}

// sweepInto refills a grid that holds another sweep (other options, another sky, another shape,
// a direct grid or none): afterwards it holds what sweep() returns, to the byte.
TEST(SweepOptimised, SweepIntoAGridInUseGivesTheSameBytesAsAFreshSweep) {
  const GridShape s{{3.0, -7.0, 1.0}, 1.0, {23, 19, 12}};
  const MaterialGrid m = mixedMaterial(s, 11);
  const SkyInput sky = morningSky();
  const Sky evening_sky = Sky::tropicalDefault();
  const SkyInput evening{skyLight(evening_sky, 16.0), sunLight(evening_sky, 16.0, 0.05)};
  SweptGrid kept = sweep(mixedMaterial({{0.0, 0.0, 0.0}, 1.0, {7, 5, 4}}, 3), sky, nullptr, options(false, false, true));
  for (const bool bottom_up : {false, true})
    for (const bool direct_sun : {false, true})
      for (const bool keep_direct : {true, false})
        for (const SkyInput* in : {&evening, &sky}) {
          const SweepOptions o = options(bottom_up, direct_sun, keep_direct);
          const std::string what = "bottom_up " + std::to_string(bottom_up) + " direct_sun " + std::to_string(direct_sun) +
                                   " keep_direct " + std::to_string(keep_direct) + (in == &sky ? " morning" : " evening");
          sweepInto(m, *in, nullptr, o, kept);
          const SweptGrid fresh = sweep(m, *in, nullptr, o);
          EXPECT_EQ(kept.light.light, fresh.light.light) << what;
          EXPECT_EQ(kept.light.average, fresh.light.average) << what;
          EXPECT_EQ(kept.light.dominant, fresh.light.dominant) << what;
          ASSERT_EQ(kept.direct.has_value(), fresh.direct.has_value()) << what;
          if (fresh.direct) {
            EXPECT_EQ(kept.direct->light, fresh.direct->light) << what;
            EXPECT_EQ(kept.direct->average, fresh.direct->average) << what;
          }
          EXPECT_EQ(kept.clear_z, fresh.clear_z) << what;
          EXPECT_EQ(kept.light_has_direct, fresh.light_has_direct) << what;
        }
}

}  // namespace
}  // namespace drtv::sweep

