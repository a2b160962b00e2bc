// The sweep's per-model material grids (eval/techniques/sweep/model_material.h): a model placed
// many times is voxelised once, and its placements resampled into 1 m cells give the material the
// ray caster (sweep_material.h) finds for the same triangles.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "../../eval/techniques/sweep/model_material.h"
#include "../../eval/techniques/sweep/sweep_material.h"
#include "drtv/eval/technique.h"
#include "drtv/raytrace/world_geometry.h"

namespace drtv::eval {
namespace {

worlds::Mesh unitBox(glm::vec3 albedo) {
  worlds::Mesh m;
  m.name = "box";
  for (int i = 0; i < 8; ++i) m.positions.push_back({(i & 1) ? 0.5f : -0.5f, (i & 2) ? 0.5f : -0.5f, (i & 4) ? 0.5f : -0.5f});
  const uint32_t q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : q) m.indices.insert(m.indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
  m.albedo = albedo;
  return m;
}

// A UV sphere of radius 1 about (0, 0, 1.5), outward-wound: a tree's crown.
worlds::Mesh crown() {
  worlds::Mesh m;
  m.name = "crown";
  constexpr int kRings = 8, kSegments = 12;
  for (int r = 0; r <= kRings; ++r)
    for (int s = 0; s < kSegments; ++s) {
      const double th = std::numbers::pi * r / kRings, ph = 2 * std::numbers::pi * s / kSegments;
      m.positions.push_back({float(std::sin(th) * std::cos(ph)), float(std::sin(th) * std::sin(ph)), float(1.5 + std::cos(th))});
    }
  for (int r = 0; r < kRings; ++r)
    for (int s = 0; s < kSegments; ++s) {
      const uint32_t a = r * kSegments + s, b = r * kSegments + (s + 1) % kSegments, c = a + kSegments, d = b + kSegments;
      m.indices.insert(m.indices.end(), {a, c, d, a, d, b});
    }
  m.albedo = {0.1f, 0.4f, 0.1f};
  return m;
}

glm::dmat4 place(glm::dvec3 t, double yaw_rad, glm::dvec3 scale) {
  return glm::translate(glm::dmat4(1.0), t) * glm::rotate(glm::dmat4(1.0), yaw_rad, glm::dvec3(0, 0, 1)) * glm::scale(glm::dmat4(1.0), scale);
}

TEST(ModelMaterial, AModelPlacedManyTimesIsVoxelisedOnce) {
  worlds::World w;
  w.meshes = {unitBox(glm::vec3(0.5f)), crown()};
  for (int i = 0; i < 5; ++i) w.instances.push_back({0, place({10.0 + 8 * i, 20, 2}, 0.3 * i, {2, 3, 4}), worlds::InstanceClass::kStatic, "box"});
  for (int i = 0; i < 7; ++i) w.instances.push_back({1, place({10.0 + 6 * i, 40, 0}, 0.5 * i, glm::dvec3(1.0 + 0.1 * i)), worlds::InstanceClass::kVegetation, "tree"});
  w.instances.push_back({1, place({5, 5, 0}, 0, glm::dvec3(1)), worlds::InstanceClass::kDynamic, "moving tree"});
  auto m = ModelMaterial::build(w, {});
  ASSERT_TRUE(m.has_value()) << m.error().message;
  EXPECT_EQ(m->stats().models, 2u);
  EXPECT_EQ(m->stats().placements, 12u) << "dynamic instances are not material";
}

// A solid 4 m box on the cells' lattice: the cells inside it block fully, as the ray caster
// finds, and the cells a cell or more away from it are clear.
TEST(ModelMaterial, ASolidBoxOnTheCellLatticeBlocksTheCellsInsideItAndNoOthers) {
  worlds::World w;
  w.meshes = {unitBox(glm::vec3(0.6f, 0.2f, 0.1f))};
  w.instances = {{0, place({12, 12, 4}, 0, glm::dvec3(4)), worlds::InstanceClass::kStatic, "box"}};
  const sweep::GridShape s{{0.0, 0.0, 0.0}, 1.0, {24, 24, 10}};
  auto m = ModelMaterial::build(w, {});
  ASSERT_TRUE(m.has_value()) << m.error().message;
  const ObjectLayer layer = m->resample(s);
  auto g = raytrace::WorldGeometry::build(w, "box");
  ASSERT_TRUE(g.has_value()) << g.error().message;
  auto rays = voxelise(*g, s, {});
  ASSERT_TRUE(rays.has_value()) << rays.error().message;
  for (int k = 0; k < s.size.z; ++k)
    for (int j = 0; j < s.size.y; ++j)
      for (int i = 0; i < s.size.x; ++i) {
        const size_t c = s.index(i, j, k);
        const bool inside = i >= 10 && i < 14 && j >= 10 && j < 14 && k >= 2 && k < 6;
        const bool far = i < 9 || i > 14 || j < 9 || j > 14 || k < 1 || k > 6;
        if (inside) {
          EXPECT_EQ(layer.share[c], 1.f) << i << " " << j << " " << k;
          EXPECT_EQ(rays->density[c], 1.f) << i << " " << j << " " << k;
          EXPECT_EQ(layer.reflectance[c], glm::vec3(0.6f, 0.2f, 0.1f));
        }
        if (far) {
          EXPECT_EQ(layer.share[c], 0.f) << i << " " << j << " " << k;
        }
      }
}

// Trees' crowns (surfaces: vegetation) rotated and scaled off the lattice: the resampled material
// is the ray-cast one within a tolerance, cell by cell and in total.
TEST(ModelMaterial, PlacedCrownsResampleCloseToTheirRayCastMaterial) {
  worlds::World w;
  w.meshes = {crown()};
  for (int i = 0; i < 6; ++i)
    w.instances.push_back(
        {0, place({6.3 + 9.1 * i, 7.7 + 3.3 * i, 0.4 * i}, 0.7 * i, glm::dvec3(1.6 + 0.25 * i)), worlds::InstanceClass::kVegetation, "tree"});
  const sweep::GridShape s{{0.0, 0.0, -1.0}, 1.0, {64, 32, 12}};
  auto m = ModelMaterial::build(w, {});
  ASSERT_TRUE(m.has_value()) << m.error().message;
  const ObjectLayer layer = m->resample(s);
  auto models = voxelise(nullptr, s, {}, nullptr, &layer);
  ASSERT_TRUE(models.has_value()) << models.error().message;
  auto g = raytrace::WorldGeometry::build(w, "trees");
  ASSERT_TRUE(g.has_value()) << g.error().message;
  auto rays = voxelise(*g, s, {});
  ASSERT_TRUE(rays.has_value()) << rays.error().message;
  double sum_rays = 0, sum_models = 0, diff = 0;
  size_t cells = 0;
  for (size_t c = 0; c < s.cellCount(); ++c) {
    const double a = rays->density[c], b = models->density[c];
    if (a == 0 && b == 0) continue;
    sum_rays += a;
    sum_models += b;
    diff += std::abs(a - b);
    ++cells;
  }
  ASSERT_GT(cells, 100u);
  // The models' shell is at least half a lattice spacing thick either side of the surface, its runs
  // counted at their middles, against the rays' exact surface sampled by 3 x 3 rays a face (a
  // cell's share in ninths). Counting every cell a run touched read 1.5 times the rays' total and
  // a mean difference of 0.17: this test failed on it.
  constexpr double kTotalTol = 0.25, kMeanAbsTol = 0.15;
  EXPECT_NEAR(sum_models / sum_rays, 1.0, kTotalTol) << "rays " << sum_rays << ", models " << sum_models;
  EXPECT_LT(diff / double(cells), kMeanAbsTol) << "over " << cells << " cells";
}

// The technique with material=models: flat ground over 2 x 1 sectors and rotated crowns and boxes
// across their border, prepared on 1 and on 2 threads, reads the same light bit for bit (each
// sector's grid is its own slot; the resampling keeps no shared state), and not the same light as
// the ray-cast material everywhere (the option is in use).
TEST(ModelMaterial, TheTechniquesModelsMaterialIsTheSameWhateverTheThreads) {
  worlds::World w;
  worlds::Mesh ground;
  ground.positions = {{0, 0, 0}, {128, 0, 0}, {128, 64, 0}, {0, 64, 0}};
  ground.indices = {0, 1, 2, 0, 2, 3};
  ground.albedo = glm::vec3(0.3f);
  ground.name = "ground";
  w.meshes = {ground, crown(), unitBox(glm::vec3(0.6f))};
  w.instances.push_back({0, glm::dmat4(1.0), worlds::InstanceClass::kTerrain, "ground"});
  for (int i = 0; i < 8; ++i) {
    w.instances.push_back({1, place({50.0 + 4.1 * i, 20.0 + 3.7 * i, 0}, 0.6 * i, glm::dvec3(1.5 + 0.1 * i)), worlds::InstanceClass::kVegetation, "tree"});
    w.instances.push_back({2, place({55.0 + 2.3 * i, 45.0, 1.5}, 0.4 * i, {1, 6, 3}), worlds::InstanceClass::kStatic, "wall"});
  }
  w.effects = worlds::defaultEffects(w);
  auto prepared = [&](const TechniqueParams& p, int threads) {
    auto t = makeTechnique("sweep", p);
    EXPECT_TRUE(t.has_value()) << t.error().message;
    PrepareInput in{w, "trees", {0, 1, 0, 0}, 1, threads, nullptr};
    auto ok = (*t)->prepare(in);
    EXPECT_TRUE(ok.has_value()) << ok.error().message;
    auto lit = (*t)->setLighting(9.0, {});
    EXPECT_TRUE(lit.has_value()) << lit.error().message;
    return std::move(*t);
  };
  const auto one = prepared({{"material", "models"}}, 1), two = prepared({{"material", "models"}}, 2);
  const auto rays = prepared({}, 2);
  int differ = 0, n = 0;
  for (double x = 40.5; x < 90; x += 3.1)
    for (double y = 10.5; y < 55; y += 2.9)
      for (double z : {0.2, 2.5, 5.0}) {
        const glm::dvec3 p(x, y, z);
        const glm::vec3 nrm = glm::normalize(glm::vec3(std::sin(x), std::cos(y), 0.5f));
        ASSERT_EQ(one->ambient(p, nrm), two->ambient(p, nrm)) << x << ", " << y << ", " << z;
        differ += one->ambient(p, nrm) != rays->ambient(p, nrm);
        ++n;
      }
  EXPECT_GT(differ, n / 10) << "material=models changed nothing";
}

TEST(ModelMaterial, TheTechniqueRefusesAnUnknownMaterialAndAVoxelOutOfRange) {
  auto bad = makeTechnique("sweep", {{"material", "voxels"}});
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("material=voxels"), std::string::npos) << bad.error().message;
  EXPECT_FALSE(makeTechnique("sweep", {{"model_voxel_m", "0.001"}}).has_value());
  EXPECT_FALSE(makeTechnique("sweep", {{"ground_blend", "9"}}).has_value());
  EXPECT_TRUE(makeTechnique("sweep", {{"material", "models"}, {"model_voxel_m", "0.1"}, {"ground_blend", "0"}}).has_value());
}

}  // namespace
}  // namespace drtv::eval
