// The volume: fill against a slow reference, the toroidal scroll against a from-scratch build
// (bit for bit), and the shader's frac-and-remap lookup against world-space trilinear filtering.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "drtv/runtime/lighting_sh.h"
#include "drtv/runtime/volume.h"
#include "runtime_world.h"

namespace drtv::runtime {
namespace {

// A 5 x 5 block of relit, packed sectors around the origin, with one hole (sector (1,1) absent)
// so that fallback texels occur.
ProbeCache makeWorld(uint32_t seed = 1) {
  ProbeCache cache;
  for (int y = -2; y <= 2; ++y)
    for (int x = -2; x <= 2; ++x)
      if (!(x == 1 && y == 1)) {
        EXPECT_TRUE(cache.addSector(testing::makeSector({x, y}, {.no_probe_fraction = 0.2f}, seed)));
      }
  const SkyLighting s = evaluateSky(Sky::tropicalDefault(), 10.0);
  cache.relightAll({s.sky_sh, s.sun_sh, s.sky_direct_sh, {}, kAllComponents});
  cache.setFallback({glm::vec3(0.1f, 0.2f, 0.3f), glm::vec3(0.1f, 0.2f, 0.3f), glm::vec3(0.1f, 0.2f, 0.3f), glm::vec3(0.05f)});
  cache.pack(cache.maxColour() * 1.25f);
  return cache;
}

uint32_t referencePack(const glm::vec4& v, float scale) {
  uint32_t t = 0;
  for (int b = 0; b < 4; ++b) {
    const double x = std::clamp(double(v[b]) / scale, 0.0, 1.0);
    t |= uint32_t(std::floor(x * 255.0 + 0.5)) << (8 * b);
  }
  return t;
}

// The texel of world texel g in nearest mode, straight from the definitions.
uint32_t referenceNearestTexel(const ProbeCache& cache, const VolumeOptions& o, const glm::ivec3& g, int channel) {
  const glm::dvec3 c = (glm::dvec3(g) + 0.5) * glm::dvec3(o.texel_size_m);
  const ProbeRef p = cache.probeAt(c);
  BasisColours colours = p.valid() ? cache.colours(p) : cache.fallback();
  return referencePack({colours[0][channel], colours[1][channel], colours[2][channel], colours[3][channel]}, cache.packedScale());
}

bool sameTexels(const Volume& a, const Volume& b) {
  for (int c = 0; c < 3; ++c)
    if (!std::equal(a.texture(c).begin(), a.texture(c).end(), b.texture(c).begin())) return false;
  return true;
}

// The texels of `v` (every channel) that differ from the reference's nearest fill.
int nearestMismatches(const Volume& v, const ProbeCache& cache, const VolumeOptions& o) {
  const glm::ivec3 n = v.period();
  int mismatches = 0;
  for (int z = 0; z < n.z; ++z)
    for (int y = 0; y < n.y; ++y)
      for (int x = 0; x < n.x; ++x) {
        const glm::ivec3 g = v.origin() + glm::ivec3(x, y, z);
        for (int c = 0; c < 3; ++c) mismatches += v.worldTexel(c, g) != referenceNearestTexel(cache, o, g, c);
      }
  return mismatches;
}

// At an even origin (a texel pair per index cell) and an odd one (each cell split between two
// pairs), and with the storage wrap inside a cell (its first texel in the last stored column, its
// second in column 0): the fill stores a cell's two texels at once where they are adjacent.
TEST(VolumeFill, NearestModeMatchesTheReferenceForEveryTexel) {
  const ProbeCache cache = makeWorld();
  const VolumeOptions o;
  int parities = 0;  // bit 0: an even origin in x was filled, bit 1: an odd one
  bool wrap_in_cell = false;
  for (const glm::dvec3 camera : {glm::dvec3(17.0, -23.0, 12.0), glm::dvec3(19.0, -21.0, 12.0), glm::dvec3(150.0, -23.0, 12.0)}) {
    Volume v(o);
    v.rebuild(v.originFor(camera), cache);
    const glm::ivec3 n = v.period();
    parities |= 1 << (v.origin().x & 1);
    for (int x = 0; x + 1 < n.x; ++x) {
      const int g = v.origin().x + x;  // 2 m texels in 4 m cells: g and g + 1 share a cell when g is even
      wrap_in_cell |= (g & 1) == 0 && ((g % n.x) + n.x) % n.x == n.x - 1;
    }
    EXPECT_EQ(nearestMismatches(v, cache, o), 0) << "origin " << v.origin().x << ", " << v.origin().y;
    EXPECT_EQ(v.texture(0).size(), 147456u);  // the talk's 96x96x16
  }
  EXPECT_EQ(parities, 3);
  EXPECT_TRUE(wrap_in_cell);
}

// Texels of other sizes: four in a cell along x and y (two pairs of one cell side by side), one in
// a cell (no pair), and 3 m (cells of one, two or no pair in turn); and a 48-texel volume whose
// storage wraps between two pairs of consecutive cells in one sector (texels 93 and 94 of its
// period of 47, world x 186-190 m), where the pairs are consecutive in the world but not in storage.
TEST(VolumeFill, NearestModeMatchesTheReferenceAtOtherTexelSizes) {
  const ProbeCache cache = makeWorld();
  const std::pair<VolumeOptions, glm::dvec3> cases[] = {
      {{.size = {64, 64, 8}, .texel_size_m = {1.f, 1.f, 4.f}}, {17.0, -23.0, 12.0}},
      {{.size = {64, 64, 8}, .texel_size_m = {4.f, 4.f, 4.f}}, {17.0, -23.0, 12.0}},
      {{.size = {64, 64, 8}, .texel_size_m = {3.f, 3.f, 4.f}}, {17.0, -23.0, 12.0}},
      {{.size = {48, 48, 8}}, {180.0, -23.0, 12.0}},
  };
  for (const auto& [o, camera] : cases) {
    Volume v(o);
    v.rebuild(v.originFor(camera), cache);
    EXPECT_EQ(nearestMismatches(v, cache, o), 0) << "texels of " << o.texel_size_m.x << " m, " << o.size.x << " wide";
    if (o.size.x == 48) {
      EXPECT_TRUE(v.origin().x <= 92 && v.origin().x + v.period().x > 95) << v.origin().x;
    }
  }
}

// The texels of `blurred` that differ from the talk's PC-path blur of `plain` (same origin),
// straight from its definition: 27 taps of [1 2 1] (x) [1 2 1] (x) [1 2 1] over the unblurred
// texels, neighbours clamped into the volume, each byte (sum + 32) / 64.
int blurMismatches(const Volume& plain, const Volume& blurred) {
  const glm::ivec3 n = plain.period(), o = plain.origin();
  EXPECT_EQ(blurred.origin(), o);
  int mismatches = 0;
  for (int c = 0; c < 3; ++c)
    for (int z = 0; z < n.z; ++z)
      for (int y = 0; y < n.y; ++y)
        for (int x = 0; x < n.x; ++x) {
          uint32_t want = 0;
          for (int byte = 0; byte < 4; ++byte) {
            uint32_t sum = 0;
            for (int dz = -1; dz <= 1; ++dz)
              for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                  const glm::ivec3 q = glm::clamp(glm::ivec3(x + dx, y + dy, z + dz), glm::ivec3(0), n - 1);
                  const uint32_t w = (2 - std::abs(dx)) * (2 - std::abs(dy)) * (2 - std::abs(dz));
                  sum += w * ((plain.worldTexel(c, o + q) >> (8 * byte)) & 0xff);
                }
            want |= ((sum + 32) / 64) << (8 * byte);
          }
          mismatches += blurred.worldTexel(c, o + glm::ivec3(x, y, z)) != want;
        }
  return mismatches;
}

// The talk's PC-path blur, straight from its definition: 27 taps of [1 2 1] (x) [1 2 1] (x) [1 2 1]
// over the unblurred texels, neighbours clamped into the volume, each byte (sum + 32) / 64. Checked
// after a scroll too, so that the storage wrap is exercised.
// A volume 5 texels wide in x is blurred by the thin-x path alone (Volume::blurThinX), rebuilds
// included: it is checked against the definition too.
TEST(VolumeFill, BlurMatchesTheTwentySevenTapDefinitionForEveryTexel) {
  const ProbeCache cache = makeWorld();
  for (const glm::ivec3 size : {glm::ivec3(96, 96, 16), glm::ivec3(5, 13, 7)}) {
  SCOPED_TRACE(size.x);
  VolumeOptions plain_o, blur_o;
  plain_o.size = blur_o.size = size;
  blur_o.blur = true;
  Volume plain(plain_o), blurred(blur_o);
  const glm::ivec3 origin = plain.originFor({17.0, -23.0, 12.0});
  for (const glm::ivec3 move : {glm::ivec3(0), glm::ivec3(5, -7, 3), glm::ivec3(-1, 2, 0)}) {
    plain.rebuild(origin, cache);
    blurred.rebuild(origin - move, cache);
    blurred.scrollTo(origin, cache);
    EXPECT_EQ(blurMismatches(plain, blurred), 0) << "after a move of " << move.x << "," << move.y << "," << move.z;
  }
  }
}

// Boxes of whole rows are blurred in storage order (Volume::blurWholeRows), which patches the
// columns whose storage neighbours are not their neighbours in the volume: storage column 0, the
// last, and the range's clamped first and last columns. Every storage position of the range's
// first column, on volumes just wider than the thin-x path's, rebuilt and after y and z scrolls
// (which blur whole-row slabs): against the definition, and the duplicated boundary.
TEST(VolumeFill, WholeRowBlurMatchesTheDefinitionAtEveryStoragePhase) {
  const ProbeCache cache = makeWorld();
  for (const glm::ivec3 size : {glm::ivec3(6, 7, 4), glm::ivec3(9, 5, 6)}) {
    VolumeOptions plain_o, blur_o;
    plain_o.size = blur_o.size = size;
    blur_o.blur = true;
    Volume plain(plain_o), blurred(blur_o);
    const glm::ivec3 n = plain.period(), p = plain.size();
    for (int phase = 0; phase < n.x; ++phase)
      for (const glm::ivec3 move : {glm::ivec3(0), glm::ivec3(0, 1, 0), glm::ivec3(0, -2, 1), glm::ivec3(0, 0, -1)}) {
        SCOPED_TRACE(::testing::Message() << "size " << size.x << " phase " << phase << " move " << move.y << "," << move.z);
        const glm::ivec3 origin(7 * n.x + phase, -3, 2);
        plain.rebuild(origin, cache);
        blurred.rebuild(origin - move, cache);
        blurred.scrollTo(origin, cache);
        EXPECT_EQ(blurMismatches(plain, blurred), 0);
        int mirror_mismatches = 0;
        for (int c = 0; c < 3; ++c)
          for (int z = 0; z < p.z; ++z)
            for (int y = 0; y < p.y; ++y)
              for (int x = 0; x < p.x; ++x)
                mirror_mismatches += blurred.physicalTexel(c, {x, y, z}) != blurred.physicalTexel(c, {x % n.x, y % n.y, z % n.z});
        EXPECT_EQ(mirror_mismatches, 0);
      }
  }
}

// With 2 m texels the blur keeps the unblurred texels once per index cell, stored modulo a
// period of cells (P = 56 in x for 95 texels, 4 in y for 5) that the covered range crosses at
// every cell phase; whole-row boxes are blurred from runs of cells between the storage wraps,
// with the runs' ends patched. Origins over two periods of cells in x (every third texel) and y,
// odd and even (a cell split at the range's edge), rebuilt and after x, y and z scrolls: against
// the definition.
TEST(VolumeFill, BlurFromCellsMatchesTheDefinitionAtEveryCellPhase) {
  const ProbeCache cache = makeWorld();
  VolumeOptions plain_o, blur_o;
  plain_o.size = blur_o.size = {96, 6, 4};
  blur_o.blur = true;
  Volume plain(plain_o), blurred(blur_o);
  int checked = 0;
  for (int oy = 0; oy < 8; ++oy)
    for (int ox = 0; ox < 112; ox += oy < 2 ? 3 : 13) {
      const glm::ivec3 origin(ox - 40, oy - 20, 1);
      const glm::ivec3 move = ox % 3 == 0 ? glm::ivec3(0) : (ox % 3 == 1 ? glm::ivec3(1, 0, 0) : glm::ivec3(0, -1, 1));
      plain.rebuild(origin, cache);
      blurred.rebuild(origin - move, cache);
      blurred.scrollTo(origin, cache);
      const int mismatches = blurMismatches(plain, blurred);
      EXPECT_EQ(mismatches, 0) << "origin " << origin.x << "," << origin.y << " move " << move.x << "," << move.y << "," << move.z;
      ++checked;
      if (mismatches != 0) return;
    }
  EXPECT_GT(checked, 100);
}

// The blur's unblurred copy, with 2 m texels, is kept per index cell: a quarter of the texels'
// bytes (and a little for the cells' storage period), where a copy of every texel doubled them.
TEST(VolumeFill, BlurWithTwoMetreTexelsAddsAQuarterOfTheTexelsBytes) {
  const VolumeOptions plain_o;
  VolumeOptions blur_o, blur4_o;
  blur_o.blur = blur4_o.blur = true;
  blur4_o.texel_size_m = {4.f, 4.f, 4.f};
  const Volume plain(plain_o), blurred(blur_o), blurred4(blur4_o);
  EXPECT_EQ(plain.bytes(), 3u * 96 * 96 * 16 * 4);
  EXPECT_LE(blurred.bytes(), plain.bytes() + plain.bytes() * 3 / 10);
  EXPECT_GT(blurred.bytes(), plain.bytes() + plain.bytes() / 4);
  EXPECT_EQ(blurred4.bytes(), 2 * plain.bytes());  // 4 m texels are whole cells: a copy of each
}

TEST(VolumeFill, DuplicatedBoundaryTexelsMirrorTheFirstLayerOnEveryAxis) {
  const ProbeCache cache = makeWorld();
  for (bool blur : {false, true}) {
    VolumeOptions o;
    o.blur = blur;
    Volume v(o);
    v.rebuild(v.originFor({0.0, 0.0, 10.0}), cache);
    v.scrollTo(v.origin() + glm::ivec3(7, -3, 2), cache);
    const glm::ivec3 p = v.size(), n = v.period();
    for (int c = 0; c < 3; ++c)
      for (int z = 0; z < p.z; ++z)
        for (int y = 0; y < p.y; ++y)
          for (int x = 0; x < p.x; ++x)
            ASSERT_EQ(v.physicalTexel(c, {x, y, z}), v.physicalTexel(c, {x % n.x, y % n.y, z % n.z}))
                << x << " " << y << " " << z << (blur ? " blurred" : "");
  }
}

struct ScrollCase {
  VolumeOptions options;
  const char* name;
};

class VolumeScroll : public ::testing::TestWithParam<ScrollCase> {};

TEST_P(VolumeScroll, AnySequenceOfMovesEqualsAFromScratchBuildBitForBit) {
  const ProbeCache cache = makeWorld(3);
  const VolumeOptions o = GetParam().options;
  Volume scrolled(o), fresh(o);
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> small(-3, 3), pick(0, 9), axis(0, 2);
  glm::ivec3 origin = scrolled.originFor({5.0, 7.0, 11.0});
  scrolled.rebuild(origin, cache);
  const glm::ivec3 n = scrolled.period();
  for (int step = 0; step < 60; ++step) {
    glm::ivec3 d(0);
    switch (pick(rng)) {
      case 0: d[axis(rng)] = n[0] + 5; break;                              // teleport
      case 1: d = glm::ivec3(small(rng), small(rng), small(rng)) * 7; break;  // many texels, all axes
      case 2: d[axis(rng)] = n[axis(rng)] - 1; break;                      // just under a period
      case 3: d[axis(rng)] = -1; break;
      default: d = glm::ivec3(small(rng), small(rng), small(rng)); break;  // several axes at once
    }
    origin += d;
    // Keep the walk over the synthetic world (and the hole) most of the time.
    origin = glm::clamp(origin, glm::ivec3(-90, -90, -6), glm::ivec3(40, 40, 8));
    scrolled.scrollTo(origin, cache);
    fresh.rebuild(origin, cache);
    ASSERT_TRUE(sameTexels(scrolled, fresh)) << GetParam().name << " after step " << step << " by (" << d.x << "," << d.y << ","
                                             << d.z << ")";
  }
}

INSTANTIATE_TEST_SUITE_P(
    Modes, VolumeScroll,
    ::testing::Values(ScrollCase{VolumeOptions{}, "nearest 96x96x16"},
                      ScrollCase{VolumeOptions{.size = {13, 9, 5}, .texel_size_m = {3.f, 2.5f, 1.f}}, "nearest small odd"},
                      ScrollCase{VolumeOptions{.fill = FillMode::kSmooth}, "smooth"},
                      ScrollCase{VolumeOptions{.blur = true}, "nearest blurred"},
                      ScrollCase{VolumeOptions{.size = {11, 12, 6}, .fill = FillMode::kSmooth, .blur = true}, "smooth blurred small"}),
    [](const auto& info) {
      std::string s = info.param.name;
      for (char& ch : s)
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      return s;
    });

TEST(VolumeScrollCost, OneTexelMoveComputesOneSlab) {
  const ProbeCache cache = makeWorld();
  Volume v;
  v.rebuild(v.originFor({0.0, 0.0, 10.0}), cache);
  const uint64_t before = v.texelsFilled();
  v.scrollTo(v.origin() + glm::ivec3(1, 0, 0), cache);
  EXPECT_EQ(v.texelsFilled() - before, uint64_t(v.period().y) * v.period().z);
  const uint64_t before2 = v.texelsFilled();
  v.scrollTo(v.origin() + glm::ivec3(0, -1, 1), cache);
  const glm::ivec3 n = v.period();
  EXPECT_EQ(v.texelsFilled() - before2, uint64_t(n.x) * n.z + uint64_t(n.x) * (n.y - 1));
}

TEST(VolumeFill, SmoothModeIsSmootherThanNearest) {
  // Sum of squared differences between horizontally adjacent texels. Linear interpolation has
  // the same total variation as nearest sampling but spreads each jump d over two 2 m texels:
  // 2 (d/2)^2 = d^2 / 2 instead of d^2, so the smooth fill must come out well below.
  const ProbeCache cache = makeWorld();
  auto roughness = [&](FillMode mode) {
    Volume v({.fill = mode});
    v.rebuild(v.originFor({0.0, 0.0, 12.0}), cache);
    double sum = 0.0;
    const glm::ivec3 n = v.period();
    for (int z = 0; z < n.z; ++z)
      for (int y = 0; y < n.y; ++y)
        for (int x = 0; x + 1 < n.x; ++x) {
          const uint32_t a = v.worldTexel(1, v.origin() + glm::ivec3(x, y, z)), b = v.worldTexel(1, v.origin() + glm::ivec3(x + 1, y, z));
          for (int k = 0; k < 4; ++k) {
            const double d = int(a >> (8 * k) & 0xff) - int(b >> (8 * k) & 0xff);
            sum += d * d;
          }
        }
    return sum;
  };
  EXPECT_LT(roughness(FillMode::kSmooth), 0.8 * roughness(FillMode::kNearest));
}

// World-space trilinear filtering between texel centres: what the frac/remap/clamp path must equal.
BasisColours referenceFetch(const Volume& v, const glm::dvec3& p) {
  const glm::dvec3 a = p / glm::dvec3(v.options().texel_size_m) - 0.5;
  const glm::dvec3 f = a - glm::floor(a);
  const glm::ivec3 g0(glm::floor(a));
  BasisColours out{};
  for (int c = 0; c < 3; ++c)
    for (int corner = 0; corner < 8; ++corner) {
      const glm::ivec3 k(corner & 1, corner >> 1 & 1, corner >> 2);
      const double w = (k.x ? f.x : 1 - f.x) * (k.y ? f.y : 1 - f.y) * (k.z ? f.z : 1 - f.z);
      const uint32_t t = v.worldTexel(c, g0 + k);
      for (int b = 0; b < 4; ++b) out[b][c] += float(w * double(t >> (8 * b) & 0xff) / 255.0 * v.hdrScale());
    }
  return out;
}

// The shader computes uv in float from a camera-relative position: ~1e-6 of the 190 m extent,
// i.e. ~1e-4 of a texel, moves the filter weights by that much of one byte step.
constexpr float kFetchRelTol = 2e-4f;

TEST(SampleVolume, FracWrapAndRemapEqualWorldSpaceTrilinearFilteringAcrossTheSeams) {
  const ProbeCache cache = makeWorld();
  for (const VolumeOptions& o : {VolumeOptions{}, VolumeOptions{.size = {13, 9, 5}, .texel_size_m = {3.f, 2.5f, 1.f}}}) {
    Volume v(o);
    v.rebuild(v.originFor({33.0, -41.0, 12.0}), cache);
    v.scrollTo(v.origin() + glm::ivec3(5, 3, 1), cache);  // seams now inside the range
    std::mt19937 rng(2);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const glm::dvec3 ts(o.texel_size_m), n(v.period()), org(v.origin());
    for (int i = 0; i < 3000; ++i) {
      const glm::dvec3 t(0.5 + u(rng) * (n.x - 1.0), 0.5 + u(rng) * (n.y - 1.0), 0.5 + u(rng) * (n.z - 1.0));
      const glm::dvec3 p = (org + t) * ts;
      const BasisColours got = fetchVolume(v, p), want = referenceFetch(v, p);
      for (int b = 0; b < 4; ++b)
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(got[b][c], want[b][c], kFetchRelTol * v.hdrScale()) << "sample " << i;
    }
  }
}

TEST(SampleVolume, AmbientIsTheShadingWeightsTimesTheFetchedBasisColours) {
  const ProbeCache cache = makeWorld();
  Volume v;
  v.rebuild(v.originFor({0.0, 0.0, 12.0}), cache);
  const glm::dvec3 p(3.3, -7.1, 12.2);
  for (const glm::vec3& n : {glm::vec3(0, 0, 1), glm::vec3(0, 0, -1), glm::normalize(glm::vec3(1, -2, 0.5f))}) {
    const float offset = 1.f;
    const BasisColours f = fetchVolume(v, p + glm::dvec3(n) * double(offset));
    const glm::vec4 w = sh::shadingWeights(n);
    const glm::vec3 want = w.x * f[0] + w.y * f[1] + w.z * f[2] + w.w * f[3];
    const glm::vec3 got = sampleVolume(v, p, n, offset);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], kFetchRelTol * v.hdrScale());
  }
}

TEST(VolumeCoverage, IsOneInsideAndFadesToZeroHalfATexelFromTheEdge) {
  const ProbeCache cache = makeWorld();
  Volume v;
  v.rebuild({0, 0, 0}, cache);
  const glm::dvec3 ts(v.options().texel_size_m);
  EXPECT_EQ(v.coverage(glm::dvec3(47.5, 47.5, 7.5) * ts, 2.f), 1.f);
  EXPECT_EQ(v.coverage(glm::dvec3(0.5, 47.5, 7.5) * ts, 2.f), 0.f);
  EXPECT_NEAR(v.coverage(glm::dvec3(1.5, 47.5, 7.5) * ts, 2.f), 0.5f, 1e-6f);
  EXPECT_EQ(v.coverage(glm::dvec3(-1.0, 47.5, 7.5) * ts, 2.f), 0.f);
  EXPECT_EQ(v.coverage(glm::dvec3(1e300, 0, 0), 2.f), 0.f);
  EXPECT_EQ(v.coverage(glm::dvec3(std::nan(""), 0, 0), 2.f), 0.f);
}

TEST(VolumeShaderConstants, PutTexelCentresOnTexelCentres) {
  const ProbeCache cache = makeWorld();
  Volume v;
  v.rebuild({-50, 13, -3}, cache);
  const VolumeShaderConstants k = v.shaderConstants();
  const glm::dvec3 ts(v.options().texel_size_m);
  for (const glm::ivec3& g : {glm::ivec3(-50, 13, -3), glm::ivec3(-4, 60, 5), glm::ivec3(44, 107, 11)}) {
    const glm::vec3 ws = glm::vec3((glm::dvec3(g) + 0.5) * ts - k.snapped_camera);
    const glm::vec3 uv = glm::fract(ws * k.uv_scale + 0.5f + k.wrap_offset) * k.uv_remap_scale + k.uv_remap_bias;
    const glm::vec3 texel = uv * glm::vec3(v.size()) - 0.5f;
    const glm::ivec3 n = v.period();
    const glm::vec3 want(float(((g.x % n.x) + n.x) % n.x), float(((g.y % n.y) + n.y) % n.y), float(((g.z % n.z) + n.z) % n.z));
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(texel[a], want[a], 1e-3f);
  }
}

}  // namespace
}  // namespace drtv::runtime
