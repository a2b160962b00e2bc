// The top-down sweep (sweep.h): the bins' physics, energy through empty levels, shadows that do not
// leak, the reflection's distribution, and a fine grid's edges from a coarse one.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "drtv/sweep/directions.h"
#include "drtv/sweep/grid.h"
#include "drtv/sweep/sweep.h"

namespace drtv::sweep {
namespace {

// R11G11B10 keeps 6 (red, green) and 5 (blue) mantissa bits: a stored value is within 2^-6 of
// itself relative (half an ulp of the blue channel's 5 bits); sums of stored values too.
constexpr float kPackTolerance = 1.f / 64.f;
// The bins' quadrature sums in double and rounds to float once per bin.
constexpr float kQuadratureTolerance = 1e-5f;

Sky uniformSky(float radiance) {
  Sky s = Sky::tropicalDefault();
  s.sky_zenith.keys = {{0.f, glm::vec3(radiance)}};
  s.sky_horizon.keys = {{0.f, glm::vec3(radiance)}};
  s.sun_irradiance.keys = {{0.f, glm::vec3(0.f)}};
  s.ground_radiance_scale = 0.f;
  return s;
}

SkyInput uniformInput(float radiance) { return {skyLight(uniformSky(radiance), 12.0), {}}; }

GridShape shape(glm::ivec3 size, double cell_m = 1.0, glm::dvec3 origin = glm::dvec3(0.0)) { return {origin, cell_m, size}; }

void expectNear(const glm::vec3& got, const glm::vec3& want, float rel, const std::string& what) {
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], rel * std::abs(want[c]) + 1e-6f) << what << " channel " << c;
}

TEST(SweepDirections, BinsPartitionTheSphere) {
  float omega = 0;
  for (const Direction& d : directions()) {
    EXPECT_GT(d.solid_angle_sr, 0.1f);
    EXPECT_LT(glm::length(d.mean_from), 1.f);
    omega += d.solid_angle_sr;
  }
  EXPECT_NEAR(omega, 4 * std::numbers::pi_v<float>, 4 * std::numbers::pi_v<float> * kQuadratureTolerance);
}

TEST(SweepDirections, UniformSkyGivesPiLOnAnUpFacingNormal) {
  const float l = 0.7f;
  const LightVector phi = skyLight(uniformSky(l), 12.0);
  expectNear(irradiance(phi, {0, 0, 1}), glm::vec3(std::numbers::pi_v<float> * l), kQuadratureTolerance, "E(+Z)");
  // Nothing comes from below: a down-facing normal sees nothing.
  expectNear(irradiance(phi, {0, 0, -1}), glm::vec3(0.f), 0.f, "E(-Z)");
}

TEST(SweepPacking, R11G11B10RoundTripsWithinHalfAnUlp) {
  for (float v : {6.2e-5f, 0.001f, 0.37f, 1.f, 3.14159f, 1000.f, 65000.f}) {
    const glm::vec3 back = unpackR11G11B10(packR11G11B10(glm::vec3(v)));
    EXPECT_NEAR(back.r, v, v / 128.f) << v;
    EXPECT_NEAR(back.b, v, v / 64.f) << v;
  }
  EXPECT_EQ(unpackR11G11B10(packR11G11B10(glm::vec3(-1.f, NAN, 1e-6f))), glm::vec3(0.f));
  EXPECT_EQ(unpackR11G11B10(packR11G11B10(glm::vec3(1e9f))).r, 65024.f);
}

TEST(Sweep, NoMaterialOverBlackGroundGivesTheSkysIrradiance) {
  const float l = 0.5f;
  MaterialGrid m = MaterialGrid::clear(shape({12, 12, 8}));
  for (int j = 0; j < 12; ++j)
    for (int i = 0; i < 12; ++i) m.density[m.shape.index(i, j, 0)] = 1.f;  // black ground
  const SweptGrid g = sweep(m, uniformInput(l), nullptr, {});
  for (double z : {1.5, 3.2, 7.5})
    expectNear(g.light.ambient({6.3, 5.1, z}, {0, 0, 1}), glm::vec3(std::numbers::pi_v<float> * l), kPackTolerance,
               "E(+Z) at z " + std::to_string(z));
  // The ground itself is dark halfway through its cell, and a black ground sends nothing up.
  expectNear(g.light.ambient({6.5, 6.5, 0.5}, {0, 0, 1}), glm::vec3(0.f), 0.f, "in the ground");
  expectNear(g.light.ambient({6.5, 6.5, 4.5}, {0, 0, -1}), glm::vec3(0.f), 0.f, "E(-Z)");
  // The average-light grid: mean radiance over the sphere, half of which is sky.
  expectNear(g.light.averageLight({6.5, 6.5, 4.5}), glm::vec3(0.5f * l), kPackTolerance, "average");
  EXPECT_NEAR(g.light.dominantDirection({6.5, 6.5, 4.5}).z, 0.5f, 0.05f);  // a hemisphere's mean cosine
}

// A coarse grid whose light is a spot in the middle of an otherwise dark level: the edges of a
// finer grid swept under it, which then carries the spot down.
SweptGrid spotParent(float value) {
  SweptGrid p;
  p.light_has_direct = true;
  p.light.shape = shape({9, 9, 1}, 10.0, {-5.0, -5.0, 0.0});
  const size_t n = p.light.shape.cellCount();
  p.light.light.assign(n * kDirections, 0);
  p.light.average.assign(n, 0);
  p.light.dominant.assign(n, 0);
  for (int b = 0; b < kSwept; ++b) p.light.light[p.light.shape.index(4, 4, 0) * kDirections + size_t(b)] = packR11G11B10(glm::vec3(value));
  return p;
}

TEST(Sweep, ConservesEnergyThroughLevelsWithoutMaterial) {
  const SweptGrid parent = spotParent(2.f);
  // 80 x 80 cells of 1 m under the parent's 9 x 9 cells of 10 m; the spot (cell 4, 4 of the
  // parent: 35..45 m, fading over +-10 m) never reaches the sides in 6 levels: the near-horizontal
  // directions move 4 cells per level.
  const MaterialGrid m = MaterialGrid::clear(shape({80, 80, 6}));
  const SweptGrid g = sweep(m, {}, &parent, {});
  for (int b = 0; b < kSwept; ++b) {
    std::array<double, 6> total{};
    for (int k = 0; k < 6; ++k)
      for (int j = 0; j < 80; ++j)
        for (int i = 0; i < 80; ++i) total[size_t(k)] += g.light.cell(m.shape.index(i, j, k))[size_t(b)].g;
    ASSERT_GT(total[5], 100.0) << "bin " << b;
    for (int k = 0; k < 5; ++k) EXPECT_NEAR(total[size_t(k)], total[5], total[5] * kPackTolerance) << "bin " << b << " level " << k;
  }
}

TEST(Sweep, DenseCellShadowsTheCellsBelowIt) {
  const float l = 1.f;
  const SkyInput sky = uniformInput(l);
  MaterialGrid m = MaterialGrid::clear(shape({9, 9, 6}));
  m.density[m.shape.index(4, 4, 5)] = 1.f;
  SweepOptions o;
  const SweptGrid g = sweep(m, sky, nullptr, o);
  constexpr int kStraightDown = 4;
  const float open = sky.sky[kStraightDown].g;
  // Straight below: only the 4 side taps of the smoothing bring light past it.
  EXPECT_NEAR(g.light.cell(m.shape.index(4, 4, 4))[kStraightDown].g, (1 - o.smoothing) * open, open * kPackTolerance);
  // The cell itself is dark halfway through, and far from it the sky is open.
  EXPECT_EQ(g.light.cell(m.shape.index(4, 4, 5))[kStraightDown].g, 0.f);
  EXPECT_NEAR(g.light.cell(m.shape.index(0, 0, 3))[kStraightDown].g, open, open * kPackTolerance);
  // The shadow fills in with depth, but stays darker than the open sky.
  const float below3 = g.light.cell(m.shape.index(4, 4, 2))[kStraightDown].g;
  EXPECT_GT(below3, (1 - o.smoothing) * open);
  EXPECT_LT(below3, open * (1 - 2 * kPackTolerance));
}

TEST(Sweep, NothingLeaksThroughADenseWallOnTheNearHorizontalPaths) {
  const SkyInput sky = uniformInput(1.f);
  constexpr int kWall = 10;
  // The wall spans the grid in y; the checked cells (j in [6, 18)) are far enough from its ends
  // that no path of theirs passes round them (the diagonal ones move 4 cells in y per level).
  MaterialGrid m = MaterialGrid::clear(shape({24, 24, 8}));
  for (int k = 0; k < 8; ++k)
    for (int j = 0; j < 24; ++j) m.density[m.shape.index(kWall, j, k)] = 1.f;
  const SweptGrid g = sweep(m, sky, nullptr, {});
  for (int b = kDown; b < kSwept; ++b) {
    const int sx = directions()[size_t(b)].step.x;
    if (sx == 0) continue;
    // Every source of these cells (4 cells back, +-1) lies behind the wall, or is the wall.
    for (int k = 0; k < 7; ++k)
      for (int j = 6; j < 18; ++j)
        for (int d = 1; d <= 3; ++d) EXPECT_EQ(g.light.cell(m.shape.index(kWall + sx * d, j, k))[size_t(b)], glm::vec3(0.f))
                                          << "bin " << b << " cell " << kWall + sx * d << "," << j << "," << k;
    // Light on the side it comes from, so that the zeros above mean something.
    EXPECT_GT(g.light.cell(m.shape.index(kWall - sx * 5, 4, 3))[size_t(b)].g, 0.5f * sky.sky[size_t(b)].g) << "bin " << b;
  }
}

TEST(Sweep, ReflectedLightGoesToEveryDirectionAsSpecified) {
  // Light only straight down, onto one cell of density d and reflectance rho, on a grid one level
  // high (its light comes from the edges directly).
  constexpr int kStraightDown = 4;
  SkyInput sky{};
  const float l = 1.f, d = 0.4f;
  const glm::vec3 rho(0.8f, 0.5f, 0.2f);
  sky.sky[kStraightDown] = glm::vec3(l);
  MaterialGrid m = MaterialGrid::clear(shape({5, 5, 1}));
  const size_t cell = m.shape.index(2, 2, 0);
  m.density[cell] = d;
  m.reflectance[cell] = rho;
  const SweptGrid g = sweep(m, sky, nullptr, {});
  // The slow reference: sweep.h's f(o) = 1 - (1 - tau)(1 + cos)/2, weights Omega_o f(o).
  const auto& dirs = directions();
  const float tau = 1 - d, stopped = l * d;  // straight down crosses one cell length
  std::array<float, kDirections> weight{};
  float total = 0;
  for (int o = 0; o < kDirections; ++o) {
    const float c = glm::dot(dirs[size_t(o)].travel, dirs[kStraightDown].travel);
    weight[size_t(o)] = dirs[size_t(o)].solid_angle_sr * (1 - (1 - tau) * (1 + c) / 2);
    total += weight[size_t(o)];
  }
  const LightVector got = g.light.cell(cell);
  glm::vec3 reflected_sum(0.f);
  for (int o = 0; o < kDirections; ++o) {
    const glm::vec3 reflected = rho * stopped * weight[size_t(o)] / total;
    const glm::vec3 passed = o == kStraightDown ? glm::vec3(l * std::sqrt(tau)) : glm::vec3(0.f);
    expectNear(got[size_t(o)], passed + 0.5f * reflected, kPackTolerance, "direction " + std::to_string(o));
    reflected_sum += reflected;
  }
  // Backwards (straight up) more than forwards (sideways down), as the seed describes.
  constexpr int kStraightUp = kSwept + 4;
  EXPECT_GT(got[kStraightUp].r, got[kStraightDown + 1].r);
  // All of what is stopped and not absorbed is reflected.
  expectNear(reflected_sum, rho * stopped, 1e-5f, "reflected total");
}

// A canopy slab at 32..48 m over a 1024 m x 1024 m x 64 m coarse grid; the fine grid below it, in
// the middle, where the sky that comes in at the coarse grid's sides under the slab (64 m further
// per 16 m level) never reaches: the light there is the same at every x, y.
MaterialGrid slab(const GridShape& s, double z0, double z1, float density_per_m) {
  MaterialGrid m = MaterialGrid::clear(s);
  for (int k = 0; k < s.size.z; ++k) {
    const double lo = s.origin.z + k * s.cell_m, hi = lo + s.cell_m;
    const double inside = std::max(0.0, std::min(hi, z1) - std::max(lo, z0)) / s.cell_m;
    const float d = 1.f - std::pow(1.f - density_per_m, float(inside * s.cell_m));
    for (int j = 0; j < s.size.y; ++j)
      for (int i = 0; i < s.size.x; ++i) {
        m.density[s.index(i, j, k)] = d;
        m.reflectance[s.index(i, j, k)] = glm::vec3(0.3f, 0.5f, 0.2f);
      }
  }
  return m;
}

TEST(Sweep, FineGridEdgesAgreeWithTheCoarseGrid) {
  Sky sunny = Sky::tropicalDefault();
  const SkyInput sky{skyLight(sunny, 11.0), sunLight(sunny, 11.0, 0.05)};
  SweepOptions coarse_o;
  coarse_o.keep_direct = true;
  const SweptGrid coarse = sweep(slab(shape({64, 64, 4}, 16.0), 32, 48, 0.05f), sky, nullptr, coarse_o);
  const GridShape fine_s = shape({32, 32, 16}, 1.0, {496.0, 496.0, 8.0});
  const SweptGrid fine = sweep(slab(fine_s, 32, 48, 0.05f), sky, &coarse, {});
  const SweptGrid open = sweep(slab(fine_s, 32, 48, 0.05f), sky, nullptr, {});
  // The coarse grid interpolated and the fine grid swept through empty space from its edges differ
  // by the packing (twice: the coarse grid is stored, then the fine one) and by the coarse grid's
  // halfway value at the slab's level, which the fine grid's top edge interpolates towards: 5 %
  // (measured: 6 of the 81 channels beyond 2 %, 1 beyond 3 %).
  constexpr float kEdgeTolerance = 0.05f;
  for (const glm::vec3 n : {glm::vec3(0, 0, 1), glm::vec3(1, 0, 0), glm::vec3(0, -0.6f, 0.8f)})
    for (const glm::dvec3 p : {glm::dvec3(496.5, 504.5, 23.5), glm::dvec3(527.5, 514.5, 10.5), glm::dvec3(512.0, 512.0, 16.0)}) {
      const glm::vec3 want = coarse.light.ambient(p, n);
      expectNear(fine.light.ambient(p, n), want, kEdgeTolerance, "normal " + std::to_string(n.x) + "," + std::to_string(n.z));
      // Without the coarse grid's edges the canopy above the fine grid would not shade it.
      EXPECT_GT(open.light.ambient(p, n).g, want.g * 1.3f);
    }
}

}  // namespace
}  // namespace drtv::sweep
