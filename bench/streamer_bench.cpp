// Streamer benchmarks: the stream-in of one sector against zstd decoding it alone (goal: <= 3x),
// and the frame-thread cost of Streamer::update at 100 m/s.
//
// Stream-in = what an I/O thread does per sector: pread of the payload, size and XXH3 check, zstd
// decode, decode + validate (formats/sector.h), the occlusion tile. Measured with the archive in
// the page cache (a warm disk), so the comparison is of CPU work.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <optional>

#include <benchmark/benchmark.h>
#include <unistd.h>
#include <zstd.h>

#include "drtv/formats/archive.h"
#include "drtv/streamer/streamer.h"
#include "test_sectors.h"

namespace drtv::streamer {
namespace {

// The formats tests' sector (testing::makeSector), with an index grid made of runs as a baked
// nearest-probe grid is (compresses 4-7x, DESIGN.md) instead of noise, so that zstd does real work.
Sector makeSector(SectorKey key, int probes, uint32_t seed) {
  Sector s = testing::makeSector(key, probes, 0, seed);
  for (int i = 0; i < kGridCells; ++i) s.grid.cells[i] = uint8_t((i / 37) % probes);
  return s;
}

// One 16 x 16 world, written once per process.
struct World {
  std::filesystem::path path;
  Manifest manifest;
  World() {
    path = std::filesystem::temp_directory_path() / ("drtv_streamer_bench_" + std::to_string(::getpid()) + ".drtv");
    auto w = ArchiveWriter::create(path);
    uint32_t seed = 1;
    for (int ix = 0; ix < 16; ++ix)
      for (int iy = 0; iy < 16; ++iy, ++seed) (void)w->addSector(makeSector({ix, iy}, 66 + int(seed % 9), seed));
    Manifest m;
    m.bounds_max = {1024, 1024, 60};
    (void)w->finish(m);
    manifest = ArchiveReader::open(path)->manifest();
  }
  ~World() { std::filesystem::remove(path); }
};
World& world() {
  static World w;
  return w;
}

// What Streamer::load runs on an I/O thread for one sector: read + check + decode + validate + tile.
OcclusionTile loadOne(FileSectorSource& file, const SectorEntry& e) {
  auto bytes = file.read(e);
  auto sector = decodeSectorPayload(e, *bytes, "bench");
  auto owned = std::make_unique<Sector>(std::move(*sector));
  return runtime::makeOcclusionTile(*owned);
}

// The archive a zstd / load benchmark reads: the synthetic world, or with `real` the baked
// archive named by DRTV_BENCH_ARCHIVE (e.g. out/world.drtv from scripts/demo); nullopt (the
// benchmark is skipped) when that is unset.
std::optional<std::filesystem::path> archiveFor(bool real) {
  if (!real) return world().path;
  if (const char* p = std::getenv("DRTV_BENCH_ARCHIVE")) return std::filesystem::path(p);
  return std::nullopt;
}

// zstd alone, cycling through every sector of the archive with one reused context (as the I/O
// threads' thread_local one is): the reference the stream-in is measured against.
void BM_ZstdDecode(benchmark::State& state, bool real) {
  const auto path = archiveFor(real);
  if (!path) return state.SkipWithError("DRTV_BENCH_ARCHIVE not set");
  auto reader = ArchiveReader::open(*path);
  if (!reader) return state.SkipWithError(reader.error().message.c_str());
  std::vector<std::vector<uint8_t>> frames;
  size_t raw_max = 0, raw_sum = 0, compressed_sum = 0;
  for (const SectorEntry& e : reader->manifest().sectors) {
    frames.push_back(*reader->readCompressed(e.key));
    raw_max = std::max<size_t>(raw_max, e.raw_bytes);
    raw_sum += e.raw_bytes;
    compressed_sum += e.compressed_bytes;
  }
  ZSTD_DCtx* dctx = ZSTD_createDCtx();
  std::vector<uint8_t> out(raw_max);
  size_t i = 0;
  for (auto _ : state) {
    const auto& f = frames[i++ % frames.size()];
    benchmark::DoNotOptimize(ZSTD_decompressDCtx(dctx, out.data(), out.size(), f.data(), f.size()));
  }
  ZSTD_freeDCtx(dctx);
  state.SetItemsProcessed(state.iterations());
  state.counters["raw_bytes"] = double(raw_sum) / double(frames.size());
  state.counters["compressed_bytes"] = double(compressed_sum) / double(frames.size());
}
BENCHMARK_CAPTURE(BM_ZstdDecode, synthetic, false);
BENCHMARK_CAPTURE(BM_ZstdDecode, real_archive, true);

// The I/O thread's work alone, without the streamer's frame bookkeeping: read + check + decode +
// validate + tile (loadOne), cycling through the same sectors as BM_ZstdDecode.
void BM_LoadPipeline(benchmark::State& state, bool real) {
  const auto path = archiveFor(real);
  if (!path) return state.SkipWithError("DRTV_BENCH_ARCHIVE not set");
  auto reader = ArchiveReader::open(*path);
  if (!reader) return state.SkipWithError(reader.error().message.c_str());
  auto file = FileSectorSource::open(*path);
  if (!file) return state.SkipWithError(file.error().message.c_str());
  const std::vector<SectorEntry>& sectors = reader->manifest().sectors;
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(loadOne(**file, sectors[i++ % sectors.size()]));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_CAPTURE(BM_LoadPipeline, synthetic, false);
BENCHMARK_CAPTURE(BM_LoadPipeline, real_archive, true);

// A sink that takes every hand-off and keeps nothing: the benchmarks time the streamer alone.
struct NullSink final : SectorSink {
  void onSectorLoaded(const Sector&, const OcclusionTile&) override {}
  void onSectorEvicted(SectorKey) override {}
};

// The streamer's whole per-sector load, through a Streamer in deterministic mode: each iteration
// requests one sector far from the previous one (so it is never resident) and reads it inline.
void BM_StreamInOneSector(benchmark::State& state) {
  const World& w = world();
  auto file = FileSectorSource::open(w.path);
  std::shared_ptr<SectorSource> source(std::move(*file));
  StreamerOptions o;
  o.io_mode = IoMode::kDeterministic;
  o.residency.max_sectors = 1;
  o.residency.volume.texel_size_m = {0.01f, 0.01f, 4.f};  // footprint ~1 m: exactly the camera's sector is wanted
  o.simulated_latency_s = 0.0;
  o.max_in_flight = 1;
  Streamer s(w.manifest, source, o);
  NullSink sink;
  double t = 0, io_ms = 0;
  int i = 0;
  for (auto _ : state) {
    const SectorKey k = w.manifest.sectors[size_t(i++ * 37 % 256)].key;
    const FrameStats st = s.update({{k.ix * 64.0 + 32, k.iy * 64.0 + 32, 0}, {0, 0, 0}}, t, sink);
    io_ms += st.inline_io_ms;
    t += 1.0;
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["inline_io_us_per_sector"] = io_ms * 1000.0 / double(state.iterations());
}
BENCHMARK(BM_StreamInOneSector);

// The parts of the pipeline, to see where a stream-in's time goes.
void BM_DecodeAndValidateOneSector(benchmark::State& state) {
  const World& w = world();
  auto reader = ArchiveReader::open(w.path);
  const auto raw = *reader->readSectorBytes(w.manifest.sectors[100].key);
  for (auto _ : state) {
    auto sector = decodeSector(raw, "bench");
    benchmark::DoNotOptimize(sector);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DecodeAndValidateOneSector);

void BM_OcclusionTileOneSector(benchmark::State& state) {
  const World& w = world();
  auto reader = ArchiveReader::open(w.path);
  const Sector sector = *reader->readSector(w.manifest.sectors[100].key);
  for (auto _ : state) {
    OcclusionTile t = runtime::makeOcclusionTile(sector);
    benchmark::DoNotOptimize(t);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_OcclusionTileOneSector);

// Frame-thread cost of update() for a camera flying at 100 m/s across the world (deterministic
// I/O excluded: reported separately as inline_io_ms).
void BM_UpdateAt100MetresPerSecond(benchmark::State& state) {
  const World& w = world();
  auto file = FileSectorSource::open(w.path);
  std::shared_ptr<SectorSource> source(std::move(*file));
  StreamerOptions o;
  o.io_mode = IoMode::kDeterministic;
  Streamer s(w.manifest, source, o);
  NullSink sink;
  double t = 0, update_ms = 0;
  int64_t frames = 0;
  for (auto _ : state) {
    const double x = 40 + std::fmod(t * 100.0, 940.0);
    const FrameStats st = s.update({{x, 500, 0}, {100, 0, 0}}, t, sink);
    update_ms += st.update_ms;
    t += 1.0 / 60.0;
    ++frames;
  }
  state.SetItemsProcessed(frames);
  state.counters["update_us"] = update_ms * 1000.0 / double(frames);
}
BENCHMARK(BM_UpdateAt100MetresPerSecond);

}  // namespace
}  // namespace drtv::streamer

BENCHMARK_MAIN();
