// The talk's test box (slides 7-9, worlds/fc3_testbox.json): the bounce colours on the dynamic
// spheres follow the sun — red from the red wall (x = -12.5) when the morning sun lights its
// east face, blue from the blue wall (x = +12.5) in the afternoon, green from the terrain below —
// in the reference and in the baked, relit system. Checked as numbers, not pictures.
#include <gtest/gtest.h>

#include <cstdio>

#include "drtv/reference/reference.h"
#include "drtv/eval/render.h"
#include "drtv/worlds/load.h"
#include "baked_world.h"

namespace drtv::baker {
using namespace reference;
using namespace eval;
namespace {

constexpr double kMorning = 8.0, kAfternoon = 16.0;
// What the sun adds when it moves onto a wall, E(wall lit) - E(wall in shadow) on the side of a
// sphere that faces the wall, must be the wall's colour: its channel at least this many times
// either other channel. The reference measures 5x (red) and 2.7x (blue), the default bake 2.5x and
// 2.4x (printed below; the blue side also gains green from the terrain the same sun lights). 1.5
// fails a swapped wall, a mirrored sun path or a bounce that does not follow the sun.
constexpr double kDominance = 1.5;
// Paths per reference query: the standard error of each channel is then ~1% of its mean.
constexpr int kReferenceSamples = 4096;

struct Side {
  const char* name;
  glm::dvec3 centre;  // sphere centre (the test box's spheres have radius 1 m)
  glm::vec3 normal;
  glm::dvec3 point() const { return centre + glm::dvec3(normal); }
};
const Side kWestSphereWestSide{"west sphere, upper west side", {-6, 0, 1.3}, glm::normalize(glm::vec3(-1, 0, 0.7f))};
const Side kEastSphereEastSide{"east sphere, upper east side", {6, 0, 1.3}, glm::normalize(glm::vec3(1, 0, 0.7f))};
const Side kCentreSphereUnderside{"centre sphere, underside", {0, 0, 1.3}, glm::normalize(glm::vec3(0, -1, -1))};

const worlds::World& testBox() {
  static const worlds::World w = [] {
    auto r = worlds::loadWorld(DRTV_SOURCE_DIR "/worlds/fc3_testbox.json");
    EXPECT_TRUE(r.has_value()) << (r ? "" : r.error().message);
    return std::move(*r);
  }();
  return w;
}

glm::dvec3 referenceAt(const Side& side, double hour) {
  static const ReferenceScene scene = *ReferenceScene::build(testBox(), "fc3_testbox");
  ReferenceSettings s;
  s.samples = kReferenceSamples;
  const ReferenceLighting light{testBox().sky, hour, testBox().lights};
  const ReferenceIrradiance r = referenceIrradiance(scene, light, {side.point(), side.normal, 1}, s);
  return glm::dvec3(r.ambient.mean);
}

glm::dvec3 bakedAt(const Side& side, double hour) {
  static const testing::BakedWorld baked = testing::bakeWorld(testBox(), Quality::kDefault);
  return glm::dvec3(testing::ambientAt(baked, hour, side.point(), side.normal, glm::dvec3(0, 0, 2)));
}

void expectTheTalksColours(glm::dvec3 (*ambient)(const Side&, double), const char* system) {
  // The upper sides of the outer spheres face the walls; the four talk bases see them best there
  // (a horizontal normal takes half its ambient from the down basis, i.e. from the terrain).
  const glm::dvec3 red = ambient(kWestSphereWestSide, kMorning) - ambient(kWestSphereWestSide, kAfternoon);
  const glm::dvec3 blue = ambient(kEastSphereEastSide, kAfternoon) - ambient(kEastSphereEastSide, kMorning);
  std::printf("%s: red wall lit adds %.3f %.3f %.3f; blue wall lit adds %.3f %.3f %.3f\n", system, red.r, red.g, red.b,
              blue.r, blue.g, blue.b);
  EXPECT_GT(red.r, kDominance * std::max(red.g, red.b)) << system << ": the morning sun's bounce off the red wall";
  EXPECT_GT(blue.b, kDominance * std::max(blue.r, blue.g)) << system << ": the afternoon sun's bounce off the blue wall";
  for (double hour : {kMorning, kAfternoon}) {
    const glm::dvec3 under = ambient(kCentreSphereUnderside, hour);
    std::printf("%s: underside at %.0f h: %.3f %.3f %.3f\n", system, hour, under.r, under.g, under.b);
    EXPECT_GT(under.g, kDominance * std::max(under.r, under.b)) << system << ": green bounce from the terrain at " << hour << " h";
  }
}

TEST(TestBoxReference, ShowsRedInTheMorningBlueInTheAfternoonAndGreenFromBelow) {
  expectTheTalksColours(referenceAt, "reference");
}

TEST(TestBoxBakedAndRelit, ShowsRedInTheMorningBlueInTheAfternoonAndGreenFromBelow) {
  expectTheTalksColours(bakedAt, "baked");
}

TEST(TestBoxRender, GivesFiniteNonNegativeImagesOfTheAskedSize) {
  const testing::BakedWorld& baked = [] -> const testing::BakedWorld& {
    static const testing::BakedWorld b = testing::bakeWorld(testBox(), Quality::kDraft);
    return b;
  }();
  RenderOptions o;
  o.camera.width = 64;
  o.camera.height = 36;
  o.hour = kMorning;
  o.reference = true;
  o.reference_samples = 8;
  auto r = render(testBox(), "fc3_testbox", baked.manifest, baked.sectors, o);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  EXPECT_EQ(r->preview.pixels.size(), 64u * 36u * 3u);
  EXPECT_EQ(r->error.pixels.size(), 64u * 36u * 3u);
  EXPECT_GT(r->stats.pixels_hit, 64u * 36u / 3);
  for (size_t i = 0; i < r->hit.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_TRUE(std::isfinite(r->preview_ambient[i][c]) && r->preview_ambient[i][c] >= 0.f) << i;
      ASSERT_TRUE(std::isfinite(r->reference_ambient[i][c]) && r->reference_ambient[i][c] >= 0.f) << i;
    }
  }
  EXPECT_TRUE(std::isfinite(r->stats.mean_abs_rel_error));
}

// A view whose ground is black (albedo 0, as the palm-tree asset's water) keeps the automatic
// exposure on what is lit: the walls and spheres are not burnt to white.
TEST(TestBoxRender, ABlackGroundInViewLeavesTheLitSurfacesUnsaturated) {
  worlds::World w = testBox();
  for (worlds::Instance& in : w.instances)
    if (in.cls == worlds::InstanceClass::kTerrain) w.meshes[in.mesh].albedo = glm::vec3(0.f);
  const testing::BakedWorld baked = testing::bakeWorld(w, Quality::kDraft);
  RenderOptions o;
  o.camera.width = 64;
  o.camera.height = 36;
  o.hour = kMorning;
  o.camera.position = {0.0, -14.0, 16.0};  // looking down: most of the view is the ground
  auto r = render(w, "fc3_testbox, black ground", baked.manifest, baked.sectors, o);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  size_t lit = 0, white = 0;
  for (size_t i = 0; i < r->hit.size(); ++i) {
    const uint8_t* p = &r->preview.pixels[i * 3];
    if (!r->hit[i] || (p[0] == 0 && p[1] == 0 && p[2] == 0)) continue;
    ++lit;
    white += p[0] >= 245 && p[1] >= 245 && p[2] >= 245;  // ACES reaches 255 only asymptotically
  }
  ASSERT_GT(lit, 64u * 36u / 20) << "the walls and spheres are in view";
  EXPECT_LT(white, lit / 10) << white << " of " << lit << " lit pixels burnt to white; exposure " << r->stats.exposure;
}

}  // namespace
}  // namespace drtv::baker
