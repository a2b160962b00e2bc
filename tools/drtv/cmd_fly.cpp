// drtv fly <archive | URL> [--path path.json | --loop] [--speed m/s] [--frames N]
//          [--time-of-day-rate h/s] [--json] [-o outdir]
// A deterministic fly-through of a baked archive (drtv/streamer/fly.h): streaming, relighting and
// volume updates per frame, written as frames.csv, fly-report.json, fly-report.md and PNGs.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "archive_source.h"
#include "commands.h"
#include "drtv/eval/technique.h"
#include "drtv/worlds/load.h"
#include "drtv/fly/fly.h"

namespace drtv::app {
namespace {

struct FlyCliOptions {
  std::string archive;
  std::string path_file;
  bool loop = false;
  double speed_mps = 100.0;
  int frames = 0;
  double hours_per_s = 0.1;
  double start_hour = 7.0;
  double fps = 60.0;
  bool json = false;
  std::string outdir = "fly-report";
  int io_threads = 0;  // 0 = deterministic I/O
  bool no_runtime = false;
  bool fine_shader = false;
  std::string volume_update = "worker";  // worker | inline
  std::string look_ahead = "path";       // path | velocity
  std::vector<std::string> faults;  // "ix,iy:kind"
  std::string world;                // world file whose lights (and their paths) to fly with
  std::string technique, params;    // a registered technique that runs on drtv::runtime
};

// "3,-1:corrupt" -> key and fault.
Result<std::pair<SectorKey, streamer::Fault>> parseFault(const std::string& text) {
  const auto colon = text.find(':');
  int ix = 0, iy = 0;
  char comma = 0;
  std::istringstream in(text.substr(0, colon));
  if (colon == std::string::npos || !(in >> ix >> comma >> iy) || comma != ',')
    return fail("--fault " + text + ": expected IX,IY:KIND (kind missing, truncated, corrupt or slow)");
  const std::string kind = text.substr(colon + 1);
  for (auto f : {streamer::Fault::kMissing, streamer::Fault::kTruncated, streamer::Fault::kCorrupt, streamer::Fault::kSlow})
    if (kind == streamer::faultName(f)) return std::pair{SectorKey{ix, iy}, f};
  return fail("--fault " + text + ": unknown kind '" + kind + "' (missing, truncated, corrupt or slow)");
}

Result<void> runFly(const FlyCliOptions& o) {
  // A URL: as many connections as I/O threads read at once (one in deterministic mode).
  auto archive = openArchive(o.archive, std::max(1, o.io_threads));
  if (!archive) return std::unexpected(archive.error());
  const Manifest& manifest = archive->manifest;
  std::shared_ptr<streamer::SectorSource> source = archive->source;
  if (!o.faults.empty()) {
    auto faults = std::make_shared<streamer::FaultInjectingSource>(
        source, o.io_threads ? streamer::FaultInjectingSource::SlowReads::kSleep : streamer::FaultInjectingSource::SlowReads::kSimulated);
    for (const std::string& text : o.faults) {
      auto f = parseFault(text);
      if (!f) return std::unexpected(f.error());
      // A slow read takes half a second: long enough to show in the report at 100 m/s.
      faults->inject(f->first, f->second, streamer::FaultInjectingSource::kForever, 0.5);
    }
    source = faults;
  }
  // The technique's runtime configuration; the streamer holds the sectors its volume covers.
  std::optional<runtime::RuntimeOptions> technique_options;
  std::string technique_name;
  std::unique_ptr<eval::Technique> own_technique;  // one that runs on its own, set up from --world
  if (!o.technique.empty()) {
    auto params = eval::parseTechniqueParams(o.params);
    if (!params) return std::unexpected(params.error().context("--params"));
    auto t = eval::makeTechnique(o.technique, *params);
    if (!t) return std::unexpected(t.error());
    technique_options = (*t)->streamingRuntime(manifest);
    technique_name = (*t)->describe();
    if (!technique_options) {
      if (!(*t)->traits().prepares_from_world)
        return fail("--technique " + technique_name + ": does not run on drtv::runtime, so it cannot be flown through a streamed archive");
      if (o.world.empty())
        return fail("--technique " + technique_name + ": bakes nothing and is set up from the world: give the world file with --world");
      own_technique = std::move(*t);
    }
  } else if (!o.params.empty()) {
    return fail("--params needs --technique");
  }
  streamer::StreamerOptions so;
  if (technique_options) so.residency.volume = technique_options->volume;
  so.io_mode = o.io_threads ? streamer::IoMode::kThreads : streamer::IoMode::kDeterministic;
  so.io_threads = std::max(1, o.io_threads);
  // Over HTTP each I/O thread holds one request in flight: let every thread have one.
  so.max_in_flight = std::max(so.max_in_flight, so.io_threads);
  streamer::Streamer s(manifest, source, so);

  auto path = o.path_file.empty() ? Result<fly::CatmullRomPath>(fly::defaultFlightPath(manifest, o.loop))
                                  : fly::loadFlightPath(o.path_file);
  if (!path) return std::unexpected(path.error());

  fly::FlyOptions fo;
  fo.speed_mps = o.speed_mps;
  fo.fps = o.fps;
  fo.frames = o.frames;
  fo.start_hour = o.start_hour;
  fo.hours_per_s = o.hours_per_s;
  fo.runtime = !o.no_runtime;
  fo.volume_worker = o.volume_update == "worker";
  fo.fine_shader = o.fine_shader;
  if (o.look_ahead == "velocity") fo.path_ahead_step_s = 0.0;
  fo.runtime_options = technique_options;
  fo.technique = technique_name;
  std::optional<worlds::World> world;
  if (!o.world.empty()) {
    auto loaded = worlds::loadWorld(o.world);
    if (!loaded) return std::unexpected(loaded.error());
    world = std::move(*loaded);
  }
  if (own_technique) {
    // Set up from the world for the sectors the archive holds. A technique that streams per sector
    // (the sweep) then builds its sectors' state as the streamer brings them in, on its workers
    // (deterministic with --io-threads 0, as the streamer's I/O); any other updates itself per frame.
    auto flight = own_technique->prepareFlight(
        *world, o.world, {manifest, so.residency, o.start_hour, so.io_mode == streamer::IoMode::kDeterministic});
    if (!flight) return std::unexpected(flight.error());
    fo.runtime = false;
    fo.technique_sink = flight->sink;
    fo.technique_bytes = flight->bytes;
    fo.technique_frame = [frame = std::move(flight->frame)](const streamer::Camera& cam, double time_s, double hour,
                                                           const std::vector<PointLight>& lights) -> Result<fly::TechniqueFrameCost> {
      auto f = frame(cam, time_s, hour, lights);
      if (!f) return std::unexpected(f.error());
      return fly::TechniqueFrameCost{f->frame_ms, f->inline_ms, f->reach, f->missing, f->stale, f->held, f->bytes, f->idle};
    };
    if (!world->lights.empty()) {
      fo.lights = world->lights;
      fo.light_paths = world->light_paths;
    }
  } else if (world) {
    if (world->lights.empty()) return fail(o.world + ": --world gives the flight its lights, and this world has none");
    if (!(manifest.effects & kEffectLocalLights))
      return fail(o.archive + ": baked without local lights (LPRT), so the lights of " + o.world + " would not show; bake a world with lights");
    fo.lights = world->lights;
    fo.light_paths = world->light_paths;
  }
  if (showProgress())
    fo.progress = [](int done, int total) {
      std::fprintf(stderr, "\rdrtv fly: frame %d / %d", done, total);
      if (done == total) std::fputc('\n', stderr);
    };
  if (auto made = createParentFolder((std::filesystem::path(o.outdir) / "fly-report.json").string()); !made) return made;
  auto result = fly::fly(s, *path, fo, o.archive);
  if (!result) return std::unexpected(result.error());
  result->source_note = archive->http_stats ? "HTTP: " + archive->http_stats() : "file";
  if (auto ok = fly::writeFlyReport(*result, o.outdir); !ok) return ok;

  const fly::FlySummary sum = fly::summarize(*result);
  if (o.json) {
    std::ifstream f(std::filesystem::path(o.outdir) / "fly-report.json");
    std::stringstream text;
    text << f.rdbuf();
    std::fputs(text.str().c_str(), stdout);
    return {};
  }
  std::printf("flew %d frames (%.0f m at %.0f m/s) over %s\n", sum.frames, result->path_length_m, o.speed_mps, o.archive.c_str());
  std::printf("resident: max %d sectors, %zu B (budget %zu B); volume %zu B on top\n", sum.max_resident, sum.max_resident_bytes,
              result->max_bytes, result->volume_bytes);
  std::printf("loads %lld, evictions %lld, failures %lld, misses %lld (in %lld frames)\n", (long long)sum.loads,
              (long long)sum.evictions, (long long)sum.failures, (long long)sum.misses, (long long)sum.frames_with_misses);
  if (sum.technique_streamed)
    std::printf("%s: sectors in the volume's reach without a fine grid: %lld sector-frames in %lld frames (reach up to %d); "
                "fine grids held max %d (%.0f MiB), stale max %d\n",
                technique_name.c_str(), (long long)sum.technique_misses, (long long)sum.technique_frames_with_misses,
                sum.technique_reach_max, sum.technique_held_max, double(sum.technique_bytes_max) / (1024.0 * 1024.0),
                sum.technique_stale_max);
  if (archive->http_stats) std::printf("http: %s\n", archive->http_stats().c_str());
  std::printf("load latency ms: p50 %.1f, p95 %.1f, p99 %.1f, max %.1f; residency guard up to %.2f s\n", sum.latency_ms_p50,
              sum.latency_ms_p95, sum.latency_ms_p99, sum.latency_ms_max, sum.guard_s_max);
  std::printf("frame CPU ms: p50 %.4f, p99 %.4f, max %.4f\n", sum.frame_ms_p50, sum.frame_ms_p99, sum.frame_ms_max);
  if (sum.volume_worker)
    std::printf("adds and volume update on a worker, one frame late: p99 %.4f ms; the frames waited for it %d times (p99 wait %.4f ms)\n",
                sum.worker_ms_p99, sum.frames_waited, sum.wait_ms_p99);
  std::printf("report: %s/fly-report.md\n", o.outdir.c_str());
  return {};
}

}  // namespace

Command registerFly(CLI::App& app) {
  auto o = std::make_shared<FlyCliOptions>();
  CLI::App* sub = app.add_subcommand("fly", "Fly a camera through a baked archive: streaming, relighting, volume updates, report");
  sub->add_option("archive", o->archive, "Baked archive: a path or an http(s):// URL (range requests)")->required();
  auto* path = sub->add_option("--path", o->path_file, "Waypoints JSON: {\"loop\": bool, \"waypoints\": [[x,y,z], ...]} (metres)");
  sub->add_flag("--loop", o->loop, "Fly the default closed circuit instead of the default crossing")->excludes(path);
  sub->add_option("--speed", o->speed_mps, "Camera speed, metres per second")->check(finiteRange(0.0, 10000.0, /*lo_open=*/true));
  sub->add_option("--frames", o->frames, "Frames to fly (0 = the path once)")->check(CLI::NonNegativeNumber);
  sub->add_option("--time-of-day-rate", o->hours_per_s, "Hours of the day per second of flight")
      ->check(finiteRange(-1e6, 1e6));
  sub->add_option("--start-hour", o->start_hour, "Time of day at the first frame, hours")->check(finiteRange(0.0, 24.0));
  sub->add_option("--fps", o->fps, "Fixed frame rate, frames per second")->check(finiteRange(1.0, 1000.0));
  sub->add_option("--io-threads", o->io_threads,
                  "Background I/O threads; 0 (default) = deterministic simulated I/O, reproducible reports")
      ->check(CLI::Range(0, 64));
  sub->add_option("--world", o->world,
                  "World file whose lights fly with the camera; lights with a path move along it (docs/world-format.md)");
  sub->add_option("--fault", o->faults, "Inject a fault on a sector: IX,IY:missing|truncated|corrupt|slow (repeatable)");
  sub->add_flag("--no-runtime", o->no_runtime, "Stream only: no relighting or volume updates");
  sub->add_option("--volume-update", o->volume_update,
                  "worker (default): the volume update on a worker thread, off the frame's critical path, one frame late, the "
                  "flight in real time; inline: in the frame, as before")
      ->check(CLI::IsMember({"worker", "inline"}));
  sub->add_option("--look-ahead", o->look_ahead,
                  "path (default): the streamer is told where the camera will be along its path, as an engine that knows "
                  "the camera's spline or route; velocity: the straight line along its velocity alone")
      ->check(CLI::IsMember({"path", "velocity"}));
  sub->add_flag("--fine-shader", o->fine_shader,
                "Each update also packs the fine level near surfaces for the shaders around the camera (runtime/fine_shader.h): "
                "its cost shows in the worker's time");
  const std::string names = eval::registeredTechniqueNames();
  sub->add_option("--technique", o->technique, "The technique to fly (one that runs on drtv::runtime): " + names + " (default: what the archive asks for)");
  sub->add_option("--params", o->params, "The technique's parameters, name=value,... (e.g. fill=smooth,texel_m=1)");
  sub->add_flag("--json", o->json, "Print fly-report.json on stdout instead of the text summary");
  sub->add_option("-o,--output", o->outdir, "Output directory (created)");
  return {sub, [o]() -> Result<void> {
            if (!isArchiveUrl(o->archive) && !std::filesystem::exists(o->archive)) return fail(o->archive + ": no such file");
            return runFly(*o);
          }, &o->archive};
}

}  // namespace drtv::app
