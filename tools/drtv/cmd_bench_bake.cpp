// drtv bench-bake [--size-km2 A ...] [--threads N] [--quality Q] [--rays R] [--keep DIR]
// Bakes procedural islands and prints the bake's rays/s next to raw Embree rays/s on the same
// scenes in the same run (a benchmark, never a test: the figures go to docs/baker.md).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <unistd.h>

#include <tbb/global_control.h>

#include "commands.h"
#include "drtv/baker/bake.h"
#include "drtv/raytrace/raw_rays.h"
#include "drtv/raytrace/ray_scene.h"
#include "drtv/worlds/island.h"

namespace drtv::app {
namespace {

struct BenchOptions {
  std::vector<double> sizes{1.0};
  int threads = 0;
  std::string quality = "default";
  uint64_t rays = 4'000'000;
  uint64_t seed = 7;
};

Result<void> runBench(const BenchOptions& o) {
  const auto quality = baker::parseQuality(o.quality);
  if (!quality) return fail("--quality '" + o.quality + "': expected draft, default or high");
  std::optional<tbb::global_control> limit;
  if (o.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(o.threads));
  const auto dir = std::filesystem::temp_directory_path() / ("drtv-bench-bake-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  for (double size : o.sizes) {
    using Clock = std::chrono::steady_clock;
    auto t0 = Clock::now();
    worlds::IslandOptions io;
    io.size_km2 = size;
    io.seed = o.seed;
    auto world = worlds::generateIsland(io);
    if (!world) return std::unexpected(world.error());
    const double gen_s = std::chrono::duration<double>(Clock::now() - t0).count();
    baker::BakeOptions bo;
    bo.quality = *quality;
    bo.threads = o.threads;
    const auto archive = dir / ("island-" + std::to_string(int(size)) + ".drtv");
    const double cpu0 = raytrace::processCpuSeconds();
    auto report = baker::bake(*world, "island", archive, bo);
    const double bake_cpu_s = raytrace::processCpuSeconds() - cpu0;
    if (!report) return std::unexpected(report.error());
    if (auto w = baker::writeReports(*report, dir / "bake-report.json", dir / "bake-report.md"); !w) return w;
    uint64_t rays = 0;
    size_t probes = 0, sectors = 0;
    for (const auto& s : report->sectors) {
      rays += s.rays();
      probes += s.probes;
      sectors += s.probes > 0;
    }
    // Raw Embree on the same scenes: 8 sectors spread along the island's diagonal.
    auto geometry = raytrace::WorldGeometry::build(*world, "island");
    if (!geometry) return std::unexpected(geometry.error());
    const raytrace::SectorRange r = geometry->sectors();
    std::vector<SectorKey> keys;
    for (int i = 0; i < 8; ++i)
      keys.push_back({r.x0 + (r.x1 - r.x0) * (2 * i + 1) / 16, r.y0 + (r.y1 - r.y0) * (2 * i + 1) / 16});
    auto raw = raytrace::measureRawRays(*geometry, keys, o.rays, report->settings.halo_m);
    if (!raw) return std::unexpected(raw.error());
    // Embree alone on the bake's own rays: bake each of those sectors again in memory with a ray
    // log installed, then cast the logged calls again on the same sector's scene.
    raytrace::ReplayFigures replay;
    uint64_t logged = 0, counted = 0;
    for (const SectorKey key : keys) {
      raytrace::RayLog log;
      baker::SectorStats st;
      raytrace::setRayLog(&log);
      auto placements = baker::placeSectors(*geometry, *world, baker::placementKeys(std::span(&key, 1), report->effects_baked),
                                            report->settings, report->effects_baked);
      if (!placements) return std::unexpected(placements.error());
      auto again = baker::bakeSector(*geometry, *world, key, report->settings, report->effects_baked, *placements, st);
      raytrace::setRayLog(nullptr);
      if (!again) return std::unexpected(again.error());
      counted += st.rays();
      logged += log.rays.size();
      const raytrace::SectorGeometry g = geometry->gather(key, baker::haloFor(report->settings, report->effects_baked));
      auto scene = raytrace::RayScene::build(g.vertices);
      if (!scene) return std::unexpected(scene.error());
      const raytrace::ReplayFigures f = raytrace::replayRays(*scene, log, 3);
      replay.rays += f.rays;
      replay.wall_s += f.wall_s;
      replay.cpu_s += f.cpu_s;
    }
    const double bake_rps = double(rays) / report->bake_s;
    std::printf("island %.0f km^2 (seed %llu), quality %s, threads %d\n", size, static_cast<unsigned long long>(o.seed),
                o.quality.c_str(), report->threads);
    std::printf("  generate world            %8.2f s (%zu triangles)\n", gen_s, report->triangles);
    std::printf("  bake wall                 %8.2f s (geometry %.2f, sectors %.2f, pack %.2f)\n", report->wall_s,
                report->geometry_s, report->bake_s, report->pack_s);
    std::printf("  sectors / probes          %8zu / %zu (%.1f per sector)\n", sectors, probes, sectors ? double(probes) / sectors : 0.0);
    std::printf("  bake rays                 %8.1f M, %.2f M rays/s over the sectors' wall time\n", double(rays) / 1e6, bake_rps / 1e6);
    std::printf("  raw embree (same scenes)  single %.2f, stream %.2f, occluded stream %.2f M rays/s (%zu tris/scene)\n",
                raw->single_rays_per_s / 1e6, raw->stream_rays_per_s / 1e6, raw->occluded_stream_rays_per_s / 1e6, raw->triangles);
    std::printf("  bake / raw stream         %8.0f %%   bake / raw single %.0f %%  (wall-clock rates)\n",
                100.0 * bake_rps / raw->stream_rays_per_s, 100.0 * bake_rps / raw->single_rays_per_s);
    std::printf("  raw embree, the bake's own rays replayed (%.2f M rays of %zu sectors, same calls): %.2f M rays/s\n",
                double(logged) / 1e6, keys.size(), double(replay.rays) / replay.wall_s / 1e6);
    if (logged != counted)
      std::printf("  WARNING: the bake's report counts %llu rays for those sectors, the log %llu\n",
                  static_cast<unsigned long long>(counted), static_cast<unsigned long long>(logged));
    std::printf("  bake / raw on its own rays %7.0f %%  (wall-clock rates)\n",
                100.0 * bake_rps / (double(replay.rays) / replay.wall_s));
    // Per CPU second: the host is shared, so wall-clock rates move with other people's load.
    const double bake_cpu_rps = double(rays) / bake_cpu_s;
    std::printf("  per CPU second            bake %.2f M rays/s (%.1f CPU s), raw stream %.2f, raw single %.2f\n",
                bake_cpu_rps / 1e6, bake_cpu_s, raw->stream_rays_per_cpu_s / 1e6, raw->single_rays_per_cpu_s / 1e6);
    std::printf("  bake / raw per CPU second %8.0f %% of stream, %.0f %% of single, %.0f %% of its own rays replayed\n",
                100.0 * bake_cpu_rps / raw->stream_rays_per_cpu_s, 100.0 * bake_cpu_rps / raw->single_rays_per_cpu_s,
                100.0 * bake_cpu_rps / (double(replay.rays) / replay.cpu_s));
    std::fflush(stdout);
  }
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  return {};
}

}  // namespace

Command registerBenchBake(CLI::App& app) {
  auto o = std::make_shared<BenchOptions>();
  CLI::App* sub = app.add_subcommand("bench-bake", "Benchmark: bake procedural islands, print bake vs raw Embree rays/s");
  sub->add_option("--size-km2", o->sizes, "Island sizes in km^2 (repeatable; default 1)");
  sub->add_option("--threads", o->threads, "Worker threads (0 = all cores)");
  sub->add_option("--quality", o->quality, "draft | default | high")->check(CLI::IsMember({"draft", "default", "high"}));
  sub->add_option("--rays", o->rays, "Raw Embree rays per mode (default 4 M)");
  sub->add_option("--seed", o->seed, "Island seed (default 7, as worlds/island.json)");
  return {sub, [o]() { return runBench(*o); }};
}

}  // namespace drtv::app
