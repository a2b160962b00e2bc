// The ambient shaders run: runtime/shaders/ambient.glsl, and ambient.hlsl through glslang's HLSL
// front end, as Vulkan compute (ambient_pass.h) over the volumes and constants of a baked archive,
// compared with the C++ lookup they mirror (sampleVolume) and with Runtime::ambient where that is
// the volume alone. Without a GPU the device is lavapipe (Mesa's CPU driver, installed by
// scripts/bootstrap); a machine with no Vulkan device at all fails here, it does not skip.
//
// The archive: a small procedural island (worlds/island.h) baked at draft quality over the 3 x 3
// sectors around (32, 32), written to disk by baker::bake and read back with ArchiveReader, relit
// at 15:00 the way `drtv query` sets up a runtime. Two cameras: one centred on the block, and one
// reached from it by a scroll (so the textures hold a toroidally wrapped, scrolled volume).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "ambient_pass.h"
#include "baked_archive.h"
#include "drtv/baker/bake.h"
#include "drtv/formats/sh.h"
#include "drtv/runtime/runtime.h"
#include "drtv/worlds/island.h"
#include "vulkan_compute.h"

namespace drtv::testing {
namespace {


// Points per camera; two cameras, so 12,000 lookups per shader language.
constexpr int kPointsPerCamera = 6000;
constexpr double kHour = 15.0;

// The tolerance, per lookup and channel, in 8-bit steps of the volume (HdrScale / 255) times the
// point's summed basis weights (sum_b w_b <= 2: how far an error of one step in every fetch moves
// the ambient). A trilinear fetch is three levels of lerps, along x, then y, then z. At each level
//  - the sampler quantises the lerp weight to 2^-subTexelPrecisionBits (the device's limit; 8 on
//    lavapipe, 1/256 of a texel), an error of at most 2^-bits of the difference it mixes, and
//  - an 8-bit filter (lavapipe filters RGBA8 in 8-bit fixed point) rounds the level's result, at
//    most kRoundingStepsPerLevel; a lerp of equal values is exact in fixed point as in float.
// The differences a level mixes are at most the largest difference between two texels of the
// footprint adjacent along that axis (the later levels mix convex combinations of them), c_axis,
// measured per point from the texels (footprintContrast). So, per lookup:
//   tolerance = kFloatSteps + sum over axes with c_axis > 0 of (kRoundingStepsPerLevel + c_axis 2^-bits)
// which is ~0 where the footprint is flat (a wrong basis or weight shows there at once) and at most
// 3 + 3 * 255 / 256 ~ 6 steps across the sharpest probe boundary. kFloatSteps covers the float
// arithmetic both sides do in different orders (unorm conversion, frac, the remap, the dot
// products, about 20 operations): 2.5e-3 steps is 1e-5 of HdrScale, some 80 float ulps (lavapipe
// stays within 1e-4 steps on flat footprints).
constexpr double kRoundingStepsPerLevel = 1.0;
constexpr double kFloatSteps = 2.5e-3;

using Baked = BakedArchive;

// The island baked to an archive and read back (once for all tests, per representation).
Baked bakeIsland(Representation representation) {
  worlds::IslandOptions io;
  io.size_km2 = 0.09;  // 300 m square: the 3 x 3 sector block is land, shore and sea
  io.seed = 7;
  auto world = worlds::generateIsland(io);
  EXPECT_TRUE(world.has_value()) << (world ? "" : world.error().message);
  if (!world) return {};
  baker::BakeOptions options;
  options.quality = baker::Quality::kDraft;
  options.sectors = raytrace::SectorRange{-1, 1, -1, 1};
  options.representation = representation;
  return bakeArchive(*world, "island", options);
}
const Baked& bakedIsland(Representation representation) {
  static BakedPerRepresentation baked(bakeIsland);
  return baked(representation);
}

// A runtime for the archive as `drtv query` builds one, lit at kHour, volume on `camera`.
std::unique_ptr<runtime::Runtime> relit(const Baked& b, const glm::dvec3& camera) { return relitArchive(b, kHour, camera); }

struct TestPoint {
  glm::dvec3 position;  // world metres
  glm::vec3 normal;     // unit
};

// Deterministic points for `volume` (seeded): sample points (position + normal * offset) inside
// the covered box, around it (the lookup wraps there: both sides must still agree), and on or
// next to the wrap seams (world texel coordinate 0.5 + k N, where frac jumps and the duplicated
// boundary takes over) and the box's edges, along one axis at a time.
std::vector<TestPoint> makePoints(const runtime::Volume& volume, float offset_m, uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const glm::dvec3 ts(volume.options().texel_size_m), o(volume.origin()), n(volume.period());
  const double jitters[] = {0.0, 1e-4, -1e-4, 1e-2, -1e-2, 0.3, -0.3};
  std::vector<TestPoint> points;
  for (int i = 0; i < kPointsPerCamera; ++i) {
    glm::dvec3 t;  // sample point in world texel units
    const double kind = u(rng);
    for (int a = 0; a < 3; ++a) t[a] = kind < 0.5 ? o[a] + 0.5 + u(rng) * (n[a] - 1.0)               // inside
                                                  : o[a] - 4.0 + u(rng) * (n[a] + 8.0);               // and around
    if (kind >= 0.7) {  // one axis on a seam or an edge
      const int a = int(rng() % 3);
      const double k = std::ceil(o[a] / n[a]);  // 0.5 + k N: the first seam inside the box
      const double planes[] = {0.5 + k * n[a], 0.5 + (k - 1) * n[a], o[a] + 0.5, o[a] + n[a] - 0.5};
      t[a] = planes[rng() % 4] + jitters[rng() % std::size(jitters)];
    }
    glm::vec3 normal;
    if (u(rng) < 0.1) {
      const glm::vec3 axes[] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1},
                                sh::kBasis[0], sh::kBasis[1], sh::kBasis[2], sh::kBasis[3]};
      normal = glm::normalize(axes[rng() % std::size(axes)]);
    } else {
      normal = randomUnitNormal(rng, u);
    }
    points.push_back({t * ts - glm::dvec3(normal) * double(offset_m), normal});
  }
  return points;
}

// Per axis, the largest difference in 8-bit steps between two texels that are neighbours along
// that axis in the trilinear footprint of `p`'s sample point (over the 4 bases and 3 textures): what
// the sampler's weight quantisation multiplies at that level. The footprint as sampleVolume's
// filter takes it (clamp addressing).
glm::dvec3 footprintContrast(const runtime::Volume& v, const runtime::VolumeShaderConstants& k, const TestPoint& p, float offset_m) {
  const glm::vec3 ws = glm::vec3(p.position - k.snapped_camera) + p.normal * offset_m;
  const glm::vec3 uv = glm::fract(ws * k.uv_scale + 0.5f + k.wrap_offset) * k.uv_remap_scale + k.uv_remap_bias;
  const glm::ivec3 size = v.size();
  int lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    const int i = int(std::floor(uv[a] * float(size[a]) - 0.5f));
    lo[a] = std::clamp(i, 0, size[a] - 1);
    hi[a] = std::clamp(i + 1, 0, size[a] - 1);
  }
  glm::dvec3 worst(0.0);
  for (int c = 0; c < 3; ++c)
    for (int corner = 0; corner < 8; ++corner) {
      const glm::ivec3 q((corner & 1) ? hi[0] : lo[0], (corner & 2) ? hi[1] : lo[1], (corner & 4) ? hi[2] : lo[2]);
      for (int a = 0; a < 3; ++a) {
        glm::ivec3 r = q;
        r[a] = (corner >> a & 1) ? lo[a] : hi[a];
        const uint32_t t0 = v.physicalTexel(c, q), t1 = v.physicalTexel(c, r);
        for (int b = 0; b < 4; ++b) worst[a] = std::max(worst[a], std::abs(double(t0 >> (8 * b) & 0xff) - double(t1 >> (8 * b) & 0xff)));
      }
    }
  return worst;
}

struct Comparison {
  size_t points = 0, failures = 0, runtime_points = 0;
  double max_abs = 0.0;         // largest |shader - C++| over points and channels (irradiance)
  double max_steps = 0.0;       // the same in 8-bit steps x summed weights
  double max_bound_share = 0.0; // largest |difference| / tolerance
  double sum_steps = 0.0;
  double max_contrast_steps = 0.0;  // the largest footprint contrast met (the data is not flat)
  size_t flat_points = 0;           // points whose footprint is flat (tolerance kFloatSteps)
  double max_flat_steps = 0.0;      // the largest difference there, steps x weights
  std::string first_failure;
};

// Runs `language`'s shader over the points of both cameras and compares with sampleVolume and,
// where the runtime's answer is the volume alone, with Runtime::ambient. `perturb` edits the
// constants the shader gets (to show that the comparison fails on a wrong shader input).
Comparison compareShader(ShaderLanguage language, void (*perturb)(VolumeConstantsBlock&) = nullptr,
                         Representation representation = Representation::kFc3) {
  Comparison out;
  const Baked& baked = bakedIsland(representation);
  if (baked.sectors.empty()) {
    ADD_FAILURE() << "no baked sectors";
    return out;
  }
  auto vk = VulkanCompute::create();
  if (!vk) {
    ADD_FAILURE() << vk.error().message;
    return out;
  }
  double probe_z = 0.0;
  size_t probes = 0;
  for (const Sector& s : baked.sectors)
    for (const ProbeRecord& r : s.probes) probe_z += r.position[2], ++probes;
  probe_z /= double(std::max<size_t>(probes, 1));
  std::unique_ptr<runtime::Runtime> rt = relit(baked, {32.0, 32.0, probe_z});
  const glm::dvec3 cameras[] = {{32.0, 32.0, probe_z}, {51.3, 9.7, probe_z + 9.0}};  // the second by a scroll
  const float offset_m = rt->options().normal_offset_m;
  for (int cam = 0; cam < 2; ++cam) {
    rt->update(cameras[cam]);
    const runtime::PublishedVolume::ReadView view = rt->volume().read();
    const runtime::Volume& volume = view.volume();
    const runtime::VolumeShaderConstants k = volume.shaderConstants();
    VolumeConstantsBlock block = makeConstantsBlock(k, offset_m);
    if (perturb) perturb(block);
    auto pass = AmbientPass::create(**vk, DRTV_SOURCE_DIR, language, volume, block, kPointsPerCamera);
    if (!pass) {
      ADD_FAILURE() << pass.error().message;
      return out;
    }
    const std::vector<TestPoint> points = makePoints(volume, offset_m, 1000u + uint32_t(cam));
    std::vector<AmbientPoint> in;
    for (const TestPoint& p : points) in.push_back({glm::vec4(glm::vec3(p.position), 0.f), glm::vec4(p.normal, 0.f)});
    auto gpu = (*pass)->run(in);
    if (!gpu) {
      ADD_FAILURE() << gpu.error().message;
      return out;
    }
    const double step = double(k.hdr_scale) / 255.0;
    const double weight_quantum = std::ldexp(1.0, -int((*vk)->subTexelPrecisionBits()));
    for (size_t i = 0; i < points.size(); ++i) {
      const TestPoint& p = points[i];
      const glm::vec3 cpu = runtime::sampleVolume(volume, p.position, p.normal, offset_m);
      // How far one 8-bit step in every fetch moves the result: the weights' sum (fc3), or
      // 1 + (255 / 127) (|n.x| + |n.y| + |n.z|) for sh-l1 (band 1's step is 255/127 of band 0's).
      const glm::vec4 w = sh::shadingWeights(p.normal);
      const double weight_sum =
          representation == Representation::kShL1
              ? 1.0 + 255.0 / 127.0 * (std::fabs(p.normal.x) + std::fabs(p.normal.y) + std::fabs(p.normal.z))
              : std::max(1e-3, double(w.x + w.y + w.z + w.w));
      const glm::dvec3 contrast = footprintContrast(volume, k, p, offset_m);
      double tolerance_steps = kFloatSteps;
      for (int a = 0; a < 3; ++a) {
        if (contrast[a] > 0.0) tolerance_steps += kRoundingStepsPerLevel + contrast[a] * weight_quantum;
        out.max_contrast_steps = std::max(out.max_contrast_steps, contrast[a]);
      }
      const bool flat = contrast == glm::dvec3(0.0);
      out.flat_points += flat;
      const double tolerance = tolerance_steps * step * weight_sum;
      // Where Runtime::ambient is the volume alone (full coverage, no interior, no fine level), it
      // must agree too.
      const runtime::AmbientSample rs = rt->ambient(p.position, p.normal);
      const bool volume_only = rs.volume_weight >= 1.f && rs.interior_weight <= 0.f && rs.fine_weight <= 0.f;
      out.runtime_points += volume_only;
      for (int c = 0; c < 3; ++c) {
        for (const float reference : {cpu[c], volume_only ? rs.irradiance[c] : cpu[c]}) {
          const double d = std::abs(double((*gpu)[i][c]) - double(reference));
          if (!(d <= tolerance)) {
            if (out.failures++ == 0) {
              char line[320];
              std::snprintf(line, sizeof line,
                            "camera %d point %zu at (%.4f, %.4f, %.4f) normal (%.4f, %.4f, %.4f) channel %d: shader %.6g, C++ %.6g, "
                            "|diff| %.4g > tolerance %.4g (%.2f steps x weights %.3f)",
                            cam, i, p.position.x, p.position.y, p.position.z, p.normal.x, p.normal.y, p.normal.z, c,
                            (*gpu)[i][c], reference, d, tolerance, tolerance_steps, weight_sum);
              out.first_failure = line;
            }
          }
          out.max_abs = std::max(out.max_abs, d);
          out.max_steps = std::max(out.max_steps, d / (step * weight_sum));
          if (flat) out.max_flat_steps = std::max(out.max_flat_steps, d / (step * weight_sum));
          out.max_bound_share = std::max(out.max_bound_share, d / tolerance);
        }
        out.sum_steps += std::abs(double((*gpu)[i][c]) - double(cpu[c])) / (step * weight_sum);
      }
      ++out.points;
    }
  }
  std::printf("[ shader ] %s on %s, archive of %zu sectors, %zu probes: %zu lookups (%zu also against Runtime::ambient), "
              "largest |diff| %.3g irradiance = %.3f 8-bit steps x weights (mean %.3f), %.0f%% of the tolerance, %zu over "
              "(largest texel contrast in a footprint %.0f steps; %zu flat footprints, largest |diff| there %.2g steps)\n",
              shaderLanguageName(language), (*vk)->deviceDescription().c_str(), baked.sectors.size(), probes, out.points,
              out.runtime_points, out.max_abs, out.max_steps, out.sum_steps / double(3 * std::max<size_t>(out.points, 1)),
              100.0 * out.max_bound_share, out.failures, out.max_contrast_steps, out.flat_points, out.max_flat_steps);
  return out;
}

void expectAgreement(ShaderLanguage language, Representation representation = Representation::kFc3) {
  const Comparison c = compareShader(language, nullptr, representation);
  if (c.points == 0) return;  // compareShader said why
  EXPECT_GE(c.points, 10000u);
  EXPECT_GE(c.runtime_points, 3000u) << "too few points where Runtime::ambient is the volume alone";
  EXPECT_GT(c.max_contrast_steps, 32.0) << "a nearly flat volume: the comparison would show little";
  EXPECT_EQ(c.failures, 0u) << c.first_failure;
  ::testing::Test::RecordProperty("largest_difference_steps", std::to_string(c.max_steps));
}

TEST(ShaderRun, GlslAmbientAsVulkanComputeMatchesSampleVolumeOnABakedArchive) { expectAgreement(ShaderLanguage::kGlsl); }

TEST(ShaderRun, HlslAmbientAsVulkanComputeMatchesSampleVolumeOnABakedArchive) { expectAgreement(ShaderLanguage::kHlsl); }

TEST(ShaderRun, GlslShL1AmbientMatchesSampleVolumeOnAnShL1Archive) {
  expectAgreement(ShaderLanguage::kGlsl, Representation::kShL1);
}

TEST(ShaderRun, HlslShL1AmbientMatchesSampleVolumeOnAnShL1Archive) {
  expectAgreement(ShaderLanguage::kHlsl, Representation::kShL1);
}

// The comparison can fail: the same run with the sampling offset a quarter texel too long, or the
// HDR scale 2 % too high, must exceed the tolerance.
TEST(ShaderRun, ComparisonFailsWhenTheShaderGetsWrongConstants) {
  const Comparison offset = compareShader(ShaderLanguage::kGlsl, [](VolumeConstantsBlock& b) { b.offset_length += 0.5f; });
  EXPECT_GT(offset.failures, 100u);
  const Comparison scale = compareShader(ShaderLanguage::kGlsl, [](VolumeConstantsBlock& b) { b.hdr_scale *= 1.02f; });
  EXPECT_GT(scale.failures, 100u);
}

}  // namespace
}  // namespace drtv::testing
