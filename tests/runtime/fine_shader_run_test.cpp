// The fine level near surfaces in the shaders (issue 35): runtime/shaders/fine.glsl, and fine.hlsl
// through glslang's HLSL front end, as Vulkan compute (fine_pass.h) over the level packed from a
// baked town block (runtime/fine_shader.h), compared with the C++ lookup they mirror
// (ProbeCache::fineLookup, shaded as Runtime::ambient shades it, times the box's fade). Without a
// GPU the device is lavapipe.
//
// The archive: a 128 m town of courtyard blocks of four storeys (worlds/town.h), baked at draft
// quality, written by baker::bake and read back, relit at 15:00 as `drtv query` sets up a runtime.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

#include <gtest/gtest.h>

#include "ambient_pass.h"
#include "baked_archive.h"
#include "drtv/baker/bake.h"
#include "drtv/formats/probe.h"
#include "drtv/runtime/fine_shader.h"
#include "drtv/runtime/runtime.h"
#include "drtv/worlds/town.h"
#include "fine_pass.h"
#include "vulkan_compute.h"

namespace drtv::testing {
namespace {


constexpr int kPoints = 6000;
constexpr double kHour = 15.0;

using Baked = BakedArchive;

Baked bakeTown(Representation representation) {
  worlds::TownOptions o;
  o.size_m = 128;
  o.min_storeys = o.max_storeys = 4;
  o.courtyard_fraction = 1, o.pair_fraction = 0, o.square_fraction = 0;
  o.lit_room_fraction = 0;
  auto world = worlds::generateTown(o);
  EXPECT_TRUE(world.has_value()) << (world ? "" : world.error().message);
  if (!world) return {};
  baker::BakeOptions options;
  options.quality = baker::Quality::kDraft;
  options.representation = representation;
  return bakeArchive(*world, "town", options);
}
const Baked& bakedTown(Representation representation) {
  static BakedPerRepresentation baked(bakeTown);
  return baked(representation);
}

std::unique_ptr<runtime::Runtime> relit(const Baked& b, const glm::dvec3& camera) { return relitArchive(b, kHour, camera); }

// The camera: over the block's courtyard, at its second storey.
constexpr glm::dvec3 kCamera{0.0, 0.0, 6.0};

struct TestPoint {
  glm::dvec3 position;
  glm::vec3 normal;
};

// Points around the packed probes (within 3 m of one: inside the rooms and corridors, through
// walls and floors), some across the box's faces (the fade), some anywhere in and around the box.
std::vector<TestPoint> makePoints(const runtime::FineShaderData& level, uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const runtime::FineShaderConstants& k = level.constants;
  const glm::dvec3 lo(k.box_min[0], k.box_min[1], k.box_min[2]), hi(k.box_max[0], k.box_max[1], k.box_max[2]);
  std::vector<TestPoint> out;
  for (int i = 0; i < kPoints; ++i) {
    glm::dvec3 p;
    const double kind = u(rng);
    if (kind < 0.8 && !level.probes.empty()) {
      const runtime::FineShaderProbe& q = level.probes[rng() % level.probes.size()];
      p = glm::dvec3(q.position[0], q.position[1], q.position[2]) + 3.0 * (2.0 * glm::dvec3(u(rng), u(rng), u(rng)) - 1.0);
    } else {
      for (int a = 0; a < 3; ++a) p[a] = lo[a] - 4.0 + u(rng) * (hi[a] - lo[a] + 8.0);
      if (kind < 0.9) {  // one axis within 6 m of a face: the fade
        const int a = int(rng() % 3);
        p[a] = (rng() % 2 ? lo[a] : hi[a]) + 12.0 * u(rng) - 6.0;
      }
    }
    out.push_back({p, randomUnitNormal(rng, u)});
  }
  return out;
}

struct Comparison {
  size_t points = 0, weighted = 0, faded = 0, failures = 0;
  double max_weight_diff = 0.0, max_colour_rel = 0.0;
  std::string first_failure;
};

// Per point: the weight within kWeightTolerance and, where the C++ weight is positive, each
// channel within kColourTolerance of the C++ colour (relative to the point's largest channel,
// at least kColourFloor). The two sides sum the same probes in another order, in float against
// double: lavapipe stays within 6e-5 of both (2026-12-07). A probe whose visibility lay within float
// noise of the floor (min_visibility) could be in on one side and out on the other, moving the
// weight by up to 0.1^3 / 0.04 / full_weight = 0.08; none of these points has one, and a point
// that had would fail here as a wrong shader would.
constexpr double kWeightTolerance = 1e-3, kColourTolerance = 1e-3, kColourFloor = 1e-2;

Comparison compare(ShaderLanguage language, Representation representation, void (*perturb)(runtime::FineShaderData&) = nullptr) {
  Comparison out;
  const Baked& baked = bakedTown(representation);
  if (baked.sectors.empty()) {
    ADD_FAILURE() << "no baked sectors";
    return out;
  }
  auto vk = VulkanCompute::create();
  if (!vk) {
    ADD_FAILURE() << vk.error().message;
    return out;
  }
  std::unique_ptr<runtime::Runtime> rt = relit(baked, kCamera);
  const runtime::FineShaderOptions options;
  runtime::FineShaderData level = runtime::packFineLevel(rt->cache(), kCamera, options);
  EXPECT_GT(level.probes.size(), 300u) << "the block's covered probes";
  const std::vector<TestPoint> points = makePoints(level, 7u);
  if (perturb) perturb(level);
  auto pass = FinePass::create(**vk, DRTV_SOURCE_DIR, language, representation, level, points.size());
  if (!pass) {
    ADD_FAILURE() << pass.error().message;
    return out;
  }
  std::vector<AmbientPoint> in;
  for (const TestPoint& p : points) in.push_back({glm::vec4(glm::vec3(p.position), 0.f), glm::vec4(p.normal, 0.f)});
  auto gpu = (*pass)->run(in);
  if (!gpu) {
    ADD_FAILURE() << gpu.error().message;
    return out;
  }
  for (size_t i = 0; i < points.size(); ++i) {
    const TestPoint& p = points[i];
    const runtime::FineSample f = rt->cache().fineLookup(p.position, p.normal, options.lookup);
    const glm::dvec3 at = p.position + glm::dvec3(p.normal) * double(options.lookup.normal_bias_m);
    const float fade = runtime::fineShaderFade(level.constants, at);
    const double weight = double(f.weight) * double(fade);
    const glm::vec3 colour = weight > 0.0 ? runtime::shade(representation, f.colours, p.normal) : glm::vec3(0.f);
    const glm::vec4 g = (*gpu)[i];
    ++out.points;
    out.weighted += weight > 0.0;
    out.faded += fade > 0.f && fade < 1.f && weight > 0.0;
    const double dw = std::abs(double(g.w) - weight);
    out.max_weight_diff = std::max(out.max_weight_diff, dw);
    const double scale = std::max({kColourFloor, double(colour.x), double(colour.y), double(colour.z)});
    double dc = 0.0;
    if (weight > 0.0)
      for (int c = 0; c < 3; ++c) dc = std::max(dc, std::abs(double(g[c]) - double(colour[c])) / scale);
    out.max_colour_rel = std::max(out.max_colour_rel, dc);
    if (!(dw <= kWeightTolerance) || !(dc <= kColourTolerance)) {
      if (out.failures++ == 0) {
        char line[320];
        std::snprintf(line, sizeof line,
                      "point %zu at (%.3f, %.3f, %.3f) normal (%.3f, %.3f, %.3f): shader (%.5g, %.5g, %.5g) weight %.5g, C++ "
                      "(%.5g, %.5g, %.5g) weight %.5g (%d probes, fade %.3f)",
                      i, p.position.x, p.position.y, p.position.z, p.normal.x, p.normal.y, p.normal.z, g.x, g.y, g.z, g.w, colour.x,
                      colour.y, colour.z, weight, f.probes, fade);
        out.first_failure = line;
      }
    }
  }
  std::printf("[ fine shader ] %s, %s on %s: %zu packed probes, %zu cells, %.2f MB; %zu points (%zu weighted, %zu faded): largest "
              "weight difference %.3g, largest colour difference %.3g of the point's colour, %zu over\n",
              shaderLanguageName(language), representation == Representation::kShL1 ? "sh-l1" : "fc3",
              (*vk)->deviceDescription().c_str(), level.probes.size(),
              size_t(level.constants.cells[0]) * size_t(level.constants.cells[1]) * size_t(level.constants.cells[2]),
              double(level.bytes()) / 1e6, out.points, out.weighted, out.faded, out.max_weight_diff, out.max_colour_rel, out.failures);
  return out;
}

void expectAgreement(ShaderLanguage language, Representation representation) {
  const Comparison c = compare(language, representation);
  if (c.points == 0) return;  // compare said why
  EXPECT_GE(c.weighted, size_t(kPoints) / 2) << "too few points the fine level lights";
  EXPECT_GE(c.faded, 20u) << "too few points in the fade at the box's faces";
  EXPECT_EQ(c.failures, 0u) << c.first_failure;
}

TEST(FineShaderRun, GlslFineLevelMatchesFineLookupOnABakedTown) { expectAgreement(ShaderLanguage::kGlsl, Representation::kFc3); }
TEST(FineShaderRun, HlslFineLevelMatchesFineLookupOnABakedTown) { expectAgreement(ShaderLanguage::kHlsl, Representation::kFc3); }
TEST(FineShaderRun, GlslShL1FineLevelMatchesFineLookup) { expectAgreement(ShaderLanguage::kGlsl, Representation::kShL1); }
TEST(FineShaderRun, HlslShL1FineLevelMatchesFineLookup) { expectAgreement(ShaderLanguage::kHlsl, Representation::kShL1); }

// The comparison can fail: a radius 20 % short, or the normal bias doubled, in the shader's
// constants alone.
TEST(FineShaderRun, ComparisonFailsWhenTheShaderGetsWrongConstants) {
  const Comparison radius =
      compare(ShaderLanguage::kGlsl, Representation::kFc3, [](runtime::FineShaderData& l) { l.constants.radius_m *= 0.8f; });
  EXPECT_GT(radius.failures, 100u);
  const Comparison bias =
      compare(ShaderLanguage::kGlsl, Representation::kFc3, [](runtime::FineShaderData& l) { l.constants.normal_bias_m *= 2.f; });
  EXPECT_GT(bias.failures, 100u);
}

// The cells list every probe within the radius of any point of theirs (what lets the shader read
// one cell), and the level with the volumes stays within issue 35's 8 MB of GPU memory.
TEST(FineShaderPack, EachCellListsEveryProbeInReachOfItsPointsWithinTheBudget) {
  const Baked& baked = bakedTown(Representation::kFc3);
  ASSERT_FALSE(baked.sectors.empty());
  std::unique_ptr<runtime::Runtime> rt = relit(baked, kCamera);
  const runtime::FineShaderOptions options;
  const runtime::FineShaderData level = runtime::packFineLevel(rt->cache(), kCamera, options);
  const runtime::FineShaderConstants& k = level.constants;
  ASSERT_GT(level.probes.size(), 300u);
  EXPECT_EQ(level.visibility.size(), level.probes.size() * kVisValuesPerProbe / 4);
  const double R = options.lookup.radius_m;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  size_t checked = 0;
  for (int i = 0; i < 20000; ++i) {
    glm::dvec3 at;
    for (int a = 0; a < 3; ++a) at[a] = double(k.box_min[a]) + u(rng) * double(k.box_max[a] - k.box_min[a]);
    const glm::ivec3 c = glm::clamp(glm::ivec3(glm::floor((at - glm::dvec3(k.box_min[0], k.box_min[1], k.box_min[2])) / double(k.cell_m))),
                                    glm::ivec3(0), glm::ivec3(k.cells[0], k.cells[1], k.cells[2]) - 1);
    const size_t cell = size_t(c.x) + size_t(k.cells[0]) * (size_t(c.y) + size_t(k.cells[1]) * size_t(c.z));
    const uint32_t first = level.cells[2 * cell], count = level.cells[2 * cell + 1];
    ASSERT_LE(size_t(first) + count, level.cells.size());
    const std::span<const uint32_t> list(level.cells.data() + first, count);
    for (uint32_t p = 0; p < level.probes.size(); ++p) {
      const glm::dvec3 q(level.probes[p].position[0], level.probes[p].position[1], level.probes[p].position[2]);
      if (glm::distance(q, at) < R) {
        EXPECT_NE(std::find(list.begin(), list.end(), p), list.end()) << "probe " << p << " not listed for the cell of a point within reach";
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 10000u);
  const glm::ivec3 size = rt->volume().read().volume().size();
  const size_t volume_bytes = 3 * size_t(size.x) * size_t(size.y) * size_t(size.z) * 4;
  EXPECT_LE(volume_bytes + level.bytes(), 8u * 1000u * 1000u) << "volumes " << volume_bytes << " B, fine level " << level.bytes() << " B";
  // No level without a finite camera or with the lookup off: every cell lists nothing.
  runtime::FineShaderOptions off;
  off.lookup.enabled = false;
  const runtime::FineShaderData none = runtime::packFineLevel(rt->cache(), kCamera, off);
  EXPECT_TRUE(none.probes.empty());
  EXPECT_TRUE(std::all_of(none.cells.begin(), none.cells.end(), [](uint32_t v) { return v == 0; }));
  EXPECT_TRUE(runtime::packFineLevel(rt->cache(), glm::dvec3(NAN), options).probes.empty());
}

// RuntimeOptions::fine_shader: an update packs the level around the camera, the same as
// packFineLevel with the runtime's lookup, whenever the box's corner, the colours or the resident
// sectors changed, and only then; a reader keeps the level it took across the next update.
TEST(FineShaderPack, TheRuntimePacksTheLevelWhenAskedAndOnlyWhenItChanges) {
  const Baked& baked = bakedTown(Representation::kFc3);
  ASSERT_FALSE(baked.sectors.empty());
  EXPECT_EQ(relit(baked, kCamera)->fineLevel(), nullptr) << "not asked for";
  runtime::RuntimeOptions ro = runtime::optionsForEffects(baked.manifest.effects);
  ro.fine_shader = runtime::FineShaderOptions{};
  auto made = runtime::runtimeForArchive(baked.manifest, ro, kHour);
  ASSERT_TRUE(made.has_value());
  std::unique_ptr<runtime::Runtime> rt = std::move(*made);
  EXPECT_EQ(rt->fineLevel(), nullptr) << "before the first update";
  for (const Sector& s : baked.sectors) ASSERT_TRUE(rt->addSector(s).has_value());
  rt->update(kCamera);
  const std::shared_ptr<const runtime::FineShaderData> level = rt->fineLevel();
  ASSERT_NE(level, nullptr);
  runtime::FineShaderOptions o;
  o.lookup = rt->options().fine;
  const runtime::FineShaderData direct = runtime::packFineLevel(rt->cache(), kCamera, o);
  ASSERT_GT(direct.probes.size(), 300u);
  ASSERT_EQ(level->probes.size(), direct.probes.size());
  EXPECT_EQ(std::memcmp(level->probes.data(), direct.probes.data(), direct.probes.size() * sizeof(runtime::FineShaderProbe)), 0);
  EXPECT_EQ(level->visibility, direct.visibility);
  EXPECT_EQ(level->cells, direct.cells);
  EXPECT_EQ(std::memcmp(&level->constants, &direct.constants, sizeof direct.constants), 0);
  rt->update(kCamera + glm::dvec3(40.0, 0.0, 0.0));
  const std::shared_ptr<const runtime::FineShaderData> moved = rt->fineLevel();
  ASSERT_NE(moved, nullptr);
  EXPECT_NE(moved.get(), level.get());
  EXPECT_EQ(moved->constants.box_min[0], level->constants.box_min[0] + 40.f) << "the box follows the camera by whole cells";
  EXPECT_EQ(level->probes.size(), direct.probes.size()) << "the level a reader took is unchanged";
  // Nothing it reads changed: the same level. A relight (another hour), a sector gone: a new one.
  rt->update(kCamera + glm::dvec3(41.0, 0.5, 0.0));
  EXPECT_EQ(rt->fineLevel().get(), moved.get()) << "the camera moved within its cell, nothing else changed";
  ASSERT_TRUE(rt->setTime(kHour + 3.0).has_value());
  rt->update(kCamera + glm::dvec3(41.0, 0.5, 0.0));
  const std::shared_ptr<const runtime::FineShaderData> later = rt->fineLevel();
  EXPECT_NE(later.get(), moved.get()) << "relit: the colours changed";
  EXPECT_NE(std::memcmp(later->probes.data(), moved->probes.data(), moved->probes.size() * sizeof(runtime::FineShaderProbe)), 0);
  ASSERT_TRUE(rt->removeSector(baked.sectors.front().key));
  rt->update(kCamera + glm::dvec3(41.0, 0.5, 0.0));
  EXPECT_NE(rt->fineLevel().get(), later.get()) << "a sector left";
}

}  // namespace
}  // namespace drtv::testing
