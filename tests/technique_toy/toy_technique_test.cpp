// A technique added from outside eval/ (toy_technique.h) with one registration line gets, through
// the generic paths alone, its rows in the accuracy table (its own knob rows and its "technique"
// row), a preview render and a flight.
#include <gtest/gtest.h>

#include <cmath>

#include "../reference/baked_world.h"
#include "../reference/test_scenes.h"
#include "drtv/eval/accuracy.h"
#include "drtv/eval/render.h"
#include "drtv/fly/fly.h"
#include "drtv/streamer/streamer.h"
#include "streamer_world.h"
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

TEST(ToyTechnique, FliesThroughAStreamedArchive) {
  ASSERT_TRUE(kRegistered);
  ::drtv::testing::TempDir dir;
  ::drtv::testing::WorldSpec spec;
  spec.sectors_x = 3, spec.sectors_y = 2;
  ::drtv::testing::writeWorld(dir.path() / "w.drtv", spec);
  streamer::StreamerOptions so;
  so.io_mode = streamer::IoMode::kDeterministic;
  auto s = streamer::Streamer::open(dir.path() / "w.drtv", so);
  ASSERT_TRUE(s.has_value()) << s.error().message;
  auto t = eval::makeTechnique("toy");
  ASSERT_TRUE(t.has_value());
  ASSERT_EQ((*t)->streamingRuntime((*s)->manifest()), std::nullopt) << "the toy runs on its own";
  const worlds::World w = plane();
  auto flight = (*t)->prepareFlight(w, "plane", {(*s)->manifest(), so.residency, 9.0, true});
  ASSERT_TRUE(flight.has_value()) << flight.error().message;
  EXPECT_EQ(flight->sink, nullptr) << "the toy does not stream per sector";
  fly::FlyOptions fo;
  fo.frames = 12;
  fo.warmup_frames = 0;
  fo.snapshots = 0;
  fo.runtime = false;
  fo.technique = (*t)->describe();
  fo.technique_frame = [frame = flight->frame](const streamer::Camera& cam, double time_s, double hour,
                                               const std::vector<PointLight>& lights) -> Result<fly::TechniqueFrameCost> {
    auto f = frame(cam, time_s, hour, lights);
    if (!f) return std::unexpected(f.error());
    return fly::TechniqueFrameCost{f->frame_ms, f->inline_ms, f->reach, f->missing, f->stale, f->held, f->bytes, f->idle};
  };
  auto r = fly::fly(**s, fly::defaultFlightPath((*s)->manifest(), false), fo, "w.drtv");
  ASSERT_TRUE(r.has_value()) << r.error().message;
  ASSERT_EQ(r->frames.size(), 12u);
  EXPECT_EQ(static_cast<const ToyTechnique&>(**t).updates(), 12) << "one update a frame";
  for (const fly::FlyFrame& f : r->frames) {
    EXPECT_EQ(f.technique.reach, -1) << "not streamed";
    EXPECT_EQ(f.technique_ms, 0.0) << "nothing runs per frame";
  }
}

}  // namespace
}  // namespace drtv::toy
