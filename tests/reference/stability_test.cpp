// Hard cases stay numerically stable: every output finite, bounded and sensible, in the reference
// and in the baked, relit system (also run under ASan and UBSan in CI).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>

#include <glm/gtc/matrix_transform.hpp>

#include "baked_world.h"
#include "drtv/reference/reference.h"
#include "drtv/eval/render.h"
#include "drtv/baker/transfer.h"
#include "drtv/formats/sh.h"
#include "drtv/worlds/load.h"
#include "test_scenes.h"

namespace drtv::baker {
using namespace reference;
using namespace eval;
namespace {

// Small reference runs: the cases test finiteness and bounds, not convergence.
constexpr int kSamples = 64;

bool finiteNonNegative(const glm::vec3& v) {
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(v[c]) || v[c] < 0.f) return false;
  return true;
}

void expectSound(const ReferenceIrradiance& r, const char* what) {
  for (int p = 0; p < kRefPartCount; ++p) {
    EXPECT_TRUE(finiteNonNegative(r.parts[p].mean)) << what << ": " << referencePartName(ReferencePart(p));
    EXPECT_TRUE(finiteNonNegative(r.parts[p].std_error)) << what << ": " << referencePartName(ReferencePart(p));
  }
  EXPECT_TRUE(finiteNonNegative(r.ambient.mean)) << what;
}

const worlds::World& testBox() {
  static const worlds::World w = *worlds::loadWorld(DRTV_SOURCE_DIR "/worlds/fc3_testbox.json");
  return w;
}

worlds::World translated(worlds::World w, const glm::dvec3& offset) {
  for (worlds::Instance& i : w.instances) i.transform = glm::translate(glm::dmat4(1.0), offset) * i.transform;
  for (PointLight& l : w.lights) l.position += offset;
  return w;
}

// Points around the test box's spheres and walls, with varied normals.
std::vector<ReferenceQuery> boxQueries(const glm::dvec3& offset = glm::dvec3(0.0)) {
  std::vector<ReferenceQuery> q;
  const glm::vec3 normals[] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {-1, 0, 0}, {0, 0.6f, 0.8f}};
  for (int i = 0; i < 10; ++i)
    q.push_back({glm::dvec3(-10 + 2.2 * i, 0.7 * i - 3, 1.0 + 0.3 * i) + offset, normals[i % 5], uint64_t(i)});
  return q;
}

TEST(StabilityOfTheSun, AtAndBelowTheHorizonGivesFiniteLightAndNoSunFromBelow) {
  worlds::World w = testBox();
  // A sun gradient that never goes dark, so that the horizon itself decides.
  w.sky.sun_irradiance = testing::constant(glm::vec3(3.f));
  const auto scene = ReferenceScene::build(w, "box");
  ASSERT_TRUE(scene.has_value());
  // The hour the sun crosses the horizon in the evening, by bisection on its elevation.
  double lo = 12.0, hi = 23.9;
  for (int i = 0; i < 60; ++i) ((w.sky.sunDirection(0.5 * (lo + hi)).z > 0.0) ? lo : hi) = 0.5 * (lo + hi);
  const testing::BakedWorld baked = testing::bakeWorld(w, Quality::kDraft);
  for (double hour : {lo, hi, hi + 0.01, 0.0, 22.0}) {
    ReferenceSettings s;
    s.samples = kSamples;
    const ReferenceLighting light{w.sky, hour, {}};
    for (const ReferenceQuery& q : boxQueries()) {
      const ReferenceIrradiance r = referenceIrradiance(*scene, light, q, s);
      expectSound(r, "reference");
      if (w.sky.sunDirection(hour).z <= 0.0) {
        EXPECT_EQ(r.parts[kRefSunBounce].mean, glm::vec3(0.f)) << hour;
        EXPECT_EQ(r.parts[kRefDirectSun].mean, glm::vec3(0.f)) << hour;
      }
    }
    auto rt = testing::relit(baked, hour, glm::dvec3(0, 0, 2));
    for (const ReferenceQuery& q : boxQueries()) {
      const glm::vec3 a = rt->ambient(q.position, q.normal).irradiance;
      EXPECT_TRUE(finiteNonNegative(a)) << "baked at " << hour << " h";
      // Nothing in the box can exceed the sun plus the whole sky on an albedo-1 world: a loose
      // bound (sun 3 + pi x brightest sky radiance) that catches a blow-up.
      EXPECT_LT(std::max({a.r, a.g, a.b}), 3.f + 4.f) << "baked at " << hour << " h";
    }
  }
}

TEST(StabilityOfTheHdrRange, ScalesTheAmbientLinearlyFrom1eMinus3To1e5) {
  // The runtime packs the volume with a scale from the brightest probe, so ambient is linear in
  // the light up to 8-bit steps: 1/255 of the brightest colour, a few percent of a dim point.
  constexpr double kEightBitRel = 0.05;
  const testing::BakedWorld base = testing::bakeWorld(testBox(), Quality::kDraft);
  const auto scene = ReferenceScene::build(testBox(), "box");
  ASSERT_TRUE(scene.has_value());
  auto scaled = [](Sky sky, float k) {
    for (Gradient* g : {&sky.sun_irradiance, &sky.sky_zenith, &sky.sky_horizon})
      for (ColorKey& key : g->keys) key.value *= k;
    return sky;
  };
  ReferenceSettings s;
  s.samples = kSamples;
  const std::vector<ReferenceQuery> q = boxQueries();
  auto rt1 = testing::relit(base, 10.0, glm::dvec3(0, 0, 2));
  for (float k : {1e-3f, 1e5f}) {
    testing::BakedWorld b = base;
    b.manifest.sky = scaled(base.manifest.sky, k);
    auto rtk = testing::relit(b, 10.0, glm::dvec3(0, 0, 2));
    const ReferenceLighting l1{testBox().sky, 10.0, {}}, lk{scaled(testBox().sky, k), 10.0, {}};
    for (const ReferenceQuery& p : q) {
      const glm::vec3 a1 = rt1->ambient(p.position, p.normal).irradiance, ak = rtk->ambient(p.position, p.normal).irradiance;
      ASSERT_TRUE(finiteNonNegative(ak));
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(ak[c] / k, a1[c], kEightBitRel * a1[c] + 1e-6) << "x" << k << " channel " << c;
      // The reference is linear to float rounding: same seeds, same paths.
      const ReferenceIrradiance r1 = referenceIrradiance(*scene, l1, p, s), rk = referenceIrradiance(*scene, lk, p, s);
      expectSound(rk, "reference");
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(rk.ambient.mean[c] / k, r1.ambient.mean[c], 1e-4 * r1.ambient.mean[c] + 1e-9);
    }
  }
}

TEST(StabilityOfAlbedo, ZeroKillsEveryBounceAndOneConvergesOnAnOpenPlane) {
  const Sky sky = testing::uniformSky(1.f, 0.f);
  for (float rho : {0.f, 1.f}) {
    const worlds::World w = testing::planeWorld(2000.0, glm::vec3(rho));
    const auto scene = ReferenceScene::build(w, "plane");
    ASSERT_TRUE(scene.has_value());
    ReferenceSettings s;
    s.samples = kSamples;
    const ReferenceIrradiance r = referenceIrradiance(*scene, ReferenceLighting{sky, 12.0, {}}, {glm::dvec3(0, 0, 1), glm::vec3(0, 0, -1), 0}, s);
    expectSound(r, "reference");
    // Over an open plane every bounce path escapes after one hit: exactly rho pi L.
    EXPECT_NEAR(r.parts[kRefSkyBounce].mean.x, rho * testing::kPi, 1e-4);
    const testing::BakedWorld b = testing::bakeWorld(w, Quality::kDraft, raytrace::SectorRange{0, 0, 0, 0});
    auto rt = testing::relit(b, 12.0, glm::dvec3(32, 32, 2));
    const glm::vec3 a = rt->ambient(glm::dvec3(32, 32, 1), glm::vec3(0, 0, -1)).irradiance;
    EXPECT_TRUE(finiteNonNegative(a));
    if (rho == 0.f) {
      // Only the wrapped upward bases' sky and the bake's noise: 0.017 pi with the direct sky's
      // unweighted six-axis fit, 0.023 pi with the receiver-weighted one (transfer.cpp
      // kSkyFitReceiverWeight), which here weighs the up axis 4x and so reads the horizontal
      // axes' noise into the down normal with a factor 8/9 instead of 2/3 (the normal equations).
      EXPECT_LT(a.x, 0.03f * testing::kPi);
    }
  }
}

TEST(StabilityOfAlbedo, OneInAClosedRoomStaysFiniteAndBoundedByTheBounceCap) {
  // A closed box of albedo 1 around a point light: light never leaves, so the exact answer is
  // infinite; the reference must stop at max_bounces and stay finite, the bake at its bounces.
  worlds::World w;
  worlds::Mesh m;
  m.name = "room";
  m.albedo = glm::vec3(1.f);
  // A 10 m cube, faces wound to look inward.
  const glm::vec3 c[8] = {{-5, -5, 0}, {5, -5, 0}, {5, 5, 0}, {-5, 5, 0}, {-5, -5, 10}, {5, -5, 10}, {5, 5, 10}, {-5, 5, 10}};
  m.positions.assign(c, c + 8);
  m.indices = {0, 1, 2, 0, 2, 3, 4, 6, 5, 4, 7, 6, 0, 4, 5, 0, 5, 1, 1, 5, 6, 1, 6, 2, 2, 6, 7, 2, 7, 3, 3, 7, 4, 3, 4, 0};
  w.meshes.push_back(m);
  w.instances.push_back(worlds::Instance{});
  w.lights.push_back(PointLight{"lamp", glm::dvec3(0, 0, 5), glm::vec3(10.f), 20.f});
  w.sky = testing::uniformSky(0.f, 0.f);
  w.effects = worlds::defaultEffects(w);
  const auto scene = ReferenceScene::build(w, "room");
  ASSERT_TRUE(scene.has_value());
  ReferenceSettings s;
  s.samples = kSamples;
  s.max_bounces = 16;
  const ReferenceIrradiance r = referenceIrradiance(*scene, ReferenceLighting{w.sky, 12.0, w.lights}, {glm::dvec3(1, 1, 2), glm::vec3(0, 0, 1), 0}, s);
  expectSound(r, "reference");
  // Each bounce adds at most the brightest direct irradiance in the room, I / (5 m)^2.
  EXPECT_LE(r.parts[kRefLocalLights].mean.x, s.max_bounces * 10.f / 25.f);
  const testing::BakedWorld b = testing::bakeWorld(w, Quality::kDraft);
  auto rt = testing::relit(b, 12.0, glm::dvec3(0, 0, 5));
  EXPECT_TRUE(finiteNonNegative(rt->ambient(glm::dvec3(1, 1, 2), glm::vec3(0, 0, 1)).irradiance));
}

TEST(StabilityInsideGeometry, AProbeInsideASolidBakesToNoLightAndIsNoticed) {
  // A closed 4 m box; the probe at its centre sees only back faces.
  worlds::World w = testing::planeWorld(200.0, glm::vec3(0.5f));
  worlds::Mesh m;
  m.name = "block";
  // Floating 1 m above the plane, so that no face of it coincides with the plane's.
  const glm::vec3 c[8] = {{-2, -2, 1}, {2, -2, 1}, {2, 2, 1}, {-2, 2, 1}, {-2, -2, 5}, {2, -2, 5}, {2, 2, 5}, {-2, 2, 5}};
  m.positions.assign(c, c + 8);
  // Outward-facing.
  m.indices = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 5, 4, 0, 1, 5, 1, 6, 5, 1, 2, 6, 2, 7, 6, 2, 3, 7, 3, 4, 7, 3, 0, 4};
  w.meshes.push_back(m);
  worlds::Instance inst;
  inst.mesh = 1;
  inst.transform = glm::translate(glm::dmat4(1.0), glm::dvec3(20, 20, 0));
  w.instances.push_back(inst);
  auto geometry = raytrace::WorldGeometry::build(w, "block");
  ASSERT_TRUE(geometry.has_value());
  const raytrace::SectorGeometry g = geometry->gather({0, 0}, 64.0);
  auto rays = raytrace::RayScene::build(g.vertices);
  ASSERT_TRUE(rays.has_value());
  TransferStats stats;
  const std::vector<glm::vec3> probes = {{20, 20, 3}, {40, 40, 1.5f}};
  const std::vector<ProbeData> d = bakeTransfer(*rays, g, probes, TransferSettings{}, stats);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_GT(d[0].backface_frac, 0.99f);
  for (int b = 0; b < 4; ++b) EXPECT_EQ(d[0].sky_vis[b], 0.f);
  for (const ProbeData& p : d)
    for (int c = 0; c < 3; ++c)
      for (int b = 0; b < 4; ++b)
        for (int k = 0; k < 4; ++k) EXPECT_TRUE(std::isfinite(p.prt[c][b][k]));
  // The reference inside the block: no light at all, finite.
  const auto scene = ReferenceScene::build(w, "block");
  ASSERT_TRUE(scene.has_value());
  ReferenceSettings s;
  s.samples = kSamples;
  const ReferenceIrradiance r = referenceIrradiance(*scene, ReferenceLighting{}, {glm::dvec3(20, 20, 3), glm::vec3(0, 0, 1), 0}, s);
  expectSound(r, "reference");
  EXPECT_EQ(r.ambient.mean, glm::vec3(0.f));
  // And the baked, relit world answers finite light there (placement moved or dropped it).
  const testing::BakedWorld b = testing::bakeWorld(w, Quality::kDraft, raytrace::SectorRange{0, 0, 0, 0});
  auto rt = testing::relit(b, 10.0, glm::dvec3(20, 20, 2));
  EXPECT_TRUE(finiteNonNegative(rt->ambient(glm::dvec3(20, 20, 3), glm::vec3(0, 0, 1)).irradiance));
}

TEST(StabilityFarFromTheOrigin, AWorld100KmAwayBakesAndRelightsToTheSameLight) {
  // Random numbers are keyed by sector key (sampling.h), so a world moved by whole sectors gets
  // other random numbers but the same geometry in every sector-local frame: the same probes and
  // grids, and light that differs from the origin's only as much as a bake with another seed.
  const glm::dvec3 far(1563 * 64.0, -1563 * 64.0, 0.0);  // 100.032 km
  auto bake = [](const worlds::World& w, uint64_t seed) {
    auto b = bakeInMemory(w, "box", BakeSettings::forQuality(Quality::kDefault, seed));
    EXPECT_TRUE(b.has_value());
    return testing::BakedWorld{std::move(b->sectors), std::move(b->manifest)};
  };
  const testing::BakedWorld a = bake(testBox(), 1), a2 = bake(testBox(), 2), b = bake(translated(testBox(), far), 1);
  ASSERT_EQ(a.sectors.size(), b.sectors.size());
  for (size_t i = 0; i < a.sectors.size(); ++i) {
    ASSERT_EQ(a.sectors[i].probes.size(), b.sectors[i].probes.size()) << "sector " << i;
    for (size_t p = 0; p < a.sectors[i].probes.size(); ++p)
      for (int k = 0; k < 3; ++k) EXPECT_EQ(a.sectors[i].probes[p].position[k], b.sectors[i].probes[p].position[k]);
    EXPECT_EQ(a.sectors[i].grid.cells, b.sectors[i].grid.cells) << "sector " << i;
  }
  auto ra = testing::relit(a, 9.0, glm::dvec3(0, 0, 2)), ra2 = testing::relit(a2, 9.0, glm::dvec3(0, 0, 2));
  auto rb = testing::relit(b, 9.0, glm::dvec3(0, 0, 2) + far);
  double far_diff = 0, seed_diff = 0, sum = 0;
  for (const ReferenceQuery& q : boxQueries()) {
    const glm::vec3 ea = ra->ambient(q.position, q.normal).irradiance, eb = rb->ambient(q.position + far, q.normal).irradiance;
    const glm::vec3 e2 = ra2->ambient(q.position, q.normal).irradiance;
    ASSERT_TRUE(finiteNonNegative(eb));
    for (int c = 0; c < 3; ++c) {
      far_diff += std::abs(eb[c] - ea[c]);
      seed_diff += std::abs(e2[c] - ea[c]);
      sum += ea[c];
    }
  }
  std::printf("relative L1 difference: 100 km away %.4f, another seed %.4f\n", far_diff / sum, seed_diff / sum);
  // Twice the seed-to-seed difference, plus 0.5% for the 8-bit volume steps.
  EXPECT_LT(far_diff / sum, 2.0 * seed_diff / sum + 0.005);
  // An offset that is not a whole number of sectors moves every float: the reference agrees
  // within its noise (five standard errors of the difference).
  const glm::dvec3 odd(100000.37, 99999.61, 0.0);
  const auto sa = ReferenceScene::build(testBox(), "box");
  const auto sb = ReferenceScene::build(translated(testBox(), odd), "box far");
  ASSERT_TRUE(sa.has_value() && sb.has_value());
  ReferenceSettings s;
  s.samples = 1024;
  const ReferenceLighting light{testBox().sky, 9.0, {}};
  for (const ReferenceQuery& q : boxQueries()) {
    const ReferenceIrradiance x = referenceIrradiance(*sa, light, q, s);
    ReferenceQuery qb = q;
    qb.position += odd;
    const ReferenceIrradiance y = referenceIrradiance(*sb, light, qb, s);
    for (int c = 0; c < 3; ++c) {
      const double se = std::hypot(x.ambient.std_error[c], y.ambient.std_error[c]);
      EXPECT_NEAR(y.ambient.mean[c], x.ambient.mean[c], 5 * se + 1e-4) << c;
    }
  }
}

TEST(StabilityOfTheCamera, TeleportingAwayAndBackGivesTheSameAmbient) {
  const testing::BakedWorld b = testing::bakeWorld(testBox(), Quality::kDraft);
  auto rt = testing::relit(b, 9.0, glm::dvec3(0, 0, 2));
  std::vector<glm::vec3> before;
  for (const ReferenceQuery& q : boxQueries()) before.push_back(rt->ambient(q.position, q.normal).irradiance);
  for (const glm::dvec3& cam : {glm::dvec3(1e5, -3e4, 50), glm::dvec3(-1e9, 1e9, 1e9), glm::dvec3(std::nan(""), 0, 0),
                                glm::dvec3(0, 0, 2), glm::dvec3(37.5, -12.25, 1)}) {
    rt->update(cam);
    for (const ReferenceQuery& q : boxQueries()) EXPECT_TRUE(finiteNonNegative(rt->ambient(q.position, q.normal).irradiance));
  }
  rt->update(glm::dvec3(0, 0, 2));
  const std::vector<ReferenceQuery> q = boxQueries();
  for (size_t i = 0; i < q.size(); ++i) EXPECT_EQ(rt->ambient(q[i].position, q[i].normal).irradiance, before[i]) << i;
  // A render from a camera far outside the world shows sky and stays finite.
  RenderOptions o;
  o.camera = RenderCamera{glm::dvec3(1e5, 1e5, 100), glm::dvec3(0, 0, 0), 40, 16, 9};
  auto r = render(testBox(), "box", b.manifest, b.sectors, o);
  ASSERT_TRUE(r.has_value());
  for (const glm::vec3& a : r->preview_ambient) EXPECT_TRUE(finiteNonNegative(a));
}

TEST(StabilityOfGeometry, DegenerateAndNonFiniteTrianglesAreSkippedNotFatal) {
  worlds::World w = testing::planeWorld(200.0, glm::vec3(0.5f));
  worlds::Mesh bad;
  bad.name = "bad";
  const float nan = std::numeric_limits<float>::quiet_NaN();
  bad.positions = {{0, 0, 1}, {1, 0, 1}, {2, 0, 1}, {0, 0, 1}, {0, 1, 2}, {nan, 0, 0}};
  bad.indices = {0, 1, 2,   // collinear
                 0, 3, 4,   // two equal vertices
                 0, 0, 0,   // a point
                 0, 5, 4,   // NaN
                 0, 1, 4};  // one good triangle
  w.meshes.push_back(bad);
  for (auto cls : {worlds::InstanceClass::kStatic, worlds::InstanceClass::kDynamic}) {
    worlds::Instance inst;
    inst.mesh = 1;
    inst.cls = cls;
    inst.transform = glm::translate(glm::dmat4(1.0), glm::dvec3(10, 10, 0));
    inst.name = "bad instance";
    w.instances.push_back(inst);
  }
  ReferenceRegion region;
  region.camera_view = true;
  const auto scene = ReferenceScene::build(w, "degenerate", region);
  ASSERT_TRUE(scene.has_value()) << scene.error().message;
  EXPECT_FALSE(scene->notes().empty());
  EXPECT_EQ(scene->triangleCount(), 2u + 1u);                    // plane + the good triangle
  EXPECT_EQ(scene->viewRays().triangleCount(), 2u + 1u + 1u);    // + its dynamic copy
  ReferenceSettings s;
  s.samples = kSamples;
  expectSound(referenceIrradiance(*scene, ReferenceLighting{}, {glm::dvec3(10.5, 10.2, 1.2), glm::vec3(0, 0, -1), 0}, s), "reference");
  const testing::BakedWorld b = testing::bakeWorld(w, Quality::kDraft, raytrace::SectorRange{0, 0, 0, 0});
  EXPECT_FALSE(b.sectors.empty());
  // A dynamic instance naming a mesh that does not exist is bad input, as a static one is
  // (World::validate): an error naming the world and the instance, not a crash.
  w.instances.back().mesh = 99;
  const auto missing = ReferenceScene::build(w, "missing mesh", region);
  ASSERT_FALSE(missing.has_value());
  EXPECT_NE(missing.error().message.find("missing mesh: instance " + std::to_string(w.instances.size() - 1) +
                                         " 'bad instance': mesh index 99 out of range"),
            std::string::npos)
      << missing.error().message;
}

TEST(StabilityOfLights, ALightExactlyOnAProbeOrOnTheQueryPointStaysFinite) {
  worlds::World w = testBox();
  w.lights.push_back(PointLight{"lamp", glm::dvec3(0, -6, 2), glm::vec3(8, 5, 2), 12.f});
  w.effects = worlds::defaultEffects(w);
  const testing::BakedWorld b = testing::bakeWorld(w, Quality::kDraft);
  ASSERT_FALSE(b.sectors.empty());
  ASSERT_TRUE(b.sectors[0].hasLprt());
  // Move the light onto a baked probe.
  const Sector& s0 = b.sectors[0];
  const ProbeData p = unpackProbe(s0.probes[0]);
  testing::BakedWorld moved = b;
  moved.manifest.lights[0].position =
      glm::dvec3(s0.key.ix * kSectorSizeM, s0.key.iy * kSectorSizeM, 0.0) + glm::dvec3(p.position);
  auto rt = testing::relit(moved, 21.0, moved.manifest.lights[0].position);
  for (const ReferenceQuery& q : boxQueries()) EXPECT_TRUE(finiteNonNegative(rt->ambient(q.position, q.normal).irradiance));
  EXPECT_TRUE(finiteNonNegative(rt->ambient(moved.manifest.lights[0].position, glm::vec3(0, 0, 1)).irradiance));
  // The reference with the light on the query point and on a surface.
  const auto scene = ReferenceScene::build(w, "box");
  ASSERT_TRUE(scene.has_value());
  ReferenceSettings rs;
  rs.samples = kSamples;
  for (const glm::dvec3& at : {moved.manifest.lights[0].position, glm::dvec3(-12.0, 0.0, 2.0)}) {
    ReferenceLighting light{w.sky, 21.0, {PointLight{"on", at, glm::vec3(8, 5, 2), 12.f}}};
    expectSound(referenceIrradiance(*scene, light, {at, glm::vec3(1, 0, 0), 0}, rs), "reference");
  }
}

}  // namespace
}  // namespace drtv::baker
