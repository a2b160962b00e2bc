// The sweep technique streamed (beginStreaming): a streamed fine grid is the grid prepare() builds
// for the same sector and hour, and at 100 m/s with the default lead every sector within the
// volume's reach has its fine grid before it gets there; without the lead it does not.
#include <cstring>

#include <gtest/gtest.h>

#include "drtv/eval/technique.h"
#include "drtv/streamer/streamer.h"
#include "streamer_world.h"

namespace drtv::eval {
namespace {

// Ground over sectors [0, nx) x [0, ny) with a building and a tree every other sector: enough
// material that fine grids differ from the coarse grid, cheap to voxelise.
worlds::World groundWorld(int nx, int ny) {
  worlds::World w;
  w.name = "ground";
  auto quad = [](glm::vec3 lo, glm::vec3 hi) {
    worlds::Mesh m;
    for (int i = 0; i < 8; ++i) m.positions.push_back({(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z});
    const uint32_t q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& f : q) m.indices.insert(m.indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
    return m;
  };
  auto add = [&](worlds::Mesh m, glm::vec3 albedo, worlds::InstanceClass cls, const char* name) {
    m.albedo = albedo;
    m.name = name;
    w.instances.push_back({uint32_t(w.meshes.size()), glm::dmat4(1.0), cls, name});
    w.meshes.push_back(std::move(m));
  };
  worlds::Mesh ground;
  const float X = 64.f * float(nx), Y = 64.f * float(ny);
  ground.positions = {{0, 0, 0}, {X, 0, 0}, {X, Y, 0}, {0, Y, 0}};
  ground.indices = {0, 1, 2, 0, 2, 3};
  add(std::move(ground), {0.3f, 0.45f, 0.2f}, worlds::InstanceClass::kTerrain, "ground");
  for (int y = 0; y < ny; ++y)
    for (int x = (y & 1); x < nx; x += 2) {
      const glm::vec3 o(64.f * float(x), 64.f * float(y), 0.f);
      add(quad(o + glm::vec3(20, 20, 0), o + glm::vec3(30, 28, 6)), {0.7f, 0.65f, 0.55f}, worlds::InstanceClass::kStatic, "house");
      add(quad(o + glm::vec3(40, 40, 3), o + glm::vec3(46, 46, 8)), {0.12f, 0.35f, 0.08f}, worlds::InstanceClass::kVegetation, "crown");
    }
  w.effects = kEffectSunBounce | kEffectSkyBounce | kEffectDirectSky | kEffectDistantOcclusion;
  return w;
}

std::unique_ptr<Technique> prepared(const worlds::World& w, raytrace::SectorRange block, const TechniqueParams& p, bool streaming) {
  auto t = makeTechnique("sweep", p);
  EXPECT_TRUE(t.has_value()) << t.error().message;
  PrepareInput in{w, "ground", block, 1, 2, nullptr};
  in.streaming = streaming;
  auto ok = (*t)->prepare(in);
  EXPECT_TRUE(ok.has_value()) << ok.error().message;
  return std::move(*t);
}

TEST(SweepStreaming, AStreamedFineGridIsTheOnePrepareBuiltForTheSameSectorAndHour) {
  testing::TempDir dir;
  testing::WorldSpec spec;
  spec.sectors_x = 3, spec.sectors_y = 2;
  const Manifest manifest = testing::writeWorld(dir.path() / "w.drtv", spec);
  const worlds::World w = groundWorld(3, 2);
  // offset=0: lookups at the cells' centres read one cell's words, so every word shows.
  const TechniqueParams p{{"offset", "0"}, {"resweep_h", "0.25"}};
  auto whole = prepared(w, {0, 2, 0, 1}, p, false);
  ASSERT_TRUE(whole->setLighting(9.0, {}).has_value());  // 9.0 h is a lighting step of 0.25 h
  auto streamed = prepared(w, {0, 2, 0, 1}, p, true);
  auto stream = streamed->beginStreaming({manifest, {}, 9.05, true});
  ASSERT_TRUE(stream.has_value()) << stream.error().message;
  for (const SectorEntry& e : manifest.sectors) {
    Sector s;
    s.key = e.key;
    (*stream)->onSectorLoaded(s, {});
  }
  const streamer::Camera cam{{96.0, 64.0, 20.0}, {0.0, 0.0, 0.0}};
  auto first = (*stream)->frame(cam, 0.0, 9.05, {});
  ASSERT_TRUE(first.has_value()) << first.error().message;
  EXPECT_EQ(first->reach, 6);
  EXPECT_EQ(first->missing, 6);  // nothing has landed yet: the coarse grid answers
  // The coarse grid's answers, to show the comparison below can fail.
  std::vector<glm::vec3> coarse_only;
  const glm::vec3 normals[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  auto points = [&](auto visit) {
    for (double z = -0.5; z < 10; z += 1.0)
      for (double y = 0.5; y < 128; y += 3.0)
        for (double x = 0.5; x < 192; x += 1.0)
          for (const glm::vec3& n : normals) visit(glm::dvec3(x, y, z), n);
  };
  points([&](const glm::dvec3& q, const glm::vec3& n) { coarse_only.push_back(streamed->ambient(q, n)); });
  double t = 0.0;
  for (int i = 0; i < 600 && !(*stream)->frame(cam, t, 9.05, {})->idle; ++i) t += 1.0 / 60.0;
  auto last = (*stream)->frame(cam, t, 9.05, {});
  ASSERT_TRUE(last.has_value());
  EXPECT_TRUE(last->idle);
  EXPECT_EQ(last->missing, 0);
  EXPECT_EQ(last->held, 6);
  size_t differ = 0, differ_from_coarse = 0, i = 0;
  points([&](const glm::dvec3& q, const glm::vec3& n) {
    const glm::vec3 a = whole->ambient(q, n), b = streamed->ambient(q, n);
    differ += std::memcmp(&a, &b, sizeof a) != 0;
    differ_from_coarse += std::memcmp(&b, &coarse_only[i++], sizeof b) != 0;
  });
  EXPECT_EQ(differ, 0u);
  EXPECT_GT(differ_from_coarse, i / 2);
}

// Flies a camera along x at 100 m/s (60 Hz, the hour moving 0.2 h/s) over a strip of sectors with
// the streamer in its deterministic mode; returns the sector-frames within reach without a fine
// grid. `held_max_after` receives the most fine grids held in the last frame.
int64_t flyStrip(const TechniqueParams& p, int* reach_max, int* held_last) {
  testing::TempDir dir;
  constexpr int kNx = 12, kNy = 4;
  testing::WorldSpec spec;
  spec.sectors_x = kNx, spec.sectors_y = kNy;
  const Manifest manifest = testing::writeWorld(dir.path() / "strip.drtv", spec);
  const worlds::World w = groundWorld(kNx, kNy);
  auto t = prepared(w, {0, kNx - 1, 0, kNy - 1}, p, true);
  streamer::StreamerOptions so;
  so.io_mode = streamer::IoMode::kDeterministic;
  auto file = streamer::FileSectorSource::open(dir.path() / "strip.drtv");
  EXPECT_TRUE(file.has_value());
  if (!file) return -1;
  streamer::Streamer s(manifest, std::shared_ptr<streamer::SectorSource>(std::move(*file)), so);
  auto stream = t->beginStreaming({manifest, so.residency, 8.0, true});
  EXPECT_TRUE(stream.has_value());
  if (!stream) return -1;
  const double dt = 1.0 / 60.0, speed = 100.0;
  streamer::Camera cam{{100.0, 120.0, 30.0}, {speed, 0.0, 0.0}};
  // Warm-up at the start, as `drtv fly` does.
  double time_s = -10.0;
  for (int i = 0; i < 600; ++i, time_s += dt) {
    s.update(cam, time_s, **stream);
    auto f = (*stream)->frame(cam, time_s, 8.0, {});
    if (s.idle() && f && f->idle) break;
  }
  int64_t misses = 0;
  *reach_max = 0;
  for (int frame = 0; cam.position_m.x < 64.0 * kNx - 100.0; ++frame) {
    const double t_s = frame * dt;
    cam.position_m.x = 100.0 + speed * t_s;
    s.update(cam, t_s, **stream);
    auto f = (*stream)->frame(cam, t_s, 8.0 + 0.2 * t_s, {});
    EXPECT_TRUE(f.has_value());
    if (!f) return -1;
    misses += f->missing;
    *reach_max = std::max(*reach_max, f->reach);
    *held_last = f->held;
  }
  return misses;
}

TEST(SweepStreaming, EverySectorWithinReachHasItsFineGridInTimeAt100MetresPerSecond) {
  int reach = 0, held = 0;
  // The defaults: a lead of 1 s and a 32 m margin, one worker taking 50 ms a sector.
  EXPECT_EQ(flyStrip({}, &reach, &held), 0);
  EXPECT_GE(reach, 12);  // the 192 m footprint covers 3-4 x 4 sectors of the strip
  // Grids of the sectors left behind were dropped: what is held is the footprint grown by the
  // margin (5 x 4 sectors) and the sectors 100 m ahead (2 more columns of 4), of the strip's 48.
  EXPECT_LE(held, 28);
  // Without a lead and with slow sweeps (0.3 s a sector) the same flight misses: the count bites.
  int reach2 = 0, held2 = 0;
  EXPECT_GT(flyStrip({{"lead_s", "0"}, {"margin_m", "0"}, {"job_s", "0.3"}}, &reach2, &held2), 0);
}

}  // namespace
}  // namespace drtv::eval
