// Memory budgets from real allocations (alloc_counter.h), cross-checked with memoryBytes().
#include <gtest/gtest.h>

#include "alloc_counter.h"
#include "drtv/streamer/streamer.h"
#include "streamer_world.h"

namespace drtv::streamer {
namespace {

constexpr double kFrameS = 1.0 / 60.0;
// Heap the streamer's bookkeeping may take after construction besides sectors: the deque map of
// loads waiting for their simulated latency (one 512-byte block plus its map).
constexpr int64_t kBookkeepingBytes = 1024;
// The streamer's fixed heap: slots with their inline tiles, scratch vectors and its copy of the
// manifest (40 bytes per archive sector): not sector data, so outside the talk's budget, but bounded.
constexpr int64_t kMaxConstructionBytes = 64 * 1024;

// A sink that allocates nothing, so that every byte counted is the streamer's.
class NullSink : public SectorSink {
 public:
  void onSectorLoaded(const Sector&, const OcclusionTile&) override {}
  void onSectorEvicted(SectorKey) override {}
};

struct Measured {
  int64_t construction_bytes = 0;  // heap the streamer took before any sector (slots, scratch)
  int64_t transient_bytes = 0;     // max over updates of the heap's peak inside it above both ends
  size_t io_buffer_bytes = 0;      // Streamer::ioBufferBytes() (operator new sees the buffers,
                                   // not zstd's context, which is malloc'd once per reader)
  int64_t peak_sector_bytes = 0;   // max over frames of live heap minus that, at frame ends
  int64_t settled_bytes = 0;       // live heap minus construction at the end, all loads done
  size_t reported_bytes = 0;       // residentBytes() at the end
  int resident = 0;
};

// Flies across the world in deterministic mode and measures the live heap at every frame end.
Measured flyAndMeasure(const std::filesystem::path& path, const Manifest& manifest, StreamerOptions o) {
  o.io_mode = IoMode::kDeterministic;
  auto file = FileSectorSource::open(path);
  EXPECT_TRUE(file.has_value());
  std::shared_ptr<SectorSource> source(std::move(*file));
  NullSink sink;
  Measured m;
  const int64_t before = testing::liveHeapBytes();
  auto s = std::make_unique<Streamer>(manifest, source, o);
  m.construction_bytes = testing::liveHeapBytes() - before;
  const int64_t base = testing::liveHeapBytes();
  const glm::dvec3 a = manifest.bounds_min + glm::dvec3(20), b = manifest.bounds_max - glm::dvec3(20);
  const glm::dvec3 v = glm::normalize(glm::dvec3(b.x - a.x, b.y - a.y, 0)) * 100.0;
  double t = 0;
  m.io_buffer_bytes = s->ioBufferBytes();
  for (glm::dvec3 p = a; glm::dot(b - p, v) > 0; p += v * kFrameS, t += kFrameS) {
    const int64_t before_update = testing::liveHeapBytes();
    testing::resetHeapPeak();
    s->update({p, v}, t, sink);
    const int64_t after_update = testing::liveHeapBytes();
    // Loads run inside update() in deterministic mode: what the heap held above both ends is
    // what a load held only while it ran (its compressed and decompressed buffers).
    m.transient_bytes = std::max(m.transient_bytes, testing::heapPeakBytes() - std::max(before_update, after_update));
    m.peak_sector_bytes = std::max(m.peak_sector_bytes, after_update - base);
  }
  const glm::dvec3 centre = 0.5 * (manifest.bounds_min + manifest.bounds_max);
  for (int i = 0; i < 30; ++i, t += kFrameS) s->update({centre, {0, 0, 0}}, t, sink);
  m.settled_bytes = testing::liveHeapBytes() - base;
  m.reported_bytes = s->residentBytes();
  m.resident = int(s->residentKeys().size());
  return m;
}

// 51 sectors resident; sector data at every frame end, loads in flight included, fits `budget`;
// the slots fit kMaxConstructionBytes; and the accounting matches the allocations: resident bytes
// = the sectors' heap, and the tiles live in the slots (construction), so the reported figure is
// larger by one tile per sector.
void expectFullAndWithin(const Measured& m, size_t budget, const char* what) {
  std::printf("%s: construction %lld B, peak %lld B, settled %lld B (%d sectors), budget %zu B\n", what,
              (long long)m.construction_bytes, (long long)m.peak_sector_bytes, (long long)m.settled_bytes, m.resident, budget);
  EXPECT_EQ(m.resident, kMaxResidentSectors) << what;
  EXPECT_LE(m.peak_sector_bytes, int64_t(budget)) << what;
  EXPECT_LE(m.construction_bytes, kMaxConstructionBytes) << what;
  // The loads' transient buffers: outside the sector budget, but within the bound the streamer
  // states (one reader here: deterministic mode), and nearly reached (the bound is not slack):
  // the decompressed payload is freed before the decoded sector's own block (4 KB of index grid)
  // is allocated, so the peak above both ends is the buffers less about that block.
  EXPECT_GE(m.transient_bytes, int64_t(m.io_buffer_bytes) - int64_t(sizeof(Sector)) - kBookkeepingBytes) << what;
  EXPECT_LE(m.transient_bytes, int64_t(m.io_buffer_bytes) + kBookkeepingBytes) << what;
  std::printf("%s: transient I/O buffers at most %lld B, stated bound %zu B\n", what, (long long)m.transient_bytes, m.io_buffer_bytes);
  const int64_t sectors = int64_t(m.reported_bytes) - int64_t(m.resident * sizeof(OcclusionTile));
  EXPECT_LE(sectors, m.settled_bytes) << what;
  EXPECT_LE(m.settled_bytes, sectors + kBookkeepingBytes) << what;
}

TEST(StreamerBudget, StaysUnder760KiBWithoutLprtByRealAllocations) {
  testing::TempDir dir;
  const Manifest manifest = testing::writeWorld(dir.path() / "w.drtv", {});
  const Measured m = flyAndMeasure(dir.path() / "w.drtv", manifest, {});
  RecordProperty("construction_bytes", std::to_string(m.construction_bytes));
  RecordProperty("peak_sector_bytes", std::to_string(m.peak_sector_bytes));
  expectFullAndWithin(m, kBudgetBytesWithoutLprt, "without LPRT");
}

TEST(StreamerBudget, StaysUnder11_5MiBWithLprtByRealAllocations) {
  testing::TempDir dir;
  testing::WorldSpec spec;
  spec.sectors_x = spec.sectors_y = 9;  // 81 sectors, enough to evict; ~19 MB of archive
  spec.lprt_sources = kMaxLprtSources;
  const Manifest manifest = testing::writeWorld(dir.path() / "w.drtv", spec);
  const Measured m = flyAndMeasure(dir.path() / "w.drtv", manifest, {});
  expectFullAndWithin(m, kBudgetBytesWithLprt, "with LPRT");
}

// The talk's budgets are fc3's; an archive whose sectors carry a sun transfer (sh-l1, the default)
// is allowed it on top for 51 sectors of 70 probes (sector.h): 5,392 B a sector at 6 samples.
TEST(StreamerBudget, ASunTransferAddsItsShareOfFiftyOneSectorsOfSeventyProbes) {
  auto manifestOf = [](size_t sun_samples, uint16_t sources) {
    Manifest m;
    for (int i = 0; i < 3; ++i) {
      SectorEntry e;
      e.key = SectorKey{i, 0};
      e.probes = uint16_t(40 + 10 * i);
      e.lprt_sources = sources;
      e.raw_bytes = uint32_t(encodedSectorBytes(e.probes, sources, true, i == 1 ? sun_samples : 0));
      m.sectors.push_back(e);
    }
    return m;
  };
  EXPECT_EQ(budgetBytesFor(manifestOf(0, 0)), kBudgetBytesWithoutLprt);
  EXPECT_EQ(budgetBytesFor(manifestOf(6, 0)), kBudgetBytesWithoutLprt + 51u * 5392u);
  EXPECT_EQ(budgetBytesFor(manifestOf(6, 0)), 1053232u);
  EXPECT_EQ(budgetBytesFor(manifestOf(8, 16)), kBudgetBytesWithLprt + 51u * (8u * 12u + 70u * (4u + 8u * 12u)));
  // What a sector of 70 probes with the default 6 samples adds is exactly that share.
  EXPECT_EQ(encodedSectorBytes(70, 0, true, 6) - encodedSectorBytes(70, 0, true, 0), sunTransferAllowanceBytes(6));
}

// Covered probes' visibility maps (sector.h) are allowed for the 51 sectors that hold the most.
TEST(StreamerBudget, VisibilityMapsAddThoseOfTheFiftyOneSectorsHoldingTheMost) {
  Manifest m;
  for (int i = 0; i < 60; ++i) {
    SectorEntry e;
    e.key = SectorKey{i, 0};
    e.probes = 100;
    e.covered = uint16_t(i);  // 0..59: the 51 largest are 9..59
    e.raw_bytes = uint32_t(encodedSectorBytes(e.probes, 0, true, 0, e.covered));
    m.sectors.push_back(e);
  }
  size_t maps = 0;
  for (size_t c = 9; c < 60; ++c) maps += c * kVisBytesPerProbe;
  EXPECT_EQ(budgetBytesFor(m), kBudgetBytesWithoutLprt + maps);
}

TEST(StreamerBudget, ASmallerByteBudgetHoldsFewerSectorsAndIsNeverExceeded) {
  testing::TempDir dir;
  const Manifest manifest = testing::writeWorld(dir.path() / "w.drtv", {});
  StreamerOptions o;
  o.max_bytes = 300 * 1024;  // ~20 sectors
  const Measured m = flyAndMeasure(dir.path() / "w.drtv", manifest, o);
  EXPECT_LE(m.peak_sector_bytes, int64_t(o.max_bytes));
  EXPECT_GE(m.resident, 18);
  EXPECT_LE(m.resident, 21);
}

}  // namespace
}  // namespace drtv::streamer
