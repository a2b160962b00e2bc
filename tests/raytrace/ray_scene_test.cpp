// RayScene (the Embree adapter) against a brute-force Moller-Trumbore over every triangle.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/sampling.h"

namespace drtv::raytrace {
namespace {

// Embree and the reference compute t in different float orders: 1e-4 relative covers the
// round-off at the 10 m distances used here.
constexpr float kDistanceTolerance = 1e-3f;

// Slow and obvious: the closest front- or back-face hit over all triangles.
raytrace::Hit bruteForce(const std::vector<glm::vec3>& v, const raytrace::Ray& ray) {
  raytrace::Hit best;
  for (size_t t = 0; t < v.size() / 3; ++t) {
    const glm::dvec3 o(ray.origin), d(ray.dir), a(v[3 * t]), b(v[3 * t + 1]), c(v[3 * t + 2]);
    const glm::dvec3 e1 = b - a, e2 = c - a, p = glm::cross(d, e2);
    const double det = glm::dot(e1, p);
    if (std::abs(det) < 1e-12) continue;
    const glm::dvec3 s = o - a;
    const double u = glm::dot(s, p) / det;
    if (u < 0 || u > 1) continue;
    const glm::dvec3 q = glm::cross(s, e1);
    const double w = glm::dot(d, q) / det;
    if (w < 0 || u + w > 1) continue;
    const double hit_t = glm::dot(e2, q) / det;
    if (hit_t >= ray.t_near && hit_t <= ray.t_far && hit_t < best.t) best = raytrace::Hit{float(hit_t), uint32_t(t)};
  }
  return best;
}

std::vector<glm::vec3> randomSoup(size_t tris) {
  std::vector<glm::vec3> v;
  for (size_t t = 0; t < tris; ++t) {
    const glm::vec3 c(raytrace::unitFloat(raytrace::hashKey(t, 1)) * 20.f - 10.f, raytrace::unitFloat(raytrace::hashKey(t, 2)) * 20.f - 10.f, raytrace::unitFloat(raytrace::hashKey(t, 3)) * 20.f - 10.f);
    for (int k = 0; k < 3; ++k)
      v.push_back(c + glm::vec3(raytrace::unitFloat(raytrace::hashKey(t, k, 4)), raytrace::unitFloat(raytrace::hashKey(t, k, 5)), raytrace::unitFloat(raytrace::hashKey(t, k, 6))) * 3.f);
  }
  return v;
}

TEST(RayScene, ClosestHitsMatchABruteForceTracer) {
  const auto soup = randomSoup(300);
  auto scene = raytrace::RayScene::build(soup);
  ASSERT_TRUE(scene) << scene.error().message;
  EXPECT_EQ(scene->triangleCount(), 300u);
  std::vector<raytrace::Ray> rays;
  for (uint32_t i = 0; i < 2000; ++i)
    rays.push_back(raytrace::Ray{glm::vec3(0.f), 0.f, raytrace::uniformSphere(raytrace::r2Point(i, {0.3f, 0.7f})), 100.f});
  std::vector<raytrace::Hit> stream(rays.size());
  scene->intersect(rays, stream);
  std::vector<uint8_t> blocked(rays.size());
  scene->occluded(rays, blocked);
  size_t hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const raytrace::Hit ref = bruteForce(soup, rays[i]);
    const raytrace::Hit one = scene->intersect(rays[i]);
    ASSERT_EQ(one.hit(), ref.hit()) << "ray " << i;
    EXPECT_EQ(stream[i].prim, one.prim) << "stream and single rays agree, ray " << i;
    EXPECT_EQ(blocked[i] != 0, ref.hit());
    EXPECT_EQ(scene->occluded(rays[i]), ref.hit());
    if (!ref.hit()) continue;
    ++hits;
    EXPECT_NEAR(one.t, ref.t, kDistanceTolerance * std::max(1.f, ref.t)) << "ray " << i;
  }
  EXPECT_GT(hits, 200u) << "the test exercises hits";
}

TEST(RayScene, FrontFaceFollowsCounterClockwiseWinding) {
  const std::vector<glm::vec3> tri = {{-1, -1, 0}, {1, -1, 0}, {0, 1, 0}};  // faces +Z
  auto scene = raytrace::RayScene::build(tri);
  ASSERT_TRUE(scene);
  EXPECT_FLOAT_EQ(scene->normal(0).z, 1.f);
  const raytrace::Ray down{{0, 0, 5}, 0.f, {0, 0, -1}, 10.f}, up{{0, 0, -5}, 0.f, {0, 0, 1}, 10.f};
  EXPECT_TRUE(scene->frontFace(down, 0));
  EXPECT_FALSE(scene->frontFace(up, 0));
  EXPECT_NEAR(scene->intersect(down).t, 5.f, kDistanceTolerance);
}

TEST(RayScene, ATwoSidedTriangleIsASurfaceFromBothSidesFacingTheRay) {
  // Two triangles facing +Z, at z = 0 (one-sided) and z = 10 (two-sided).
  const std::vector<glm::vec3> tris = {{-1, -1, 0}, {1, -1, 0}, {0, 1, 0}, {-1, -1, 10}, {1, -1, 10}, {0, 1, 10}};
  const std::vector<uint8_t> two_sided = {0, 1};
  auto scene = raytrace::RayScene::build(tris, two_sided);
  ASSERT_TRUE(scene);
  EXPECT_FALSE(scene->twoSided(0));
  EXPECT_TRUE(scene->twoSided(1));
  const raytrace::Ray down{{0, 0, 5}, 0.f, {0, 0, -1}, 10.f}, up{{0, 0, 5}, 0.f, {0, 0, 1}, 10.f};
  ASSERT_EQ(scene->intersect(down).prim, 0u);
  ASSERT_EQ(scene->intersect(up).prim, 1u);
  EXPECT_TRUE(scene->frontFace(up, 1)) << "from behind, still a surface";
  EXPECT_EQ(scene->facingNormal(up, 1), glm::vec3(0, 0, -1)) << "its normal faces the ray";
  EXPECT_EQ(scene->normal(1), glm::vec3(0, 0, 1)) << "the geometric normal is the winding's";
  EXPECT_TRUE(scene->frontFace(down, 0));
  EXPECT_EQ(scene->facingNormal(down, 0), glm::vec3(0, 0, 1));
  const raytrace::Ray below{{0, 0, -5}, 0.f, {0, 0, 1}, 10.f};
  EXPECT_FALSE(scene->frontFace(below, 0)) << "a one-sided back face stays the inside";
  // Without flags every triangle is one-sided.
  auto plain = raytrace::RayScene::build(tris);
  ASSERT_TRUE(plain);
  EXPECT_FALSE(plain->frontFace(up, 1));
  EXPECT_EQ(plain->facingNormal(up, 1), glm::vec3(0, 0, 1));
}

TEST(RayScene, EmptySceneMissesEverything) {
  auto scene = raytrace::RayScene::build({});
  ASSERT_TRUE(scene);
  EXPECT_FALSE(scene->intersect(raytrace::Ray{}).hit());
  EXPECT_FALSE(scene->occluded(raytrace::Ray{}));
}

}  // namespace
}  // namespace drtv::raytrace
