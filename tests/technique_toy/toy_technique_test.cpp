// A technique added from outside eval/ (toy_technique.h) with one registration line gets, through
// the generic paths alone, its rows in the accuracy table (its own knob rows and its "technique"
// row) and a preview render.
#include <gtest/gtest.h>

#include <cmath>

#include "../reference/baked_world.h"
#include "../reference/test_scenes.h"
#include "drtv/eval/accuracy.h"
#include "drtv/eval/render.h"
#include "toy_technique.h"

namespace drtv::toy {
namespace {

// The one registration line.
const bool kRegistered = eval::registerTechnique<ToyTechnique>().has_value();

worlds::World plane() {
  worlds::World w = testing::planeWorld(100.0, glm::vec3(0.5f));
  w.sky = testing::uniformSky(1.f, 1.f);
  return w;
}

const eval::AccuracyRow* find(const eval::AccuracyReport& r, const std::string& knob, const std::string& value) {
  for (const eval::AccuracyRow& row : r.rows)
    if (row.knob == knob && row.value == value) return &row;
  return nullptr;
}

TEST(ToyTechnique, IsRegisteredUnderItsNames) {
  ASSERT_TRUE(kRegistered);
  EXPECT_NE(eval::registeredTechniqueNames().find("toy, toy-bright"), std::string::npos) << eval::registeredTechniqueNames();
  auto bad = eval::makeTechnique("toy", {{"level", "11"}});
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().message, "technique toy: level=11: expected a number in [0, 10]");
}

TEST(ToyTechnique, GetsItsKnobRowsAndItsTechniqueRowInTheAccuracyTable) {
  ASSERT_TRUE(kRegistered);
  eval::AccuracyOptions o;
  o.hours = {12.0};
  o.points = 8;
  o.reference_samples = 8;
  o.probe_samples = 4;
  o.threads = 2;
  o.timing_repeats = 1;
  o.techniques = {"toy"};
  o.knobs = {"toy"};
  const worlds::World w = plane();
  auto r = eval::measureAccuracy(w, "plane", o);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  const eval::AccuracyRow* half = find(*r, "toy_level", "0.5");
  const eval::AccuracyRow* one = find(*r, "toy_level", "1");
  const eval::AccuracyRow* two = find(*r, "toy_level", "2");
  const eval::AccuracyRow* row = find(*r, "technique", "toy");
  ASSERT_TRUE(half && one && two && row);
  EXPECT_FALSE(half->is_default);
  EXPECT_TRUE(one->is_default);
  EXPECT_EQ(find(*r, "technique", "toy-bright"), nullptr) << "--techniques toy only";
  // The toy's ambient scales with `level`, so its sum over the points does: (bias + 1) is that sum
  // over the reference's, and doubles from one level to the next.
  EXPECT_NEAR(two->bias + 1.0, 2.0 * (one->bias + 1.0), 1e-5 * (two->bias + 1.0));
  EXPECT_NEAR(one->bias + 1.0, 2.0 * (half->bias + 1.0), 1e-5 * (one->bias + 1.0));
  // The technique row is the technique at its defaults: the default knob row's figures.
  EXPECT_EQ(row->rel_error, one->rel_error);
  EXPECT_EQ(row->bias, one->bias);
  // Nothing runs per frame (FrameWork::kNone).
  EXPECT_TRUE(std::isnan(row->relight_fill_ms));
  // --knobs rejects a technique without rows by name.
  o.knobs = {"toy-bright"};
  auto none = eval::measureAccuracy(w, "plane", o);
  ASSERT_FALSE(none.has_value());
  EXPECT_NE(none.error().message.find("technique 'toy-bright' declares no knob rows"), std::string::npos) << none.error().message;
}

TEST(ToyTechnique, RendersAPreviewThroughTheRenderer) {
  ASSERT_TRUE(kRegistered);
  const worlds::World w = plane();
  const testing::BakedWorld baked = testing::bakeWorld(w, baker::Quality::kDraft);
  eval::RenderOptions o;
  o.camera.width = 32;
  o.camera.height = 18;
  o.camera.position = {0.0, -20.0, 10.0};
  o.camera.target = {0.0, 0.0, 0.0};
  o.hour = 12.0;
  o.technique = "toy";
  auto one = eval::render(w, "plane", baked.manifest, baked.sectors, o);
  ASSERT_TRUE(one.has_value()) << one.error().message;
  o.technique_params = {{"level", "2"}};
  auto two = eval::render(w, "plane", baked.manifest, baked.sectors, o);
  ASSERT_TRUE(two.has_value()) << two.error().message;
  ASSERT_GT(one->stats.pixels_hit, 0u);
  // Every pixel of the ground is shaded by the toy: pi x the zenith radiance facing up, times level.
  const float expected = 3.14159265f * w.sky.skyRadiance(glm::dvec3(0, 0, 1), 12.0).r;
  size_t checked = 0;
  for (size_t i = 0; i < one->hit.size(); ++i) {
    if (!one->hit[i]) continue;
    EXPECT_NEAR(one->preview_ambient[i].r, expected, 1e-4f * expected) << i;
    EXPECT_NEAR(two->preview_ambient[i].r, 2.f * one->preview_ambient[i].r, 1e-5f * expected) << i;
    ++checked;
  }
  EXPECT_GT(checked, 0u);
}

}  // namespace
}  // namespace drtv::toy
