// Physics through the whole pipeline, for every directional representation (issue 13): a grey
// plane (albedo 0.5) under a uniform white sky or a sun in a black sky, baked in memory, written
// to an archive and read back, set up with runtimeForArchive, relit, filled into the volume and
// shaded by Runtime::ambient 2 m above the plane, against the closed-form answers:
//   uniform sky L = 1:   up pi, sideways 3 pi / 4, down pi / 2 (ground radiance rho L)
//   sun of irradiance E at elevation e, black sky:
//                        down rho E sin e (the ground bounce), sideways rho E sin e / 2, up 0.
// The talk's representation (fc3) misses these by design; its values are asserted as the
// documented properties they are (the windowed band-1 sun, the shading weights), so that fc3's
// figures cannot move unnoticed. sh-l1 is held to the physics.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "drtv/baker/bake.h"
#include "drtv/reference/reference.h"
#include "drtv/formats/archive.h"
#include "drtv/runtime/runtime.h"
#include "test_scenes.h"

namespace drtv {
namespace {

using testing::kPi;

constexpr double kPlaneSizeM = 20000.0;
constexpr float kRho = 0.5f;
// The tolerances. 3 %: band-1 SH is exact for a uniform sky over a plane (the sky and
// the ground are each a uniform hemisphere, whose irradiance is linear in n), so what is left is
// Monte-Carlo noise of the bake (256 rays per basis, ~1 %), the 8-bit texels (1/255 of the HDR
// scale ~0.4 % of the brightest colour, 1/127 for band 1). (A plane has no interreflection: one
// bounce is all there is, so the surface cache's bounce count does not enter.)
constexpr double kUniformSkyRel = 0.03;
// 10 % for the sun's ground bounce at elevations 20..90 deg, and the up normal below 0.01 E.
constexpr double kSunBounceRel = 0.10;
constexpr double kUpNormalAbs = 0.01;
// fc3's documented properties are held to 3 %: the same noise and quantisation as above.
constexpr double kFc3PropertyRel = 0.03;

struct Plane {
  Manifest manifest;
  std::filesystem::path archive;
};

// Bakes sector (0, 0) of the plane world in `representation` and writes it to an archive.
Plane bakePlane(Representation representation, const Sky& sky) {
  worlds::World world = testing::planeWorld(kPlaneSizeM, glm::vec3(kRho));
  world.sky = sky;
  baker::BakeSettings settings = baker::BakeSettings::forQuality(baker::Quality::kDefault, 1);
  settings.transfer.probe_rays_per_basis = 256;
  settings.transfer.representation = representation;
  auto baked = baker::bakeInMemory(world, "plane", settings, raytrace::SectorRange{0, 0, 0, 0});
  EXPECT_TRUE(baked.has_value()) << (baked ? "" : baked.error().message);
  Plane p;
  // Named after the test too: ctest runs the tests of this file in parallel processes, and two
  // writing one path read each other's half-written archive.
  p.archive = std::filesystem::path(::testing::TempDir()) /
              ("plane_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
               representationName(representation) + ".drtv");
  auto w = ArchiveWriter::create(p.archive);
  EXPECT_TRUE(w.has_value());
  for (const Sector& s : baked->sectors) EXPECT_TRUE(w->addSector(s).has_value());
  EXPECT_TRUE(w->finish(baked->manifest).has_value());
  return p;
}

// Ambient (channel R) 2 m above sector (0, 0)'s centre for each normal, at `hour`, read back
// from the archive the way an engine sets up.
struct Ambient {
  double up, side, down;
};
Ambient ambientOverPlane(Representation representation, const Sky& sky, double hour,
                         float sun_window = runtime::kSunLobeOfRepresentation,
                         float sun_band0 = 1.f) {
  const Plane plane = bakePlane(representation, sky);
  auto reader = ArchiveReader::open(plane.archive);
  EXPECT_TRUE(reader.has_value()) << (reader ? "" : reader.error().message);
  if (!reader) return {};
  const Manifest& m = reader->manifest();
  EXPECT_EQ(m.representation, representation);
  runtime::RuntimeOptions options = runtime::optionsForEffects(m.effects);
  options.sun_band1_window = sun_window;
  options.sun_band0_scale = sun_band0;
  auto rt = runtime::runtimeForArchive(m, options, hour);
  EXPECT_TRUE(rt.has_value());
  for (const SectorEntry& e : m.sectors) {
    auto s = reader->readSector(e.key);
    EXPECT_TRUE(s.has_value());
    EXPECT_TRUE((*rt)->addSector(*s).has_value());
  }
  const glm::dvec3 at(32.0, 32.0, 2.0);
  (*rt)->update(at);
  auto e = [&](glm::vec3 n) { return double((*rt)->ambient(at, n).irradiance.r); };
  Ambient a{e({0, 0, 1}), e({1, 0, 0}), e({0, 0, -1})};
  std::filesystem::remove(plane.archive);
  return a;
}

double rel(double got, double want) { return (got - want) / want; }

TEST(PlanePhysics, ShL1MatchesAUniformSkyWithin3Percent) {
  const Ambient a = ambientOverPlane(Representation::kShL1, testing::uniformSky(1.f, 1.f), 12.0);
  RecordProperty("up", std::to_string(a.up));
  RecordProperty("side", std::to_string(a.side));
  RecordProperty("down", std::to_string(a.down));
  EXPECT_NEAR(rel(a.up, kPi), 0.0, kUniformSkyRel) << a.up;
  EXPECT_NEAR(rel(a.side, 0.75 * kPi), 0.0, kUniformSkyRel) << a.side;
  EXPECT_NEAR(rel(a.down, 0.5 * kPi), 0.0, kUniformSkyRel) << a.down;
}

// fc3 under the uniform sky: the talk's shading weights on the four basis colours. The basis
// colours themselves are exact (analytic_baked_test.cpp); the weights lose 10 % at the up normal
// and add 13 % sideways (the table: 2.816, 2.659, 1.586). Asserted so that fc3 stays what
// it is; the error is the representation's, not a bug.
TEST(PlanePhysics, Fc3UnderAUniformSkyKeepsTheTalksWeightsErrors) {
  const Ambient a = ambientOverPlane(Representation::kFc3, testing::uniformSky(1.f, 1.f), 12.0);
  RecordProperty("up", std::to_string(a.up));
  RecordProperty("side", std::to_string(a.side));
  RecordProperty("down", std::to_string(a.down));
  EXPECT_NEAR(rel(a.up, 2.816), 0.0, kFc3PropertyRel) << a.up;
  EXPECT_NEAR(rel(a.side, 2.659), 0.0, kFc3PropertyRel) << a.side;
  EXPECT_NEAR(rel(a.down, 1.586), 0.0, kFc3PropertyRel) << a.down;
  EXPECT_LT(a.up, 0.95 * kPi);  // the up normal misses physics by more than the tolerance
}

// fc3's sun bounce is the windowed band-1 lobe's (lighting_sh.h): rho E (1/4 + w/2 sin e) at the
// down normal (the down basis' weight is 1 there), -25 % .. -50 % of rho E sin e for 30..90 deg.
TEST(PlanePhysics, Fc3SunBounceIsTheWindowedBandOneLobes) {
  for (double elevation : {30.0, 60.0, 90.0}) {
    const Ambient a = ambientOverPlane(Representation::kFc3, testing::sunOnlySky(1.f, elevation), 12.0);
    const double s = std::sin(elevation * kPi / 180.0);
    const double model = kRho * (0.25 + 0.5 * runtime::kHanningBand1 * s);
    RecordProperty("down_" + std::to_string(int(elevation)), std::to_string(a.down));
    EXPECT_NEAR(rel(a.down, model), 0.0, kFc3PropertyRel) << elevation << " deg: " << a.down;
    if (elevation >= 60.0) {
      EXPECT_LT(a.down, 0.8 * kRho * s) << "fc3 misses the physics at " << elevation << " deg";
    }
  }
}

// The sun lobes measured for sh-l1 (lighting_sh.h), printed as a table for docs/accuracy.md.
TEST(PlanePhysics, SunLobesMeasuredForShL1) {
  struct Lobe {
    const char* name;
    float window, band0;
  } lobes[] = {{"hanning", runtime::kHanningBand1, 1.f}, {"unwindowed", runtime::kNoWindowBand1, 1.f}, {"linear", runtime::kLinearSunBand1, 0.f}};
  for (const Lobe& l : lobes)
    for (double elevation : {20.0, 30.0, 45.0, 60.0, 90.0}) {
      const Ambient a = ambientOverPlane(Representation::kShL1, testing::sunOnlySky(1.f, elevation), 12.0, l.window, l.band0);
      const double s = std::sin(elevation * kPi / 180.0);
      std::printf("[ sun ] %-10s %4.0f deg  down %.4f (exact %.4f, %+.1f %%)  side %.4f (%+.1f %%)  up %.4f\n", l.name, elevation,
                  a.down, kRho * s, 100 * rel(a.down, kRho * s), a.side, 100 * rel(a.side, 0.5 * kRho * s), a.up);
    }
}

TEST(PlanePhysics, ShL1SunBounceIsWithin10PercentAndNothingComesFromAbove) {
  for (double elevation : {20.0, 30.0, 45.0, 60.0, 90.0}) {
    const Ambient a = ambientOverPlane(Representation::kShL1, testing::sunOnlySky(1.f, elevation), 12.0);
    const double s = std::sin(elevation * kPi / 180.0);
    RecordProperty("down_" + std::to_string(int(elevation)), std::to_string(a.down));
    RecordProperty("up_" + std::to_string(int(elevation)), std::to_string(a.up));
    EXPECT_NEAR(rel(a.down, kRho * s), 0.0, kSunBounceRel) << elevation << " deg: " << a.down << " vs " << kRho * s;
    EXPECT_NEAR(rel(a.side, 0.5 * kRho * s), 0.0, kSunBounceRel) << elevation << " deg sideways: " << a.side;
    EXPECT_LT(std::fabs(a.up), kUpNormalAbs) << elevation << " deg up: " << a.up;
  }
}

// A box mesh from `lo` to `hi`, outward-facing (counter-clockwise seen from outside).
worlds::Mesh boxMesh(const glm::vec3& lo, const glm::vec3& hi, const glm::vec3& albedo) {
  worlds::Mesh m;
  m.name = "box";
  for (int i = 0; i < 8; ++i) m.positions.push_back({i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z});
  const uint32_t faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) m.indices.insert(m.indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
  m.albedo = albedo;
  return m;
}

// The sun's ground bounce in a wall's shadow, against the path tracer: a plane (albedo 0.5)
// with a wall 10 m high along x at y = 30 (the noon sun at 60 deg, from -y, shades the ground
// from y = 30.5 to 36.3), black sky, a down-facing normal 1 m above the shaded ground. The band-1
// lobe cannot see the shadow: the shaded ground sees most of the sky, so the linear lobe lights it
// as if the sun did. The sun transfer traces it (transfer.h).
struct ShadowCase {
  double drtv, reference, reference_error;
};
ShadowCase sunBounceInAWallsShadow(int sun_samples) {
  worlds::World world = testing::planeWorld(kPlaneSizeM, glm::vec3(kRho));
  world.meshes.push_back(boxMesh({-300.f, 30.f, 0.f}, {364.f, 30.5f, 10.f}, glm::vec3(kRho)));
  worlds::Instance wall;
  wall.mesh = 1;
  wall.transform = glm::dmat4(1.0);
  wall.cls = worlds::InstanceClass::kStatic;
  wall.name = "wall";
  world.instances.push_back(wall);
  world.sky = testing::sunOnlySky(1.f, 60.0);
  baker::BakeSettings settings = baker::BakeSettings::forQuality(baker::Quality::kDefault, 1);
  settings.transfer.representation = Representation::kShL1;
  settings.transfer.sun_samples = sun_samples;
  auto baked = baker::bakeInMemory(world, "wall", settings, raytrace::SectorRange{0, 0, 0, 0});
  EXPECT_TRUE(baked.has_value()) << (baked ? "" : baked.error().message);
  if (!baked) return {};
  runtime::RuntimeOptions options = runtime::optionsForEffects(baked->manifest.effects);
  auto rt = runtime::runtimeForArchive(baked->manifest, options, 12.0);
  EXPECT_TRUE(rt.has_value());
  for (const Sector& s : baked->sectors) EXPECT_TRUE((*rt)->addSector(s).has_value());
  const glm::dvec3 at(32.0, 33.5, 1.0);
  (*rt)->update(at);
  ShadowCase c;
  c.drtv = (*rt)->ambient(at, glm::vec3(0, 0, -1)).irradiance.r;
  auto scene = reference::ReferenceScene::build(world, "wall");
  EXPECT_TRUE(scene.has_value());
  reference::ReferenceLighting light;
  light.sky = world.sky;
  light.hour = 12.0;
  reference::ReferenceSettings rs;
  rs.samples = 8192;
  const reference::ReferenceIrradiance r = reference::referenceIrradiance(*scene, light, {at, glm::vec3(0, 0, -1), 1}, rs);
  c.reference = r.ambient.mean.r;
  c.reference_error = r.ambient.std_error.r;
  return c;
}

TEST(PlanePhysics, ShL1SunTransferSeesAWallsShadowThePathTracerSees) {
  const ShadowCase with = sunBounceInAWallsShadow(6), without = sunBounceInAWallsShadow(0);
  std::printf("[ shadow ] reference %.4f +- %.4f; sh-l1 with the sun transfer %.4f (%+.1f %%), without %.4f (%+.1f %%); open ground %.4f\n",
              with.reference, with.reference_error, with.drtv, 100 * rel(with.drtv, with.reference), without.drtv,
              100 * rel(without.drtv, without.reference), kRho * std::sin(60.0 * kPi / 180.0));
  RecordProperty("reference", std::to_string(with.reference));
  RecordProperty("with", std::to_string(with.drtv));
  RecordProperty("without", std::to_string(without.drtv));
  EXPECT_LT(std::fabs(with.drtv - with.reference), 0.5 * std::fabs(without.drtv - with.reference));
}

// A clear-sky gradient over the plane, no sun: L = H + (Z - H) sqrt(z), zenith darker than the
// horizon in every channel (the tropical default's day colours). The up normal sees the upper
// hemisphere only, so its ambient is the direct sky, pi (H + 0.8 (Z - H)) exactly. sh-l1's
// band-1 fit of the six axis irradiances (probe.h kProbeSkyFit) cannot be exact at every axis
// (the sqrt(z) gradient is not linear in n; docs/accuracy.md): with equal weights it reads
// pi (H + 0.737 (Z - H)) at the up normal, 0.0633 pi |Z - H| off (+8.9 / +4.6 / +1.7 % in R / G /
// B). The bake weighs each axis by the probe's receivers (transfer.cpp, kSkyFitReceiverWeight):
// over the plane every receiver faces up, and the up normal reads +3.2 / +2.2 / +0.5 %
// (measured), 0.0245 pi |Z - H| in red. The tolerance is 0.035 pi |Z - H| plus the uniform sky's
// 3 %; the unweighted fit (+0.0633) and the masked band-1 projection of archive version 2
// (pi (H + 0.683 (Z - H)), 0.117 off) fall outside it in the red channel.
TEST(PlanePhysics, ShL1UnderASkyGradientReadsTheUpNormalWithinItsReceiverWeightedFit) {
  Sky sky = testing::uniformSky(0.f, 0.f);
  const glm::vec3 zenith(0.125f, 0.225f, 0.45f), horizon(0.35f, 0.42f, 0.55f);
  sky.sky_zenith = testing::constant(zenith);
  sky.sky_horizon = testing::constant(horizon);
  const Plane plane = bakePlane(Representation::kShL1, sky);
  auto reader = ArchiveReader::open(plane.archive);
  ASSERT_TRUE(reader.has_value());
  auto rt = runtime::runtimeForArchive(reader->manifest(), runtime::optionsForEffects(reader->manifest().effects), 12.0);
  ASSERT_TRUE(rt.has_value());
  for (const SectorEntry& e : reader->manifest().sectors) ASSERT_TRUE((*rt)->addSector(*reader->readSector(e.key)).has_value());
  const glm::dvec3 at(32.0, 32.0, 2.0);
  (*rt)->update(at);
  const glm::vec3 up = (*rt)->ambient(at, glm::vec3(0, 0, 1)).irradiance;
  std::filesystem::remove(plane.archive);
  for (int c = 0; c < 3; ++c) {
    const double delta = double(zenith[c]) - horizon[c];
    const double exact = kPi * (horizon[c] + 0.8 * delta);
    const double tolerance = 0.035 * kPi * std::fabs(delta) + kUniformSkyRel * exact;
    std::printf("[ gradient ] channel %d: up %.4f, exact %.4f (%+.1f %%), the unweighted fit's %.4f\n", c, up[c], exact,
                100 * rel(up[c], exact), kPi * (horizon[c] + 0.737 * delta));
    EXPECT_NEAR(up[c], exact, tolerance) << "channel " << c;
  }
}

}  // namespace
}  // namespace drtv
