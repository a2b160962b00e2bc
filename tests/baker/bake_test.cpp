// The whole bake: archive contents, budgets, determinism, resumption, shards, bad input.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <map>

#include "drtv/baker/accuracy.h"
#include "drtv/baker/bake.h"
#include "drtv/baker/placement.h"
#include "drtv/baker/ray_scene.h"
#include "drtv/baker/world_geometry.h"
#include "drtv/formats/archive.h"
#include "test_worlds.h"

namespace drtv::baker {
namespace {
namespace fs = std::filesystem;

// A scratch directory per test, removed at the end.
struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("drtv_baker_test_" + std::to_string(::getpid()) + "_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

std::vector<char> readBytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

BakeOptions draft(int threads = 0) {
  BakeOptions o;
  o.quality = Quality::kDraft;
  o.threads = threads;
  return o;
}

worlds::World litWorld() {
  worlds::World w = test::smallWorld();
  w.lights.push_back({"lamp", {10.0, 10.0, 2.0}, glm::vec3(5.f), 12.f});
  w.effects |= kEffectLocalLights;
  return w;
}

TEST(Bake, ProbeRecordIs152Bytes) { EXPECT_EQ(sizeof(ProbeRecord), 152u); }

TEST(Bake, OneAndTwoThreadsWriteByteIdenticalArchives) {
  TempDir dir;
  const worlds::World w = test::smallWorld();
  auto one = bake(w, "small", dir.path / "one.drtv", draft(1));
  ASSERT_TRUE(one) << one.error().message;
  auto two = bake(w, "small", dir.path / "two.drtv", draft(2));
  ASSERT_TRUE(two) << two.error().message;
  EXPECT_TRUE(one->packed && two->packed);
  const auto a = readBytes(dir.path / "one.drtv"), b = readBytes(dir.path / "two.drtv");
  ASSERT_FALSE(a.empty());
  EXPECT_TRUE(a == b) << "1 and 2 threads must give identical bytes";
  EXPECT_FALSE(fs::exists(sectorDirectory(dir.path / "one.drtv"))) << "sector files are removed after packing";
}

TEST(Bake, ArchiveHoldsEverySectorWithItsManifest) {
  TempDir dir;
  worlds::World w = test::smallWorld();
  w.interiors.push_back({"house", {15.4, 16.4, 0.0}, {24.6, 23.6, 3.0}, {20.0, 20.0, 1.5}, 0.5f});
  w.effects |= kEffectInteriors;
  auto r = bake(w, "small", dir.path / "a.drtv", draft());
  ASSERT_TRUE(r) << r.error().message;
  auto reader = ArchiveReader::open(dir.path / "a.drtv");
  ASSERT_TRUE(reader) << reader.error().message;
  const Manifest& m = reader->manifest();
  EXPECT_EQ(m.sectors.size(), 4u);
  EXPECT_EQ(m.bounds_min.x, -64.0);
  EXPECT_EQ(m.bounds_max.y, 64.0);
  EXPECT_TRUE(m.effects & kEffectInteriors);
  EXPECT_FALSE(m.effects & kEffectLocalLights);
  EXPECT_EQ(m.setting("quality"), "draft");
  EXPECT_EQ(m.interiors.size(), 1u);
  EXPECT_EQ(m.sky.latitude_rad, w.sky.latitude_rad);
  bool designated = false;
  for (const SectorEntry& e : m.sectors) {
    auto s = reader->readSector(e.key);
    ASSERT_TRUE(s) << s.error().message;
    EXPECT_GT(s->probes.size(), 40u);
    EXPECT_TRUE(s->has_ground);
    for (uint8_t c : s->grid.cells) EXPECT_LT(c, s->probes.size());
    for (const ProbeRecord& p : s->probes) designated |= (p.flags & kProbeInterior) && p.interior == 1;
  }
  EXPECT_TRUE(designated);
}

// Talk slide 22: "a little bit less than 15KB" per sector of about 70 probes, in bytes (1 KB =
// 1000 B here, the stricter reading): 64 header + 70 x 152 probes + 4096 grid + 128 ground.
TEST(Bake, SectorOfAbout70ProbesWithoutLprtIsUnder15KB) {
  EXPECT_LT(encodedSectorBytes(70, 0, true), 15000u);
  TempDir dir;
  auto r = bake(test::smallWorld(), "small", dir.path / "a.drtv", draft());
  ASSERT_TRUE(r);
  for (const SectorStats& s : r->sectors) {
    EXPECT_EQ(s.bytes, s.bytes_without_lprt);
    if (s.probes <= 70) {
      EXPECT_LT(s.bytes, 15000u) << toString(s.key) << " with " << s.probes << " probes";
    }
  }
}

// Talk slide 22: LPRT adds "210KB" per sector: 70 probes x 128 sources x 4 x 3 x 2 B = 215,040 B
// = 210 KiB exactly, plus the 512 B source table (KiB = 1024 B here).
TEST(Bake, LprtAddsAtMost210KiBPerSectorOfAbout70Probes) {
  TempDir dir;
  auto r = bake(litWorld(), "lit", dir.path / "a.drtv", draft());
  ASSERT_TRUE(r) << r.error().message;
  for (const SectorStats& s : r->sectors) {
    EXPECT_LE(s.lprt_sources, 128u);
    EXPECT_GT(s.lprt_sources, 0u);
    EXPECT_EQ(s.bytes - s.bytes_without_lprt, s.probes * s.lprt_sources * 24 + s.lprt_sources * 4);
    if (s.probes <= 70) {
      EXPECT_LE(s.bytes - s.bytes_without_lprt, 210u * 1024u + 512u);
    }
  }
  auto reader = ArchiveReader::open(dir.path / "a.drtv");
  ASSERT_TRUE(reader);
  EXPECT_TRUE(reader->manifest().effects & kEffectLocalLights);
  auto s = reader->readSector(reader->manifest().sectors[0].key);
  ASSERT_TRUE(s);
  EXPECT_TRUE(s->hasLprt());
  EXPECT_TRUE(s->lprt.on_bases);
  float biggest = 0.f;
  for (int16_t q : s->lprt.coeffs) biggest = std::max(biggest, float(std::abs(q)));
  EXPECT_GT(biggest, 0.f) << "the lamp's sources bounce light";
}

// Each sector names its LPRT sources by (neighbour, probe index), placing its neighbours again in
// its own scene. Those indices must be the neighbours' own probes: same count, same order, same
// positions as the neighbour's bake wrote.
TEST(Bake, LprtSourcesNameTheNeighboursOwnProbes) {
  TempDir dir;
  const worlds::World world = litWorld();
  auto r = bake(world, "lit", dir.path / "a.drtv", draft());
  ASSERT_TRUE(r) << r.error().message;
  // The packer checked every source against its neighbour (reconcileLprtSources): none was off.
  for (const std::string& note : r->notes) EXPECT_EQ(note.find("LPRT"), std::string::npos) << note;
  auto reader = ArchiveReader::open(dir.path / "a.drtv");
  ASSERT_TRUE(reader);
  auto geometry = WorldGeometry::build(world, "lit");
  ASSERT_TRUE(geometry);
  const BakeSettings settings = BakeSettings::forQuality(Quality::kDraft);
  int compared = 0;
  for (const SectorEntry& e : reader->manifest().sectors) {
    const SectorGeometry g = geometry->gather(e.key, settings.lprt_halo_m);
    auto scene = RayScene::build(g.vertices);
    ASSERT_TRUE(scene);
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const SectorKey nk{e.key.ix + dx, e.key.iy + dy};
        if (!reader->manifest().find(nk)) continue;
        auto neighbour = reader->readSector(nk);
        ASSERT_TRUE(neighbour);
        PlacementStats ps;
        const std::vector<PlacedProbe> again = placeProbes(*scene, g, {dx, dy}, {}, settings.placement, ps);
        ASSERT_EQ(again.size(), neighbour->probes.size()) << toString(e.key) << " placing " << toString(nk);
        for (size_t i = 0; i < again.size(); ++i) {
          const float* q = neighbour->probes[i].position;
          EXPECT_NEAR(again[i].position.x - float(dx * kSectorSizeM), q[0], 1e-3f) << toString(nk) << " probe " << i;
          EXPECT_NEAR(again[i].position.y - float(dy * kSectorSizeM), q[1], 1e-3f) << toString(nk) << " probe " << i;
          EXPECT_NEAR(again[i].position.z, q[2], 1e-3f) << toString(nk) << " probe " << i;
        }
        ++compared;
      }
  }
  EXPECT_GT(compared, 4);
}

TEST(Bake, NoLprtBlockAtAllWithoutLocalLights) {
  TempDir dir;
  worlds::World w = test::smallWorld();
  w.effects |= kEffectLocalLights;  // asked for, but there is no light
  auto r = bake(w, "small", dir.path / "a.drtv", draft());
  ASSERT_TRUE(r);
  bool reported = false;
  for (const auto& s : r->effects_skipped) reported |= s.starts_with("local_lights");
  EXPECT_TRUE(reported);
  auto reader = ArchiveReader::open(dir.path / "a.drtv");
  ASSERT_TRUE(reader);
  EXPECT_FALSE(reader->manifest().effects & kEffectLocalLights);
  for (const SectorEntry& e : reader->manifest().sectors) {
    EXPECT_EQ(e.lprt_sources, 0u);
    auto s = reader->readSector(e.key);
    ASSERT_TRUE(s);
    EXPECT_FALSE(s->hasLprt());
    EXPECT_EQ(s->lprt.coeffs.size(), 0u);
    for (const ProbeRecord& p : s->probes) EXPECT_EQ(p.lprt_range, 0.f);
  }
}

TEST(Bake, DynamicInstancesDoNotChangeTheArchive) {
  TempDir dir;
  worlds::World with = test::smallWorld(), without = test::smallWorld();
  without.instances.pop_back();  // the dynamic crate
  ASSERT_TRUE(bake(with, "small", dir.path / "a.drtv", draft()));
  ASSERT_TRUE(bake(without, "small", dir.path / "b.drtv", draft()));
  EXPECT_TRUE(readBytes(dir.path / "a.drtv") == readBytes(dir.path / "b.drtv"));
}

TEST(Bake, AnInterruptedBakeResumesAndGivesTheSameArchive) {
  TempDir dir;
  const worlds::World w = test::smallWorld();
  ASSERT_TRUE(bake(w, "small", dir.path / "fresh.drtv", draft()));
  // "Interrupted": only one sector done, its files kept.
  BakeOptions part = draft();
  part.sectors = SectorRange{-1, -1, -1, -1};
  part.keep_sector_files = true;
  part.shard_count = 2;  // a shard never packs
  part.shard_index = 0;
  auto first = bake(w, "small", dir.path / "resumed.drtv", part);
  ASSERT_TRUE(first) << first.error().message;
  EXPECT_FALSE(first->packed);
  auto rest = bake(w, "small", dir.path / "resumed.drtv", draft());
  ASSERT_TRUE(rest) << rest.error().message;
  size_t resumed = 0;
  for (const auto& s : rest->sectors) resumed += s.resumed;
  EXPECT_EQ(resumed, 1u);
  EXPECT_TRUE(readBytes(dir.path / "fresh.drtv") == readBytes(dir.path / "resumed.drtv"));
}

// A bake killed in the middle of writing a sector leaves a torn record at the end of its shard's
// journal; a bit flipped on disk leaves a record whose hash fails. Either way the whole records
// before it are resumed and the bad one (and any after it in that journal) is baked again: same
// archive as a clean bake.
TEST(Bake, ATornOrCorruptJournalRecordIsBakedAgain) {
  TempDir dir;
  const worlds::World w = test::smallWorld();
  ASSERT_TRUE(bake(w, "small", dir.path / "fresh.drtv", draft()));
  enum Damage { kTornTail, kCorruptLast, kCorruptFirst };
  for (const Damage damage : {kTornTail, kCorruptLast, kCorruptFirst}) {
    SCOPED_TRACE(int(damage));
    const fs::path archive = dir.path / ("damaged" + std::to_string(int(damage)) + ".drtv");
    BakeOptions part = draft();
    part.shard_count = 2;
    part.shard_index = 0;
    auto first = bake(w, "small", archive, part);
    ASSERT_TRUE(first) << first.error().message;
    ASSERT_GE(first->sectors.size(), 2u);
    const fs::path log = fs::path(archive.string() + ".sectors") / "sectors-0-of-2.log";
    ASSERT_TRUE(fs::exists(log));
    const auto size = fs::file_size(log);
    if (damage == kTornTail) {
      fs::resize_file(log, size - 100);
    } else {
      const std::streamoff at = damage == kCorruptLast ? std::streamoff(size - 200) : 100;
      std::fstream f(log, std::ios::in | std::ios::out | std::ios::binary);
      f.seekg(at);
      const char byte = char(f.get() ^ 0x10);
      f.seekp(at);
      f.put(byte);
    }
    auto rest = bake(w, "small", archive, draft());
    ASSERT_TRUE(rest) << rest.error().message;
    size_t resumed = 0;
    for (const auto& s : rest->sectors) resumed += s.resumed;
    // All but the last record of shard 0; none when its first record is bad.
    EXPECT_EQ(resumed, damage == kCorruptFirst ? 0u : first->sectors.size() - 1);
    EXPECT_TRUE(readBytes(dir.path / "fresh.drtv") == readBytes(archive));
  }
}

TEST(Bake, TwoBakesOfTheSameShardAtOnceAreRefused) {
  TempDir dir;
  const fs::path sectors = dir.path / "a.drtv.sectors";
  fs::create_directories(sectors);
  // Another process holds this shard's journal (flock is per open file, so a second open in this
  // process stands for it).
  const int fd = ::open((sectors / "sectors-0-of-2.log").c_str(), O_RDWR | O_CREAT, 0644);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX | LOCK_NB), 0);
  BakeOptions o = draft();
  o.shard_count = 2;
  auto r = bake(test::smallWorld(), "small", dir.path / "a.drtv", o);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("another bake is writing"), std::string::npos) << r.error().message;
  // Nor may a --fresh bake of other settings (shard 1 here) discard the journal under it.
  BakeOptions other = o;
  other.shard_index = 1;
  other.quality = Quality::kDefault;
  other.fresh = true;
  {
    std::ofstream stamp(sectors / "bake.txt");
    stamp << "0000000000000000";  // a different bake's fingerprint
  }
  auto f = bake(test::smallWorld(), "small", dir.path / "a.drtv", other);
  ASSERT_FALSE(f);
  EXPECT_NE(f.error().message.find("another bake is writing"), std::string::npos) << f.error().message;
  EXPECT_TRUE(fs::exists(sectors / "sectors-0-of-2.log"));
  ::close(fd);
  o.fresh = true;  // bake.txt now names another bake
  auto after = bake(test::smallWorld(), "small", dir.path / "a.drtv", o);
  EXPECT_TRUE(after) << after.error().message;
}

TEST(Bake, ShardsMergeIntoTheSameArchiveAsOneBake) {
  TempDir dir;
  const worlds::World w = test::smallWorld();
  ASSERT_TRUE(bake(w, "small", dir.path / "one.drtv", draft()));
  for (int k = 0; k < 3; ++k) {
    BakeOptions o = draft();
    o.shard_index = k;
    o.shard_count = 3;
    auto r = bake(w, "small", dir.path / "sharded.drtv", o);
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_FALSE(r->packed);
  }
  BakeOptions merge = draft();
  merge.merge_only = true;
  auto m = bake(w, "small", dir.path / "sharded.drtv", merge);
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_TRUE(m->packed);
  EXPECT_TRUE(readBytes(dir.path / "one.drtv") == readBytes(dir.path / "sharded.drtv"));
}

TEST(Bake, MergeWithMissingShardsIsAnError) {
  TempDir dir;
  BakeOptions o = draft();
  o.shard_count = 2;
  ASSERT_TRUE(bake(test::smallWorld(), "small", dir.path / "a.drtv", o));
  BakeOptions merge = draft();
  merge.merge_only = true;
  auto m = bake(test::smallWorld(), "small", dir.path / "a.drtv", merge);
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("not baked yet"), std::string::npos) << m.error().message;
}

TEST(Bake, SectorFilesOfADifferentBakeAreRefusedUnlessFresh) {
  TempDir dir;
  BakeOptions o = draft();
  o.shard_count = 2;
  ASSERT_TRUE(bake(test::smallWorld(), "small", dir.path / "a.drtv", o));
  BakeOptions other = o;
  other.quality = Quality::kDefault;
  auto r = bake(test::smallWorld(), "small", dir.path / "a.drtv", other);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("different bake"), std::string::npos);
  other.fresh = true;
  EXPECT_TRUE(bake(test::smallWorld(), "small", dir.path / "a.drtv", other));
}

TEST(Bake, BadGeometryIsSkippedAndNamedInTheReport) {
  TempDir dir;
  worlds::World w = test::smallWorld();
  w.meshes[0].positions.push_back({0, 0, 0});
  w.meshes[0].positions.push_back({std::numeric_limits<float>::quiet_NaN(), 0, 0});
  w.meshes[0].indices.insert(w.meshes[0].indices.end(), {0, 4, 5});
  auto r = bake(w, "bad", dir.path / "a.drtv", draft());
  ASSERT_TRUE(r) << r.error().message;
  ASSERT_FALSE(r->notes.empty());
  EXPECT_NE(r->notes[0].find("'ground'"), std::string::npos);
  ASSERT_TRUE(writeReports(*r, dir.path / "r.json", dir.path / "r.md"));
  const auto md = readBytes(dir.path / "r.md");
  EXPECT_NE(std::string(md.begin(), md.end()).find("non-finite"), std::string::npos);
}

TEST(Bake, AbsurdSettingsAreAnErrorNotALoop) {
  TempDir dir;
  BakeOptions o = draft();
  for (auto change : std::initializer_list<void (*)(BakeSettings&)>{
           [](BakeSettings& s) { s.placement.column_spacing_m = 0.0; },
           [](BakeSettings& s) { s.placement.inside_test_rays = -1; },
           [](BakeSettings& s) { s.transfer.surfel_cell_m = std::numeric_limits<float>::quiet_NaN(); },
           [](BakeSettings& s) { s.transfer.bounces = 0; }}) {
    BakeSettings settings = BakeSettings::forQuality(Quality::kDraft);
    change(settings);
    o.settings = settings;
    auto r = bake(test::smallWorld(), "small", dir.path / "a.drtv", o);
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().message.rfind("bake settings: ", 0), 0u) << r.error().message;
    // The accuracy sweep's in-memory bake takes settings from its knobs: checked the same way.
    auto m = bakeInMemory(test::smallWorld(), "small", settings, std::nullopt, 0);
    ASSERT_FALSE(m);
    EXPECT_NE(m.error().message.find("bake settings: "), std::string::npos) << m.error().message;
  }
  for (Quality q : {Quality::kDraft, Quality::kDefault, Quality::kHigh}) {
    o.settings = BakeSettings::forQuality(q);
    o.sectors = SectorRange{0, 0, 0, 0};
    EXPECT_TRUE(bake(test::smallWorld(), "small", dir.path / "b.drtv", o)) << "every preset is valid";
  }
}

TEST(Bake, EmptyWorldIsAClearError) {
  TempDir dir;
  worlds::World w;
  auto r = bake(w, "empty.json", dir.path / "a.drtv", draft());
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("empty.json: nothing to bake"), std::string::npos);
}

TEST(Bake, ReportsSayWhatWasBakedAndSkipped) {
  TempDir dir;
  auto r = bake(test::smallWorld(), "small", dir.path / "a.drtv", draft());
  ASSERT_TRUE(r);
  ASSERT_TRUE(writeReports(*r, dir.path / "bake-report.json", dir.path / "bake-report.md"));
  const auto json = readBytes(dir.path / "bake-report.json");
  const std::string text(json.begin(), json.end());
  for (const char* key : {"\"per_sector\"", "\"invalid_dropped\"", "\"without_lprt\"", "\"per_second_wall\"", "\"skipped\"", "\"index_grid\""})
    EXPECT_NE(text.find(key), std::string::npos) << key;
}

// The packer's check of LPRT source indices, on a hand-made sector: sources baked for probes of
// the east and south neighbours. Indices that name those probes pass; an index that names another
// probe is re-indexed to the probe at the position the source was baked for; no probe there (or
// positions not matching the sources) is an error.
TEST(Bake, LprtSourceIndicesAreCheckedAndReindexedAtPacking) {
  std::map<SectorKey, std::vector<glm::vec3>> probes;
  probes[{1, 0}] = {{10.f, 10.f, 3.f}, {30.f, 12.f, 4.f}, {5.f, 50.f, 2.f}};
  probes[{0, -1}] = {{40.f, 60.f, 1.5f}};
  auto lookup = [&](SectorKey k) -> std::optional<std::span<const glm::vec3>> {
    const auto it = probes.find(k);
    if (it == probes.end()) return std::nullopt;  // outside the bake: not checked
    return std::span<const glm::vec3>(it->second);
  };
  Sector s;
  s.key = {0, 0};
  s.lprt.sources = {{1, 0, 2}, {0, -1, 0}};
  // In sector (0,0)'s frame: x + 64 for the east neighbour, y - 64 for the south one.
  const std::vector<glm::vec3> assumed = {{69.f, 50.f, 2.f}, {40.f, -4.f, 1.5f}};
  auto ok = reconcileLprtSources(s, assumed, lookup);
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(*ok, 0u);

  s.lprt.sources[0].probe = 1;  // names the wrong probe of (1,0)
  auto fixed = reconcileLprtSources(s, assumed, lookup);
  ASSERT_TRUE(fixed) << fixed.error().message;
  EXPECT_EQ(*fixed, 1u);
  EXPECT_EQ(s.lprt.sources[0].probe, 2);
  EXPECT_EQ(s.lprt.sources[1].probe, 0);

  std::vector<glm::vec3> moved = assumed;
  moved[1].x += 0.5f;  // no probe of (0,-1) there
  auto bad = reconcileLprtSources(s, moved, lookup);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("sector (0,-1) at"), std::string::npos) << bad.error().message;
  EXPECT_FALSE(reconcileLprtSources(s, std::span(assumed).first(1), lookup));

  probes[{0, -1}].clear();  // in the bake, without probes: the source names nothing
  EXPECT_FALSE(reconcileLprtSources(s, assumed, lookup));
  probes.erase({0, -1});  // outside the bake (--sectors): not checked
  auto outside = reconcileLprtSources(s, moved, lookup);
  ASSERT_TRUE(outside) << outside.error().message;
  EXPECT_EQ(*outside, 0u);
}

// A lit world baked in part (--sectors): the edge sectors' sources in neighbours outside the
// range cannot be checked, and packing must not call that a bug.
TEST(Bake, ALitWorldBakesInPart) {
  TempDir dir;
  BakeOptions o = draft();
  o.sectors = SectorRange{0, 0, 0, 0};
  auto r = bake(litWorld(), "lit", dir.path / "part.drtv", o);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_TRUE(r->packed);
  ASSERT_EQ(r->sectors.size(), 1u);
  EXPECT_GT(r->sectors[0].lprt_sources, r->sectors[0].probes);  // it has neighbours' sources
}

// The report's ray counts are what the bake really cast: every query on any scene is logged
// (RayLog, the hook bench-bake replays) and counted, with and without LPRT.
TEST(Bake, ReportCountsEveryRayTheBakeCasts) {
  TempDir dir;
  for (const bool lit : {false, true}) {
    SCOPED_TRACE(lit ? "with LPRT" : "without LPRT");
    RayLog log;
    setRayLog(&log);
    auto r = bake(lit ? litWorld() : test::smallWorld(), "small", dir.path / (lit ? "lit.drtv" : "a.drtv"), draft());
    setRayLog(nullptr);
    ASSERT_TRUE(r) << r.error().message;
    uint64_t counted = 0;
    for (const auto& s : r->sectors) counted += s.rays();
    EXPECT_GT(counted, 0u);
    EXPECT_EQ(counted, log.rays.size());
    size_t in_calls = 0;
    for (const RayLog::Call& c : log.calls) in_calls += c.count;
    EXPECT_EQ(in_calls, log.rays.size());
  }
}

}  // namespace
}  // namespace drtv::baker
