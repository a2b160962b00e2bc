// The HTTP sector source against the file source: the stream-in of one sector (read + size and
// XXH3 check + zstd + decode + validate + occlusion tile, what a streamer I/O thread does) from a
// local file and from a real nginx over loopback, side by side, and the read alone.
//
// nginx is started here on a free loopback port (bench/common/nginx_server.h) and stopped at exit;
// without it the HTTP benchmarks report an error. The archive is the streamer benchmark's
// synthetic 16 x 16 world, in the page cache: the difference is the HTTP request's cost on one
// kept-alive connection (no network latency; over a network add the round trip).
#include <filesystem>
#include <memory>

#include <benchmark/benchmark.h>
#include <curl/curl.h>
#include <unistd.h>

#include "drtv/formats/archive.h"
#include "drtv/netsource/http_source.h"
#include "drtv/runtime/occlusion.h"
#include "drtv/streamer/sector_source.h"
#include "nginx_server.h"
#include "test_sectors.h"

namespace drtv::netsource {
namespace {

// The streamer benchmark's world (bench/streamer_bench.cpp): 256 sectors of 66-74 probes, an
// index grid of runs, zstd level 3. Served by nginx from a temporary folder.
struct Served {
  std::filesystem::path dir, path;
  Manifest manifest;
  std::unique_ptr<testing::NginxServer> nginx;
  std::string url, error;
  Served() {
    dir = std::filesystem::temp_directory_path() / ("drtv_netsource_bench_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir / "www");
    path = dir / "www" / "world.drtv";
    auto w = ArchiveWriter::create(path);
    uint32_t seed = 1;
    for (int ix = 0; ix < 16; ++ix)
      for (int iy = 0; iy < 16; ++iy, ++seed) {
        const int probes = 66 + int(seed % 9);
        Sector s = testing::makeSector({ix, iy}, probes, 0, seed);
        for (int i = 0; i < kGridCells; ++i) s.grid.cells[i] = uint8_t((i / 37) % probes);
        (void)w->addSector(s);
      }
    Manifest m;
    m.bounds_max = {1024, 1024, 60};
    (void)w->finish(m);
    manifest = ArchiveReader::open(path)->manifest();
    nginx = std::make_unique<testing::NginxServer>(dir / "nginx", dir / "www", "");
    if (auto ok = nginx->start(); !ok) error = ok.error().message;
    url = nginx->url("/world.drtv");
  }
  ~Served() {
    nginx.reset();
    std::filesystem::remove_all(dir);
  }
};
Served& served() {
  static Served s;
  return s;
}

std::shared_ptr<streamer::SectorSource> sourceFor(bool http, std::string& error) {
  Served& s = served();
  if (http) {
    if (!s.error.empty()) return error = s.error, nullptr;
    auto h = HttpSectorSource::open(s.url);
    if (!h) return error = h.error().message, nullptr;
    return std::shared_ptr<streamer::SectorSource>(std::move(*h));
  }
  auto f = streamer::FileSectorSource::open(s.path);
  if (!f) return error = f.error().message, nullptr;
  return std::shared_ptr<streamer::SectorSource>(std::move(*f));
}

// The payload read alone, cycling through the sectors.
void BM_ReadOneSector(benchmark::State& state, bool http) {
  std::string error;
  auto source = sourceFor(http, error);
  if (!source) return state.SkipWithError(error.c_str());
  const auto& sectors = served().manifest.sectors;
  size_t i = 0, bytes = 0;
  for (auto _ : state) {
    auto b = source->read(sectors[i++ * 37 % sectors.size()]);
    if (!b) return state.SkipWithError(b.error().message.c_str());
    bytes += b->size();
    benchmark::DoNotOptimize(b);
  }
  state.SetItemsProcessed(state.iterations());
  state.SetBytesProcessed(int64_t(bytes));
}
BENCHMARK_CAPTURE(BM_ReadOneSector, file, false);
BENCHMARK_CAPTURE(BM_ReadOneSector, http_loopback, true);

// The floor under BM_ReadOneSector/http_loopback: the same ranges by the least libcurl allows, one
// easy handle set up once and kept alive, only the range changed per request and the body
// appended (no reset, no checks, no retries). What the source's own work costs is the difference.
size_t appendBody(char* data, size_t size, size_t n, void* user) {
  auto* body = static_cast<std::vector<uint8_t>*>(user);
  body->insert(body->end(), reinterpret_cast<const uint8_t*>(data), reinterpret_cast<const uint8_t*>(data) + size * n);
  return size * n;
}
void BM_ReadOneSectorCurlFloor(benchmark::State& state) {
  Served& s = served();
  if (!s.error.empty()) return state.SkipWithError(s.error.c_str());
  curl_global_init(CURL_GLOBAL_DEFAULT);
  CURL* c = curl_easy_init();
  std::vector<uint8_t> body;
  curl_easy_setopt(c, CURLOPT_URL, s.url.c_str());
  curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);
  curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, appendBody);
  curl_easy_setopt(c, CURLOPT_WRITEDATA, &body);
  const auto& sectors = s.manifest.sectors;
  size_t i = 0;
  for (auto _ : state) {
    const SectorEntry& e = sectors[i++ * 37 % sectors.size()];
    const std::string range = std::to_string(e.offset) + "-" + std::to_string(e.offset + e.compressed_bytes - 1);
    body.clear();
    curl_easy_setopt(c, CURLOPT_RANGE, range.c_str());
    if (curl_easy_perform(c) != CURLE_OK || body.size() != e.compressed_bytes) {
      curl_easy_cleanup(c);
      return state.SkipWithError("range request failed");
    }
    benchmark::DoNotOptimize(body.data());
  }
  curl_easy_cleanup(c);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ReadOneSectorCurlFloor);

// What a streamer I/O thread does per sector: read, check, decode, validate, occlusion tile.
void BM_StreamInOneSector(benchmark::State& state, bool http) {
  std::string error;
  auto source = sourceFor(http, error);
  if (!source) return state.SkipWithError(error.c_str());
  const auto& sectors = served().manifest.sectors;
  size_t i = 0;
  for (auto _ : state) {
    const SectorEntry& e = sectors[i++ * 37 % sectors.size()];
    auto b = source->read(e);
    if (!b) return state.SkipWithError(b.error().message.c_str());
    auto sector = decodeSectorPayload(e, *b, "bench");
    if (!sector) return state.SkipWithError(sector.error().message.c_str());
    runtime::OcclusionTile tile = runtime::makeOcclusionTile(*sector);
    benchmark::DoNotOptimize(tile);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_CAPTURE(BM_StreamInOneSector, file, false);
BENCHMARK_CAPTURE(BM_StreamInOneSector, http_loopback, true);

// Reads in flight at once: N threads share one source (16 connections), each reading payloads
// in turn, as the streamer's I/O threads do; items/s is the total sector rate.
void BM_ReadsInFlight(benchmark::State& state) {
  static std::string error;
  static const std::shared_ptr<streamer::SectorSource> source = sourceFor(true, error);
  if (!source) return state.SkipWithError(error.c_str());
  const auto& sectors = served().manifest.sectors;
  size_t i = size_t(state.thread_index()) * 101;
  for (auto _ : state) {
    auto b = source->read(sectors[i++ * 37 % sectors.size()]);
    if (!b) return state.SkipWithError(b.error().message.c_str());
    benchmark::DoNotOptimize(b);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ReadsInFlight)->Threads(1)->Threads(8)->UseRealTime();

}  // namespace
}  // namespace drtv::netsource
BENCHMARK_MAIN();
