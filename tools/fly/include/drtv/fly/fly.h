// drtv/fly/fly.h — a deterministic fly-through: a camera on a spline at a fixed frame rate,
// the streamer feeding drtv::runtime (relight, volumes, occlusion), the time of day advancing,
// and per-frame measurements written as CSV, JSON, Markdown and PNG (`drtv fly`).
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slides 24 (51
//      sectors, 760 KB / 11.5 MB), 34-36 (volume scrolling), 58 (occlusion tiles).
//
// Warm-up: before frame 0 the camera is held at the start until the streamer is idle (not
// measured; FlyResult::warmup_frames says how many updates it took).
// Per frame (frame's thread, in this order):
//   1. Streamer::update(camera, t, sink): loads handed to the runtime (Runtime::addSector relights
//      the sector with the current lighting and marks its volume footprint; timed as relight_ms),
//      evictions (Runtime::removeSector);
//   2. Runtime::setTime(hour) and Runtime::update(camera): a full relight when the time of day
//      moved the lighting past the runtime's threshold, the volume scroll and slab fills, publish
//      (timed as volume_ms; full_relight says whether this frame relit everything).
// frame_ms = update_ms + relight_ms + volume_ms: the frame thread's CPU time for GI. I/O is not
// in it: threads do it (kThreads), or it is simulated and reported apart (kDeterministic).
//
// Determinism: with StreamerOptions::io_mode = kDeterministic (the default here) the loads,
// evictions, misses and bytes of every frame depend only on the archive and the options; the
// times (ms) are measurements and vary from run to run.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"
#include "drtv/image/image.h"
#include "drtv/fly/flight_path.h"
#include "drtv/runtime/runtime.h"
#include "drtv/streamer/streamer.h"

namespace drtv::fly {

// At most this many frames per flight (~3 days at 60 Hz; the per-frame records take ~170 B each).
inline constexpr int kMaxFlyFrames = 10'000'000;

// What a technique of its own (FlyOptions::technique_frame) did in one frame.
struct TechniqueFrameCost {
  double ms = 0.0;          // frame-thread milliseconds (in frame_ms)
  double inline_ms = 0.0;   // deterministic streaming: per-sector jobs run inline, a worker's time
                            // (not in frame_ms, as the streamer's inline I/O)
  // Streamed techniques: sectors within the volume's footprint that get per-sector state (-1: the
  // technique does not stream), and how many of them lack it this frame; stale: per-sector state
  // built for an older time of day; held: sectors holding state.
  int reach = -1, missing = 0, stale = 0, held = 0;
  size_t bytes = 0;         // the technique's runtime state (streamed: its grids)
  bool idle = true;         // nothing left to build (the warm-up waits for it)
};

struct FlyOptions {
  double speed_mps = 100.0;     // camera speed along the path, metres per second
  double fps = 60.0;            // fixed frame rate, frames per second
  int frames = 0;               // frames to fly; 0 = the path once (one lap of a loop)
  double start_hour = 7.0;      // time of day at frame 0, hours
  double hours_per_s = 0.1;     // time-of-day rate: hours per second of flight
  bool runtime = true;          // relight and fill the volumes with drtv::runtime
  int snapshots = 4;            // top-down PNGs at evenly spaced frames (the last included)
  // Before frame 0, load the start position's sectors with the camera held there (a game loads
  // the area before the player appears), so that the flight's misses are the streamer's, not a
  // cold start's. At most this many warm-up updates, 1/fps apart, before t = 0; 0 = cold start.
  int warmup_frames = 600;
  // Moving lights: when `lights` is not empty it replaces the archive's lights, and each frame
  // sets every light with a path (light_paths[i], validateLightPath) to its state at the frame's
  // flight time (lightAt); the runtime redistributes them onto source probes and relights.
  std::vector<PointLight> lights;
  std::vector<LightPath> light_paths;
  // The runtime's configuration (a technique's, `drtv fly --technique`) instead of what an engine
  // picks for the archive's effects (runtime::optionsForEffects); its volume's size and texel
  // size are the streamer's residency's, so pass the same there. `technique` names it in the report.
  std::optional<runtime::RuntimeOptions> runtime_options;
  std::string technique;
  // A technique that does not run on drtv::runtime (`drtv fly --technique lpv`): called every
  // frame with the camera, the camera clock, the time of day and the lights (moved along their
  // paths) after the streamer's update; returns what its update cost (in the frame time), or an
  // error that ends the flight. Set `runtime` false with it. `technique_bytes` is reported beside
  // the volume's. A streamed technique (eval::TechniqueStream, the sweep) is also called during the
  // warm-up, until it says it is idle, and gets the streamer's loads and evictions through
  // `technique_sink` (their time counts as technique_ms). With StreamerOptions::kThreads such a
  // flight keeps to real time (frame f starts f / fps seconds after the first), so that the
  // technique's workers get the time a game's frames would leave them.
  std::function<Result<TechniqueFrameCost>(const streamer::Camera& camera, double time_s, double hour,
                                           const std::vector<PointLight>& lights)>
      technique_frame;
  streamer::SectorSink* technique_sink = nullptr;
  size_t technique_bytes = 0;
  // The volume update (Runtime::setTime's relight, scroll, fill, blur, publish) and the adds of
  // the frame's loads (their relight and slabs) on a worker thread (runtime::UpdateWorker), off
  // the frame's critical path: frame f hands its update over
  // and frame f + 1 waits for it before it streams, so the volume a frame reads is the previous
  // frame's (one frame late). The flight then keeps to real time (frame f starts f / fps seconds
  // after the first): a game's frame leaves the worker the time its other work takes, which a
  // flight that only streams and updates does not have. The frame time counts the frame's own
  // thread (its wait for the worker included); the worker's time is reported beside it.
  bool volume_worker = false;
  // Each update also packs the fine level for the shaders (RuntimeOptions::fine_shader): its
  // cost is in the worker's time (or the frame's, inline).
  bool fine_shader = false;
  // The streamer is told where the camera will be along the flight path (Camera::path_ahead), as
  // an engine that knows a camera's spline or route would: 8 points up to its look-ahead (its
  // guard included), at least this many seconds apart, with the spline's largest distance from
  // their chords (x 1.5) as the tolerance; 0 = the velocity alone.
  double path_ahead_step_s = 0.1;
  // Called every ~1 % of the flight with (frames done, frames total): progress for a terminal.
  std::function<void(int, int)> progress;
};

struct FlyFrame {
  streamer::FrameStats stats;             // the streamer's view of the frame
  glm::dvec3 position_m{0.0};   // camera
  double hour = 0.0;            // time of day
  double relight_ms = 0.0;      // Runtime::addSector of this frame's loads (0 without runtime);
                                // with volume_worker, queueing them (the adds are in worker_ms)
  double volume_ms = 0.0;       // Runtime::setTime + update: relight if needed, scroll, publish.
                                // With volume_worker: the frame thread's part (setTime, the wait
                                // for the previous frame's update, the hand-over)
  double worker_ms = 0.0;       // volume_worker: the worker's time for this frame's adds and update
  double wait_ms = 0.0;         // volume_worker: this frame's wait for the previous frame's update
  bool waited = false;          // volume_worker: that update was still running when the frame began
  int runtime_probes = 0;       // probes the runtime held after this frame's update
  bool full_relight = false;    // the runtime relit every resident probe this frame
  bool lights_relit = false;    // it relit only the sectors changed lights reach (Runtime::lightRelightCount)
  double lights_ms = 0.0;       // Runtime::setLights of this frame's moving lights (0 without)
  double technique_ms = 0.0;    // FlyOptions::technique_frame's update (0 without)
  TechniqueFrameCost technique; // its whole report (reach -1 unless streamed)
  double frame_ms = 0.0;        // stats.update_ms + relight_ms + lights_ms + volume_ms + technique_ms
};

// A top-down picture of the world at one frame: RGB8, row 0 = north (max y).
struct FlySnapshot {
  int frame = 0;
  image::RgbImage image;
};

struct FlyResult {
  std::string archive;              // path as given, for the report
  std::string runtime_note;         // what the runtime did, or why it did not run
  FlyOptions options;
  streamer::StreamerOptions streamer;
  double path_length_m = 0.0;
  bool loop = false;
  std::vector<glm::dvec3> waypoints;
  int warmup_frames = 0;            // warm-up updates run before frame 0
  std::vector<FlyFrame> frames;
  std::vector<FlySnapshot> snapshots;
  std::vector<streamer::SectorFailure> failures;
  size_t max_bytes = 0;             // the streamer's byte budget
  size_t volume_bytes = 0;          // the runtime's 3 RGBA8 textures (0 without runtime)
  size_t io_working_bytes = 0;      // the loads' working memory at most (streamer::Streamer::ioWorkingBytes)
  uint64_t total_loads = 0, total_evictions = 0;
  // Every load's latency, camera seconds from the update that asked for it to the one that handed
  // it over (Streamer::lastLoadLatenciesS), in flight order; warm-up loads left out.
  std::vector<double> load_latencies_s;
  // What the sectors were read from, for the report: "file", or the HTTP source's counts
  // ("N requests on C connections, R retries, F failed reads, B payload bytes"). Set by the caller.
  std::string source_note;
};

// Flies `path` with `streamer` (fresh: nothing resident). Errors: the runtime rejected the
// archive's lighting or a sector (the message says which). Frame's thread; not reentrant.
Result<FlyResult> fly(streamer::Streamer& streamer, const CatmullRomPath& path, const FlyOptions& options, std::string archive_name);

// Summary figures of a flight (also in fly-report.json).
struct FlySummary {
  int frames = 0;
  int max_resident = 0;
  size_t max_resident_bytes = 0, max_reserved_bytes = 0;
  int64_t loads = 0, evictions = 0, failures = 0, misses = 0, frames_with_misses = 0;
  double frame_ms_p50 = 0, frame_ms_p99 = 0, frame_ms_max = 0;
  double update_ms_p99 = 0, relight_ms_p99 = 0, volume_ms_p99 = 0, technique_ms_p99 = 0;
  // volume_worker: the worker's update p99, the frames that found it still running, and how
  // many frames late the volume a frame reads is (0 inline, 1 with the worker).
  bool volume_worker = false;
  double worker_ms_p99 = 0, wait_ms_p99 = 0;
  int frames_waited = 0, volume_late_frames = 0;
  double inline_io_ms_mean_per_load = 0;  // kDeterministic: the I/O threads' work per sector
  int full_relights = 0;
  // Load latency (FlyResult::load_latencies_s), milliseconds; and the largest residency guard
  // the streamer used (seconds ahead that are tier 0, sized by the latency it measured).
  double latency_ms_p50 = 0, latency_ms_p95 = 0, latency_ms_p99 = 0, latency_ms_max = 0;
  double guard_s_max = 0;
  // A streamed technique: sector-frames within the volume's reach without per-sector state, the
  // frames with any, the most sectors in reach, the most stale, and the inline (worker) time.
  bool technique_streamed = false;
  int64_t technique_misses = 0, technique_frames_with_misses = 0;
  int technique_reach_max = 0, technique_stale_max = 0, technique_held_max = 0;
  size_t technique_bytes_max = 0;
  double technique_inline_ms_total = 0;
};
FlySummary summarize(const FlyResult& result);

// Writes frames.csv, fly-report.json, fly-report.md, resident-bytes.png, frame-time.png and
// topdown-<frame>.png into `outdir` (created). Error names the file that could not be written.
Result<void> writeFlyReport(const FlyResult& result, const std::filesystem::path& outdir);

}  // namespace drtv::fly
