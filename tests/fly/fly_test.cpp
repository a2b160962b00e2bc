// Flight paths and the fly-through report.
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "drtv/fly/fly.h"
#include "streamer_world.h"

namespace drtv::fly {
using namespace streamer;
namespace {

// The arc-length table's chord error on these gentle test paths (see flight_path.cpp): 1 cm.
constexpr double kArcLengthToleranceM = 0.01;

TEST(CatmullRomPath, PassesThroughEveryWaypoint) {
  const std::vector<glm::dvec3> pts{{0, 0, 10}, {100, 50, 10}, {200, 0, 20}, {300, 80, 10}};
  auto p = CatmullRomPath::create(pts, false);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR(glm::length(p->position(0) - pts[0]), 0, 1e-9);
  EXPECT_NEAR(glm::length(p->position(p->lengthM()) - pts[3]), 0, 1e-9);
  // Each inner waypoint is on the curve: the nearest sampled point is within the sampling step.
  for (size_t i = 1; i + 1 < pts.size(); ++i) {
    double best = 1e9;
    for (double s = 0; s <= p->lengthM(); s += 0.01) best = std::min(best, glm::length(p->position(s) - pts[i]));
    EXPECT_LT(best, 0.01);
  }
}

TEST(CatmullRomPath, IsParametrisedByArcLength) {
  auto p = CatmullRomPath::create({{0, 0, 0}, {100, 100, 0}, {250, 50, 0}, {400, 200, 0}}, false);
  ASSERT_TRUE(p.has_value());
  const double ds = 1.0;
  for (double s = 0; s + ds < p->lengthM(); s += 7.3)
    EXPECT_NEAR(glm::length(p->position(s + ds) - p->position(s)), ds, kArcLengthToleranceM) << s;
  EXPECT_NEAR(glm::length(p->direction(10.0)), 1.0, 1e-9);
}

TEST(CatmullRomPath, LoopsWrapAround) {
  auto p = CatmullRomPath::create({{0, 0, 0}, {100, 0, 0}, {100, 100, 0}, {0, 100, 0}}, true);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR(glm::length(p->position(p->lengthM() + 5.0) - p->position(5.0)), 0, 1e-6);
  EXPECT_NEAR(glm::length(p->position(-5.0) - p->position(p->lengthM() - 5.0)), 0, 1e-6);
}

TEST(CatmullRomPath, RejectsTooFewOrRepeatedWaypoints) {
  EXPECT_FALSE(CatmullRomPath::create({{0, 0, 0}}, false).has_value());
  EXPECT_FALSE(CatmullRomPath::create({{0, 0, 0}, {1, 1, 1}}, true).has_value());
  auto dup = CatmullRomPath::create({{0, 0, 0}, {0, 0, 0}, {5, 5, 5}}, false);
  ASSERT_FALSE(dup.has_value());
  EXPECT_NE(dup.error().message.find("waypoint 1"), std::string::npos);
}

TEST(CatmullRomPath, RejectsWaypointsBeyondTenThousandKilometres) {
  auto far = CatmullRomPath::create({{0, 0, 0}, {1e12, 0, 0}}, false);
  ASSERT_FALSE(far.has_value());
  EXPECT_NE(far.error().message.find("waypoint 1: beyond"), std::string::npos) << far.error().message;
}

TEST(LoadFlightPath, LoopMustBeABoolean) {
  testing::TempDir dir;
  std::ofstream(dir.path() / "p.json") << R"({"loop": 1, "waypoints": [[0,0,5],[100,0,5],[50,80,5]]})";
  auto p = loadFlightPath(dir.path() / "p.json");
  ASSERT_FALSE(p.has_value());
  EXPECT_NE(p.error().message.find("p.json: \"loop\": expected true or false"), std::string::npos) << p.error().message;
}

TEST(Fly, BadOptionsAreErrorsNotCrashes) {
  testing::TempDir dir;
  testing::writeWorld(dir.path() / "w.drtv", {});
  StreamerOptions so;
  so.io_mode = IoMode::kDeterministic;
  auto s = Streamer::open(dir.path() / "w.drtv", so);
  ASSERT_TRUE(s.has_value());
  const CatmullRomPath path = defaultFlightPath((*s)->manifest(), false);
  auto with = [](auto change) {
    FlyOptions o;
    o.frames = 10;
    change(o);
    return o;
  };
  const FlyOptions bad[] = {
      with([](FlyOptions& o) { o.fps = std::nan(""); }),          with([](FlyOptions& o) { o.speed_mps = -1.0; }),
      with([](FlyOptions& o) { o.hours_per_s = INFINITY; }),      with([](FlyOptions& o) { o.frames = -3; }),
      with([](FlyOptions& o) { o.frames = kMaxFlyFrames + 1; }),
      // The path once at 1 nm/s would take ~1e12 frames.
      with([](FlyOptions& o) { o.frames = 0, o.speed_mps = 1e-9; }),
  };
  for (const FlyOptions& o : bad) {
    auto r = fly(**s, path, o, "w.drtv");
    ASSERT_FALSE(r.has_value());
    EXPECT_EQ(r.error().message.rfind("fly: ", 0), 0u) << r.error().message;
  }
}

TEST(LoadFlightPath, ReadsWaypointsAndNamesABadOne) {
  testing::TempDir dir;
  {
    std::ofstream(dir.path() / "ok.json") << R"({"loop": true, "waypoints": [[0,0,5],[100,0,5],[50,80,5]]})";
    std::ofstream(dir.path() / "bad.json") << R"({"waypoints": [[0,0,5],[100,"x",5]]})";
  }
  auto ok = loadFlightPath(dir.path() / "ok.json");
  ASSERT_TRUE(ok.has_value()) << ok.error().message;
  EXPECT_TRUE(ok->closed());
  auto bad = loadFlightPath(dir.path() / "bad.json");
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("waypoints[1]"), std::string::npos) << bad.error().message;
}

TEST(DefaultFlightPath, StaysInsideTheWorldBounds) {
  Manifest m;
  m.bounds_min = {-500, 200, 0};
  m.bounds_max = {1500, 1200, 80};
  for (bool loop : {false, true}) {
    const CatmullRomPath p = defaultFlightPath(m, loop);
    for (double s = 0; s < p.lengthM(); s += 5) {
      const glm::dvec3 q = p.position(s);
      EXPECT_GE(q.x, m.bounds_min.x);
      EXPECT_LE(q.x, m.bounds_max.x);
      EXPECT_GE(q.y, m.bounds_min.y);
      EXPECT_LE(q.y, m.bounds_max.y);
    }
  }
}

FlyResult flyOnce(const std::filesystem::path& archive, bool runtime) {
  StreamerOptions so;
  so.io_mode = IoMode::kDeterministic;
  auto s = Streamer::open(archive, so);
  EXPECT_TRUE(s.has_value());
  FlyOptions fo;
  fo.runtime = runtime;
  fo.frames = 400;
  auto r = fly(**s, defaultFlightPath((*s)->manifest(), false), fo, archive.string());
  EXPECT_TRUE(r.has_value()) << r.error().message;
  return std::move(*r);
}

TEST(Fly, DeterministicFlightsGiveTheSameFramesAndNoMissesAt100MetresPerSecond) {
  testing::TempDir dir;
  testing::writeWorld(dir.path() / "w.drtv", {});
  const FlyResult a = flyOnce(dir.path() / "w.drtv", true), b = flyOnce(dir.path() / "w.drtv", false);
  ASSERT_EQ(a.frames.size(), b.frames.size());
  for (size_t i = 0; i < a.frames.size(); ++i) {
    const FrameStats &x = a.frames[i].stats, &y = b.frames[i].stats;
    EXPECT_EQ(std::tie(x.resident, x.in_flight, x.loads, x.evictions, x.misses, x.resident_bytes),
              std::tie(y.resident, y.in_flight, y.loads, y.evictions, y.misses, y.resident_bytes))
        << "frame " << i;
  }
  const FlySummary s = summarize(a);
  EXPECT_EQ(s.misses, 0);
  EXPECT_EQ(s.max_resident, kMaxResidentSectors);
  EXPECT_LE(s.max_reserved_bytes, kBudgetBytesWithoutLprt);
  EXPECT_GT(a.volume_bytes, 0u);
}

// 32 lights on vehicles driving at 100 m/s around the flight (plus a flicker), over a world with
// LPRT, at 0.2 h/s: the streamer keeps up (no misses), the resident bytes stay within the LPRT
// budget, and every frame sets the moved lights and relights.
TEST(Fly, ThirtyTwoMovingLightsAtHundredMetresPerSecondStayWithinTheLprtBudget) {
  testing::TempDir dir;
  const Manifest m = testing::writeWorld(dir.path() / "lit.drtv", {.lprt_sources = 128, .holes = {}});
  StreamerOptions so;
  so.io_mode = IoMode::kDeterministic;
  auto s = Streamer::open(dir.path() / "lit.drtv", so);
  ASSERT_TRUE(s.has_value());
  FlyOptions fo;
  fo.frames = 300;
  fo.hours_per_s = 0.2;
  fo.start_hour = 19.0;
  const CatmullRomPath path = defaultFlightPath(m, false);
  for (int i = 0; i < 32; ++i) {
    PointLight l{"vehicle " + std::to_string(i), path.position(0.0), glm::vec3(20.f), 12.f};
    LightPath p;
    const glm::dvec3 offset(8.0 * (i % 8) - 28.0, 8.0 * (i / 8) - 12.0, 2.0);
    for (int k = 0; k <= 10; ++k) {
      const double t = 0.5 * k;  // 5 s: 500 m along the camera's path at 100 m/s
      p.keys.push_back({t, path.position(100.0 * t) + offset, glm::vec3(k % 2 ? 12.f : 20.f), 12.f});
    }
    fo.lights.push_back(l);
    fo.light_paths.push_back(p);
  }
  auto r = fly(**s, path, fo, "lit.drtv");
  ASSERT_TRUE(r.has_value()) << r.error().message;
  const FlySummary sum = summarize(*r);
  EXPECT_EQ(sum.misses, 0);
  EXPECT_LE(sum.max_reserved_bytes, kBudgetBytesWithLprt);
  EXPECT_GT(sum.max_reserved_bytes, kBudgetBytesWithoutLprt) << "the sectors carry LPRT";
  // Every frame relights: all of it when the time of day moved past the threshold, else only the
  // sectors the moved lights reach (after sunset the sky changes slowly).
  int relit = 0;
  for (const FlyFrame& f : r->frames) relit += (f.full_relight || f.lights_relit) && f.lights_ms > 0.0;
  EXPECT_EQ(relit, int(r->frames.size()));
  EXPECT_NE(r->runtime_note.find("32 of 32 lights move"), std::string::npos) << r->runtime_note;

  // A path that is not one is an error naming the light, not a flight.
  fo.light_paths[3].keys.resize(1);
  auto bad = fly(**s, path, fo, "lit.drtv");
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("lights[3].path.keys"), std::string::npos) << bad.error().message;
}

// The adds and the volume update on a worker (FlyOptions::volume_worker): the same streaming,
// the same relights frame by frame, every frame's update done by the worker and reported, and
// the volume one frame late. (That the worker publishes the very texels an inline update does is
// tests/runtime/update_worker_test.cpp's.)
TEST(Fly, TheWorkerFliesTheSameFramesAndReportsItsUpdates) {
  testing::TempDir dir;
  const Manifest m = testing::writeWorld(dir.path() / "lit.drtv", {.lprt_sources = 128, .holes = {}});
  auto flyWith = [&](bool worker) {
    StreamerOptions so;
    so.io_mode = IoMode::kDeterministic;
    auto s = Streamer::open(dir.path() / "lit.drtv", so);
    EXPECT_TRUE(s.has_value());
    FlyOptions fo;
    fo.frames = 150;
    fo.fps = 500.0;        // kept to real time with the worker: 0.3 s
    fo.speed_mps = 2000.0;  // 600 m: sectors stream in and out
    fo.hours_per_s = 40.0;  // the time of day relights every frame
    fo.volume_worker = worker;
    auto r = fly(**s, defaultFlightPath(m, false), fo, "lit.drtv");
    EXPECT_TRUE(r.has_value()) << r.error().message;
    return std::move(*r);
  };
  const FlyResult a = flyWith(false), b = flyWith(true);
  ASSERT_EQ(a.frames.size(), b.frames.size());
  int64_t loads = 0;
  for (size_t i = 0; i < a.frames.size(); ++i) {
    const FlyFrame &x = a.frames[i], &y = b.frames[i];
    EXPECT_EQ(std::tie(x.stats.resident, x.stats.loads, x.stats.evictions, x.stats.misses, x.full_relight, x.lights_relit,
                       x.runtime_probes),
              std::tie(y.stats.resident, y.stats.loads, y.stats.evictions, y.stats.misses, y.full_relight, y.lights_relit,
                       y.runtime_probes))
        << "frame " << i;
    EXPECT_GT(y.worker_ms, 0.0) << "frame " << i;
    EXPECT_GT(y.runtime_probes, 0) << "frame " << i;
    EXPECT_EQ(x.worker_ms, 0.0);
    loads += x.stats.loads;
  }
  EXPECT_GT(loads, 20);
  const FlySummary sa = summarize(a), sb = summarize(b);
  EXPECT_EQ(sa.full_relights, sb.full_relights);
  EXPECT_GT(sb.full_relights, 100);
  EXPECT_FALSE(sa.volume_worker);
  EXPECT_EQ(sa.volume_late_frames, 0);
  EXPECT_TRUE(sb.volume_worker);
  EXPECT_EQ(sb.volume_late_frames, 1);
  EXPECT_GT(sb.worker_ms_p99, 0.0);
  EXPECT_EQ(b.runtime_note.find("rejected"), std::string::npos) << b.runtime_note;
  EXPECT_NE(b.runtime_note.find("one frame late"), std::string::npos) << b.runtime_note;
  EXPECT_EQ(a.volume_bytes, b.volume_bytes);
}

TEST(Fly, WritesCsvJsonMarkdownAndPngs) {
  testing::TempDir dir;
  testing::writeWorld(dir.path() / "w.drtv", {});
  const FlyResult r = flyOnce(dir.path() / "w.drtv", true);
  const auto out = dir.path() / "report";
  auto ok = writeFlyReport(r, out);
  ASSERT_TRUE(ok.has_value()) << ok.error().message;
  for (const char* f : {"frames.csv", "fly-report.json", "fly-report.md", "resident-bytes.png", "frame-time.png"})
    EXPECT_TRUE(std::filesystem::exists(out / f)) << f;
  std::ifstream j(out / "fly-report.json");
  const auto json = nlohmann::json::parse(j);
  EXPECT_EQ(json["summary"]["frames"], 400);
  EXPECT_EQ(json["snapshots"].size(), 4u);
  for (const auto& name : json["snapshots"]) EXPECT_TRUE(std::filesystem::exists(out / name.get<std::string>()));
  int lines = 0;
  std::ifstream csv(out / "frames.csv");
  for (std::string l; std::getline(csv, l);) ++lines;
  EXPECT_EQ(lines, 401);
}

}  // namespace
}  // namespace drtv::fly
