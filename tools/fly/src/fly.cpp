// The fly-through and its report (fly.h).
#include "drtv/fly/fly.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "drtv/image/image.h"
#include "drtv/runtime/runtime.h"
#include "drtv/runtime/update_worker.h"

namespace drtv::fly {
using namespace streamer;
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Hands the streamer's sectors to the runtime and remembers what was ever loaded (for pictures).
class FlySink final : public SectorSink {
 public:
  FlySink(runtime::Runtime* rt, SectorSink* technique) : rt_(rt), technique_(technique) {}
  void onSectorLoaded(const Sector& sector, const OcclusionTile& tile) override {
    ever_loaded.insert(sector.key);
    if (technique_) {
      const auto t0 = Clock::now();
      technique_->onSectorLoaded(sector, tile);
      technique_ms += msSince(t0);
    }
    if (!rt_) return;
    const auto t0 = Clock::now();
    // The streamer keeps `sector` until onSectorEvicted returns: the runtime borrows its LPRT block.
    if (worker_) {
      worker_->addSector(sector, &tile, runtime::SectorBlock::kBorrow);  // added on the worker
    } else if (auto ok = rt_->addSector(sector, &tile, runtime::SectorBlock::kBorrow); !ok) {
      error(ok.error());
    }
    relight_ms += msSince(t0);
  }
  void onSectorEvicted(SectorKey key) override {
    // A load queued for the worker and evicted before it was handed over was never added.
    if (rt_ && !(worker_ && worker_->cancelAdd(key))) rt_->removeSector(key);
    if (technique_) {
      const auto t0 = Clock::now();
      technique_->onSectorEvicted(key);
      technique_ms += msSince(t0);
    }
  }
  // From here on the runtime's adds are queued for `worker` (its wait() must have returned).
  void setWorker(runtime::UpdateWorker* worker) { worker_ = worker; }
  void error(const Error& e) {
    ++runtime_errors;
    if (first_error.empty()) first_error = e.message;
  }
  std::set<SectorKey> ever_loaded;
  double relight_ms = 0.0, technique_ms = 0.0;
  int runtime_errors = 0;
  std::string first_error;

 private:
  runtime::Runtime* rt_;
  runtime::UpdateWorker* worker_ = nullptr;
  SectorSink* technique_;
};

struct KeyRange {
  int32_t x0, y0, x1, y1;
};
KeyRange keyRange(const Manifest& m) {
  KeyRange r{0, 0, 0, 0};
  if (m.sectors.empty()) return r;
  r = {INT32_MAX, INT32_MAX, INT32_MIN, INT32_MIN};
  for (const SectorEntry& e : m.sectors) {
    r.x0 = std::min(r.x0, e.key.ix);
    r.y0 = std::min(r.y0, e.key.iy);
    r.x1 = std::max(r.x1, e.key.ix);
    r.y1 = std::max(r.y1, e.key.iy);
  }
  return r;
}

// Widest archive, in sectors, that gets top-down pictures (8 px per sector at least: 4096 px).
constexpr int64_t kMaxPictureSectors = 512;

// Top-down picture: one block per sector (its occlusion tile when resident), the volume's
// footprint, the path and the camera.
FlySnapshot snapshot(const Streamer& s, const FlySink& sink, const CatmullRomPath& path, const Camera& cam, int frame) {
  const Manifest& m = s.manifest();
  const KeyRange kr = keyRange(m);
  const int nx = kr.x1 - kr.x0 + 3, ny = kr.y1 - kr.y0 + 3;  // one sector of margin each side
  const int ps = std::clamp(8 * int(std::lround(640.0 / (8.0 * std::max(nx, ny)))), 8, 64);  // pixels per sector
  image::Canvas c(nx * ps, ny * ps, {18, 28, 56});
  const double x0_m = (kr.x0 - 1) * kSectorSizeM, y0_m = (kr.y0 - 1) * kSectorSizeM;
  auto px = [&](double wx) { return (wx - x0_m) / kSectorSizeM * ps; };
  auto py = [&](double wy) { return c.height() - (wy - y0_m) / kSectorSizeM * ps; };
  const int tp = ps / runtime::kOcclusionTileDim;
  for (const SectorEntry& e : m.sectors) {
    const int sx = int(px(e.key.ix * kSectorSizeM)), sy = int(py((e.key.iy + 1) * kSectorSizeM));
    const SectorState st = s.state(e.key);
    image::Rgb col{72, 72, 72};  // in the archive, never loaded
    if (st == SectorState::kQueued || st == SectorState::kLoading) col = {215, 175, 40};
    else if (st == SectorState::kBackingOff) col = {205, 40, 205};
    else if (sink.ever_loaded.count(e.key)) col = {120, 52, 52};  // evicted
    if (const OcclusionTile* t = s.occlusionTile(e.key)) {
      for (int ty = 0; ty < runtime::kOcclusionTileDim; ++ty)
        for (int tx = 0; tx < runtime::kOcclusionTileDim; ++tx) {
          const float v = t->visibility(tx, ty);
          const image::Rgb g{uint8_t(30 + 90 * v), uint8_t(90 + 165 * v), uint8_t(30 + 90 * v)};
          const int y = sy + (runtime::kOcclusionTileDim - 1 - ty) * tp;  // tile row 0 is south
          c.fill(sx + tx * tp, y, sx + (tx + 1) * tp, y + tp, g);
        }
    } else {
      c.fill(sx, sy, sx + ps, sy + ps, col);
    }
    if (ps >= 16) c.rect(sx, sy, sx + ps - 1, sy + ps - 1, {40, 40, 40});
  }
  const Footprint f = volumeFootprint(cam.position_m, s.options().residency);
  c.rect(int(px(f.min.x)), int(py(f.max.y)), int(px(f.max.x)), int(py(f.min.y)), {255, 255, 255});
  const double step = std::max(1.0, path.lengthM() / 2000.0);
  for (double a = 0; a + step <= path.lengthM(); a += step) {
    const glm::dvec3 p = path.position(a), q = path.position(a + step);
    c.line(px(p.x), py(p.y), px(q.x), py(q.y), {90, 150, 255});
  }
  c.fill(int(px(cam.position_m.x)) - 3, int(py(cam.position_m.y)) - 3, int(px(cam.position_m.x)) + 4,
         int(py(cam.position_m.y)) + 4, {255, 60, 40});
  c.digits(6, 6, std::to_string(frame), {255, 255, 255}, 3);
  return {frame, c.take()};
}

// The points of the flight path the streamer is told per frame (FlyOptions::path_ahead_step_s).
constexpr int kPathAheadPoints = 8;

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, size_t(std::ceil(p * double(v.size()))) - (p > 0 ? 1 : 0));
  return v[i];
}

}  // namespace

Result<FlyResult> fly(Streamer& streamer, const CatmullRomPath& path, const FlyOptions& o, std::string archive_name) {
  // Options come from the command line: bad values are errors, not bugs.
  if (!(std::isfinite(o.fps) && o.fps > 0.0)) return fail("fly: fps must be a finite number > 0");
  if (!(std::isfinite(o.speed_mps) && o.speed_mps >= 0.0)) return fail("fly: speed must be a finite number >= 0");
  if (!std::isfinite(o.start_hour) || !std::isfinite(o.hours_per_s)) return fail("fly: start hour and time-of-day rate must be finite");
  if (o.frames < 0 || o.frames > kMaxFlyFrames) return fail("fly: frames must be in [0, " + std::to_string(kMaxFlyFrames) + "]");
  const Manifest& m = streamer.manifest();
  FlyResult r;
  r.archive = std::move(archive_name);
  r.options = o;
  r.streamer = streamer.options();
  r.path_length_m = path.lengthM();
  r.loop = path.closed();
  r.waypoints = path.waypoints();
  r.max_bytes = streamer.maxBytes();
  r.io_working_bytes = streamer.ioWorkingBytes();

  for (size_t i = 0; i < o.light_paths.size(); ++i)
    if (!o.light_paths[i].keys.empty())
      if (auto e = validateLightPath(o.light_paths[i]); !e)
        return fail("fly: lights[" + std::to_string(i) + "].path." + e.error().message);
  if (o.light_paths.size() > o.lights.size()) return fail("fly: more light paths than lights");
  if (o.technique_frame && o.runtime) return fail("fly: a technique of its own and drtv::runtime: give one");
  if (o.technique_sink && !o.technique_frame) return fail("fly: a technique sink without its frame");

  std::unique_ptr<runtime::Runtime> rt;
  if (o.technique_frame) {
    r.runtime_note = "technique " + o.technique +
                     (o.technique_sink ? ": streamed per sector (the streamer's loads and evictions go to it; drtv::runtime off); "
                                       : ": its own update per frame (drtv::runtime off); ") +
                     std::to_string(o.technique_bytes) + " B of its state";
  } else if (o.runtime) {
    runtime::RuntimeOptions ro = o.runtime_options ? *o.runtime_options : runtime::optionsForEffects(m.effects);
    // The volume the streamer holds the sectors of (its residency's tier 0); fill and blur stay
    // what the archive's effects ask for.
    ro.volume.size = streamer.options().residency.volume.size;
    ro.volume.texel_size_m = streamer.options().residency.volume.texel_size_m;
    if (o.fine_shader) ro.fine_shader = runtime::FineShaderOptions{};
    const std::vector<PointLight>& lights = o.lights.empty() ? m.lights : o.lights;
    auto made = runtime::runtimeForArchive(m, ro, o.start_hour, &lights);
    if (!made) return std::unexpected(made.error().context(r.archive));
    rt = std::move(*made);
    r.runtime_note = "drtv::runtime: Runtime::addSector per load, setTime + update per frame (" +
                     effectsToString(m.effects) + ")";
    if (!o.technique.empty()) r.runtime_note += "; technique " + o.technique;
    const size_t movers = size_t(std::count_if(o.light_paths.begin(), o.light_paths.end(), [](const LightPath& p) { return !p.keys.empty(); }));
    if (movers > 0)
      r.runtime_note += "; " + std::to_string(movers) + " of " + std::to_string(lights.size()) +
                        " lights move (Runtime::setLights every frame, in the frame time)";
  } else {
    r.runtime_note = "runtime off (--no-runtime): streaming only; relight and volume times are 0";
  }
  FlySink sink(rt.get(), o.technique_sink);

  const double dt = 1.0 / o.fps;
  const double travel_s = o.speed_mps > 0 ? path.lengthM() / o.speed_mps : 0.0;
  const double path_frames = std::ceil(travel_s * o.fps) + 1.0;
  if (o.frames == 0 && (o.speed_mps <= 0.0 || !(path_frames <= double(kMaxFlyFrames))))
    return fail("fly: flying the " + std::to_string(int64_t(path.lengthM())) + " m path once at " + std::to_string(o.speed_mps) +
                " m/s takes more than " + std::to_string(kMaxFlyFrames) + " frames: raise the speed or give the frame count");
  const int frames = o.frames > 0 ? o.frames : std::max(1, int(path_frames));
  if (o.warmup_frames > 0) {
    const Camera start{path.position(0.0), path.direction(0.0) * o.speed_mps};
    // Warm-up time runs up to t = 0 so that back-off and simulated latency stay consistent. A
    // streamed technique warms up with it (its sectors' state built before the flight starts).
    // With I/O or worker threads real time must pass for them, a frame's worth per update: else
    // the camera's clock would race ahead of the reads, the warm-up would end before they are
    // done, and the streamer would measure a 20 ms read as seconds of flight (and size its
    // look-ahead by that).
    const bool real_time = streamer.options().io_mode == IoMode::kThreads;
    for (int i = 0; i < o.warmup_frames; ++i) {
      const double t = double(i - o.warmup_frames) * dt;
      streamer.update(start, t, sink);
      ++r.warmup_frames;
      bool technique_idle = true;
      if (o.technique_sink) {
        auto c = o.technique_frame(start, t, std::fmod(o.start_hour, 24.0), o.lights.empty() ? m.lights : o.lights);
        if (!c) return std::unexpected(c.error().context("fly: warm-up"));
        technique_idle = c->idle;
      }
      if (streamer.idle() && technique_idle && i > 0) break;
      if (real_time) std::this_thread::sleep_for(std::chrono::duration<double>(dt));
    }
    if (rt) rt->update(start.position_m);
  }
  std::vector<int> snap_at;
  // Top-down pictures cost 8 px per sector at least: a world wider than kMaxPictureSectors gets none.
  const KeyRange kr = keyRange(m);
  const bool pictures = int64_t(kr.x1) - kr.x0 + 3 <= kMaxPictureSectors && int64_t(kr.y1) - kr.y0 + 3 <= kMaxPictureSectors;
  if (!pictures) r.runtime_note += "; no top-down pictures: the archive spans more than " + std::to_string(kMaxPictureSectors) + " sectors";
  for (int k = 1; pictures && k <= o.snapshots; ++k) snap_at.push_back(std::min(frames - 1, int(std::lround(double(frames - 1) * k / o.snapshots))));
  r.frames.reserve(size_t(frames));
  const bool moving = std::any_of(o.light_paths.begin(), o.light_paths.end(), [](const LightPath& p) { return !p.keys.empty(); });
  std::vector<PointLight> lights_now = o.lights;
  // With I/O threads and a streamed technique's workers, the flight keeps to real time (a frame
  // every 1/fps seconds, as a game would): the workers get the time the frames would leave them.
  std::optional<runtime::UpdateWorker> worker;
  if (rt && o.volume_worker) {
    worker.emplace(*rt);
    sink.setWorker(&*worker);
  }
  const bool pace = (o.technique_sink && streamer.options().io_mode == IoMode::kThreads) || worker.has_value();
  // With the worker, what an update did (a full relight, lights relit) is read once it is done.
  uint64_t relights_before = 0, light_relights_before = 0;
  auto finishUpdate = [&](FlyFrame& frame) {
    frame.worker_ms = worker->lastUpdateMs();
    for (const auto& [key, e] : worker->takeAddErrors()) sink.error(e);
    frame.full_relight = rt->relightCount() != relights_before;
    frame.lights_relit = rt->lightRelightCount() != light_relights_before;
    frame.runtime_probes = rt->cache().probeCount();
  };
  std::vector<glm::dvec3> ahead;  // Camera::path_ahead's points
  ahead.reserve(kPathAheadPoints);
  const auto flight_start = Clock::now();
  for (int f = 0; f < frames; ++f) {
    const double t = f * dt;
    if (pace) std::this_thread::sleep_until(flight_start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(t)));
    FlyFrame ff;
    if (worker && f > 0) {
      // The runtime is the worker's until its update is done: wait before the sectors stream.
      const auto t0 = Clock::now();
      ff.waited = worker->busy();
      worker->wait();
      ff.wait_ms = msSince(t0);
      finishUpdate(r.frames.back());
    }
    const double s_m = o.speed_mps * t;
    Camera cam{path.position(s_m), path.direction(s_m) * o.speed_mps};
    if (!path.closed() && s_m >= path.lengthM()) cam.velocity_mps = glm::dvec3(0.0);
    if (o.path_ahead_step_s > 0.0) {
      // Points along the path up to the streamer's look-ahead (its guard included).
      // At most kPathAheadPoints: each costs the ranking a test per sector; the chord error
      // between them is the tolerance below.
      const double reach_s = std::max(streamer.guardS(), streamer.options().residency.lookahead_s);
      const double step_s = std::max(o.path_ahead_step_s, reach_s / kPathAheadPoints);
      const int n = std::min(kPathAheadPoints, int(std::ceil(reach_s / step_s)));
      ahead.clear();
      const double step_m = o.speed_mps * step_s;
      double stray_m = 0.0;  // the spline's largest distance from a chord, measured at its middles
      for (int i = 1; i <= n; ++i) {
        ahead.push_back(path.position(s_m + step_m * i));
        const glm::dvec3 from = i == 1 ? cam.position_m : ahead[size_t(i - 2)];
        stray_m = std::max(stray_m, glm::length(path.position(s_m + step_m * (i - 0.5)) - 0.5 * (from + ahead.back())));
      }
      cam.path_ahead = ahead;
      cam.path_step_s = step_s;
      cam.path_tolerance_m = 1.5 * stray_m;  // the middle is not always the farthest point
    }
    ff.position_m = cam.position_m;
    ff.hour = std::fmod(o.start_hour + o.hours_per_s * t, 24.0);
    sink.relight_ms = 0.0;
    sink.technique_ms = 0.0;
    ff.stats = streamer.update(cam, t, sink);
    const auto latencies = streamer.lastLoadLatenciesS();
    r.load_latencies_s.insert(r.load_latencies_s.end(), latencies.begin(), latencies.end());
    ff.relight_ms = sink.relight_ms;
    if ((rt || o.technique_frame) && moving) {
      const auto t0 = Clock::now();
      for (size_t i = 0; i < o.light_paths.size(); ++i)
        if (!o.light_paths[i].keys.empty()) lights_now[i] = lightAt(o.lights[i], o.light_paths[i], t);
      if (rt) (void)rt->setLights(lights_now);  // validated paths give valid lights
      ff.lights_ms = msSince(t0);
    }
    if (o.technique_frame) {
      auto c = o.technique_frame(cam, t, ff.hour, o.lights.empty() ? m.lights : lights_now);
      if (!c) return std::unexpected(c.error().context("fly: frame " + std::to_string(f)));
      ff.technique = *c;
      ff.technique_ms = c->ms + sink.technique_ms;
    }
    if (rt) {
      relights_before = rt->relightCount();
      light_relights_before = rt->lightRelightCount();
      const auto t0 = Clock::now();
      (void)rt->setTime(ff.hour);  // finite by construction
      if (worker) {
        worker->start(cam.position_m);
        ff.volume_ms = ff.wait_ms + msSince(t0);
      } else {
        rt->update(cam.position_m);
        ff.volume_ms = msSince(t0);
        ff.full_relight = rt->relightCount() != relights_before;
        ff.lights_relit = rt->lightRelightCount() != light_relights_before;
        ff.runtime_probes = rt->cache().probeCount();
      }
    }
    ff.frame_ms = ff.stats.update_ms + ff.relight_ms + ff.lights_ms + ff.volume_ms + ff.technique_ms;
    r.frames.push_back(ff);
    if (std::find(snap_at.begin(), snap_at.end(), f) != snap_at.end()) r.snapshots.push_back(snapshot(streamer, sink, path, cam, f));
    if (o.progress && (f % std::max(1, frames / 100) == 0 || f == frames - 1)) o.progress(f + 1, frames);
  }
  if (worker) {
    worker->wait();
    sink.setWorker(nullptr);
    if (!r.frames.empty()) finishUpdate(r.frames.back());
    r.runtime_note += "; volume updated on a worker thread, published one frame late (the flight kept to real time)";
  }
  if (rt) {
    const auto view = rt->volume().read();
    size_t bytes = 0;
    for (int c = 0; c < 3; ++c) bytes += view->texture(c).size_bytes();
    r.volume_bytes = 2 * bytes;  // PublishedVolume double-buffers (publish.h)
    r.runtime_note += "; volume " + std::to_string(bytes) + " B per buffer x 2 buffers (double-buffered)";
    if (sink.runtime_errors)
      r.runtime_note += "; " + std::to_string(sink.runtime_errors) + " sectors rejected by the runtime, first: " + sink.first_error;
  }
  r.failures.assign(streamer.failures().begin(), streamer.failures().end());
  r.total_loads = streamer.totalLoads();
  r.total_evictions = streamer.totalEvictions();
  return r;
}

FlySummary summarize(const FlyResult& r) {
  FlySummary s;
  s.frames = int(r.frames.size());
  std::vector<double> frame_ms, update_ms, relight_ms, volume_ms, technique_ms, worker_ms, wait_ms;
  double io_ms = 0;
  s.volume_worker = r.options.volume_worker && r.options.runtime;
  s.volume_late_frames = s.volume_worker ? 1 : 0;
  for (const FlyFrame& f : r.frames) {
    if (s.volume_worker) {
      worker_ms.push_back(f.worker_ms);
      wait_ms.push_back(f.wait_ms);
      s.frames_waited += f.waited;
    }
    s.max_resident = std::max(s.max_resident, f.stats.resident);
    s.max_resident_bytes = std::max(s.max_resident_bytes, f.stats.resident_bytes);
    s.max_reserved_bytes = std::max(s.max_reserved_bytes, f.stats.reserved_bytes);
    s.loads += f.stats.loads;
    s.evictions += f.stats.evictions;
    s.failures += f.stats.failures;
    s.misses += f.stats.misses;
    s.frames_with_misses += f.stats.misses > 0;
    s.full_relights += f.full_relight;
    s.guard_s_max = std::max(s.guard_s_max, f.stats.guard_s);
    io_ms += f.stats.inline_io_ms;
    frame_ms.push_back(f.frame_ms);
    update_ms.push_back(f.stats.update_ms);
    relight_ms.push_back(f.relight_ms);
    volume_ms.push_back(f.volume_ms);
    technique_ms.push_back(f.technique_ms);
    if (f.technique.reach >= 0) {
      s.technique_streamed = true;
      s.technique_misses += f.technique.missing;
      s.technique_frames_with_misses += f.technique.missing > 0;
      s.technique_reach_max = std::max(s.technique_reach_max, f.technique.reach);
      s.technique_stale_max = std::max(s.technique_stale_max, f.technique.stale);
      s.technique_held_max = std::max(s.technique_held_max, f.technique.held);
      s.technique_bytes_max = std::max(s.technique_bytes_max, f.technique.bytes);
      s.technique_inline_ms_total += f.technique.inline_ms;
    }
  }
  std::vector<double> latency_ms;
  for (double l : r.load_latencies_s) latency_ms.push_back(l * 1000.0);
  s.latency_ms_p50 = percentile(latency_ms, 0.5);
  s.latency_ms_p95 = percentile(latency_ms, 0.95);
  s.latency_ms_p99 = percentile(latency_ms, 0.99);
  s.latency_ms_max = percentile(latency_ms, 1.0);
  s.frame_ms_p50 = percentile(frame_ms, 0.5);
  s.frame_ms_p99 = percentile(frame_ms, 0.99);
  s.frame_ms_max = frame_ms.empty() ? 0 : *std::max_element(frame_ms.begin(), frame_ms.end());
  s.update_ms_p99 = percentile(update_ms, 0.99);
  s.relight_ms_p99 = percentile(relight_ms, 0.99);
  s.volume_ms_p99 = percentile(volume_ms, 0.99);
  s.worker_ms_p99 = percentile(worker_ms, 0.99);
  s.wait_ms_p99 = percentile(wait_ms, 0.99);
  s.technique_ms_p99 = percentile(technique_ms, 0.99);
  const int64_t started = [&] {
    int64_t n = 0;
    for (const FlyFrame& f : r.frames) n += f.stats.started;
    return n;
  }();
  s.inline_io_ms_mean_per_load = started ? io_ms / double(started) : 0.0;
  return s;
}

Result<void> writeFlyReport(const FlyResult& r, const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return fail(dir.string() + ": cannot create: " + ec.message());
  const FlySummary s = summarize(r);
  const bool deterministic = r.streamer.io_mode == IoMode::kDeterministic;

  {  // frames.csv
    const auto p = dir / "frames.csv";
    std::ofstream f(p);
    if (!f) return fail(p.string() + ": cannot write");
    f << "frame,time_s,x_m,y_m,z_m,hour,resident,in_flight,wanted,loads,evictions,cancels,failures,misses,fallback,"
         "resident_bytes,reserved_bytes,update_ms,relight_ms,volume_ms,frame_ms,full_relight,inline_io_ms,technique_ms,"
         "technique_reach,technique_missing,technique_stale,technique_held,technique_inline_ms,worker_ms,wait_ms,waited,guard_s,"
         "latency_max_ms\n";
    char line[512];
    for (const FlyFrame& x : r.frames) {
      const FrameStats& st = x.stats;
      std::snprintf(line, sizeof line, "%llu,%.6f,%.3f,%.3f,%.3f,%.5f,%d,%d,%d,%d,%d,%d,%d,%d,%d,%zu,%zu,%.5f,%.5f,%.5f,%.5f,%d,%.5f,%.5f,%d,%d,%d,%d,%.5f,%.5f,%.5f,%d,%.4f,%.3f\n",
                    (unsigned long long)st.frame, st.time_s, x.position_m.x, x.position_m.y, x.position_m.z, x.hour, st.resident,
                    st.in_flight, st.wanted, st.loads, st.evictions, st.cancels, st.failures, st.misses, st.fallback,
                    st.resident_bytes, st.reserved_bytes, st.update_ms, x.relight_ms, x.volume_ms, x.frame_ms, int(x.full_relight),
                    st.inline_io_ms, x.technique_ms, x.technique.reach, x.technique.missing, x.technique.stale,
                    x.technique.held, x.technique.inline_ms, x.worker_ms, x.wait_ms, int(x.waited), st.guard_s,
                    st.latency_max_s * 1000.0);
      f << line;
    }
    if (!f) return fail(p.string() + ": write failed");
  }

  std::vector<double> bytes_kib, frame_ms;
  for (const FlyFrame& x : r.frames) {
    bytes_kib.push_back(double(x.stats.resident_bytes) / 1024.0);
    frame_ms.push_back(x.frame_ms);
  }
  const double budget_kib = double(r.max_bytes) / 1024.0;
  {
    auto c = image::linePlot(bytes_kib, {30, 90, 200}, {{budget_kib, {220, 40, 40}}}, budget_kib * 1.1);
    if (auto ok = image::writePng(dir / "resident-bytes.png", c.image()); !ok) return ok;
  }
  {
    const double y_max = std::max({1.2, s.frame_ms_p99 * 1.5, 0.0});
    auto c = image::linePlot(frame_ms, {30, 140, 60}, {{1.0, {220, 40, 40}}, {s.frame_ms_p99, {240, 150, 20}}}, y_max);
    if (auto ok = image::writePng(dir / "frame-time.png", c.image()); !ok) return ok;
  }
  std::vector<std::string> snaps;
  for (const FlySnapshot& sn : r.snapshots) {
    char name[64];
    std::snprintf(name, sizeof name, "topdown-%05d.png", sn.frame);
    if (auto ok = image::writePng(dir / name, sn.image); !ok) return ok;
    snaps.push_back(name);
  }

  nlohmann::json j;
  j["archive"] = r.archive;
  j["runtime"] = r.runtime_note;
  j["io_mode"] = deterministic ? "deterministic" : "threads";
  j["source"] = r.source_note;
  j["deterministic"] = deterministic;
  j["warmup_frames"] = r.warmup_frames;
  j["options"] = {{"speed_mps", r.options.speed_mps}, {"fps", r.options.fps}, {"frames", s.frames},
                  {"start_hour", r.options.start_hour}, {"hours_per_s", r.options.hours_per_s},
                  {"max_sectors", r.streamer.residency.max_sectors}, {"volume_texel_m", r.streamer.residency.volume.texel_size_m.x},
                  {"lookahead_s", r.streamer.residency.lookahead_s}, {"guard_s", r.streamer.residency.guard_s},
                  {"io_threads", r.streamer.io_threads}, {"simulated_latency_s", r.streamer.simulated_latency_s},
                  {"max_in_flight", r.streamer.max_in_flight}, {"guard_latency_factor", r.streamer.guard_latency_factor},
                  {"path_ahead_step_s", r.options.path_ahead_step_s}};
  nlohmann::json wps = nlohmann::json::array();
  for (const auto& w : r.waypoints) wps.push_back({w.x, w.y, w.z});
  j["path"] = {{"length_m", r.path_length_m}, {"loop", r.loop}, {"waypoints", wps}};
  j["budget"] = {{"max_sectors", r.streamer.residency.max_sectors}, {"max_bytes", r.max_bytes},
                 {"volume_bytes", r.volume_bytes}, {"io_working_bytes", r.io_working_bytes}};
  j["summary"] = {{"frames", s.frames},
                  {"max_resident", s.max_resident},
                  {"max_resident_bytes", s.max_resident_bytes},
                  {"max_reserved_bytes", s.max_reserved_bytes},
                  {"loads", s.loads},
                  {"evictions", s.evictions},
                  {"failures", s.failures},
                  {"misses", s.misses},
                  {"frames_with_misses", s.frames_with_misses},
                  {"frame_ms_p50", s.frame_ms_p50},
                  {"frame_ms_p99", s.frame_ms_p99},
                  {"frame_ms_max", s.frame_ms_max},
                  {"update_ms_p99", s.update_ms_p99},
                  {"relight_ms_p99", s.relight_ms_p99},
                  {"volume_ms_p99", s.volume_ms_p99},
                  {"technique_ms_p99", s.technique_ms_p99},
                  {"full_relights", s.full_relights},
                  {"inline_io_ms_per_load", s.inline_io_ms_mean_per_load},
                  {"volume_worker", s.volume_worker},
                  {"volume_late_frames", s.volume_late_frames},
                  {"worker_ms_p99", s.worker_ms_p99},
                  {"wait_ms_p99", s.wait_ms_p99},
                  {"frames_waited", s.frames_waited},
                  {"latency_ms_p50", s.latency_ms_p50},
                  {"latency_ms_p95", s.latency_ms_p95},
                  {"latency_ms_p99", s.latency_ms_p99},
                  {"latency_ms_max", s.latency_ms_max},
                  {"guard_s_max", s.guard_s_max}};
  if (s.technique_streamed)
    j["technique_stream"] = {{"technique", r.options.technique},
                             {"misses", s.technique_misses},
                             {"frames_with_misses", s.technique_frames_with_misses},
                             {"reach_max", s.technique_reach_max},
                             {"held_max", s.technique_held_max},
                             {"stale_max", s.technique_stale_max},
                             {"bytes_max", s.technique_bytes_max},
                             {"inline_ms_total", s.technique_inline_ms_total}};
  j["goals"] = {{"zero_misses", s.misses == 0}, {"p99_frame_ms_le_1", s.frame_ms_p99 <= 1.0},
                {"within_sector_budget", s.max_resident <= r.streamer.residency.max_sectors},
                {"within_byte_budget", s.max_reserved_bytes <= r.max_bytes}};
  nlohmann::json fails = nlohmann::json::array();
  for (const SectorFailure& f : r.failures)
    fails.push_back({{"sector", toString(f.key)}, {"attempt", f.attempt}, {"time_s", f.time_s}, {"retry_at_s", f.retry_at_s},
                     {"message", f.message}});
  j["failures"] = fails;
  j["snapshots"] = snaps;
  {
    const auto p = dir / "fly-report.json";
    std::ofstream f(p);
    if (!f) return fail(p.string() + ": cannot write");
    f << j.dump(2) << "\n";
  }

  const auto p = dir / "fly-report.md";
  std::ofstream md(p);
  if (!md) return fail(p.string() + ": cannot write");
  char buf[1024];
  md << "# drtv fly: " << r.archive << "\n\n";
  std::snprintf(buf, sizeof buf,
                "%d frames at %.0f Hz, %.0f m/s along %s Catmull-Rom path of %.0f m (%zu waypoints); time of day "
                "%.2f h + %.3f h/s.\n\n",
                s.frames, r.options.fps, r.options.speed_mps, r.loop ? "a closed" : "an open", r.path_length_m, r.waypoints.size(),
                r.options.start_hour, r.options.hours_per_s);
  md << buf;
  md << "Runtime: " << r.runtime_note << ".\n\n";
  md << "Warm-up: " << r.warmup_frames << " streamer updates with the camera held at the start before frame 0 (not "
        "in the figures below).\n\n";
  if (deterministic)
    md << "I/O: **deterministic** — reads run inline and complete " << r.streamer.simulated_latency_s * 1000.0
       << " ms later in flight time, so loads, evictions, misses and bytes are the same on every run; the "
          "times below are measurements and vary.\n\n";
  else
    md << "I/O: **" << r.streamer.io_threads << " background threads** — the frame in which a load arrives depends on "
          "the OS, so loads, evictions and misses per frame are not reproducible.\n\n";
  md << "| figure | value | goal |\n|---|---|---|\n";
  std::snprintf(buf, sizeof buf, "| resident sectors, max | %d | <= %d |\n", s.max_resident, r.streamer.residency.max_sectors);
  md << buf;
  std::snprintf(buf, sizeof buf, "| resident bytes, max | %zu (%.1f KiB) | <= %zu (%.1f KiB) |\n", s.max_resident_bytes,
                s.max_resident_bytes / 1024.0, r.max_bytes, r.max_bytes / 1024.0);
  md << buf;
  std::snprintf(buf, sizeof buf, "| resident + in-flight bytes, max | %zu | <= %zu |\n", s.max_reserved_bytes, r.max_bytes);
  md << buf;
  std::snprintf(buf, sizeof buf, "| volume textures (runtime) | %zu B | on top |\n", r.volume_bytes);
  md << buf;
  std::snprintf(buf, sizeof buf, "| loads' working memory, at most | %zu B (readers x (largest compressed + raw sector + zstd context)) | on top |\n",
                r.io_working_bytes);
  md << buf;
  std::snprintf(buf, sizeof buf, "| misses (sector-frames) | %lld in %lld frames | 0 |\n", (long long)s.misses,
                (long long)s.frames_with_misses);
  md << buf;
  std::snprintf(buf, sizeof buf, "| loads / evictions / failures | %lld / %lld / %lld | |\n", (long long)s.loads,
                (long long)s.evictions, (long long)s.failures);
  md << buf;
  std::snprintf(buf, sizeof buf,
                "| load latency ms p50 / p95 / p99 / max (request to hand-over, flight time) | %.1f / %.1f / %.1f / %.1f | |\n",
                s.latency_ms_p50, s.latency_ms_p95, s.latency_ms_p99, s.latency_ms_max);
  md << buf;
  std::snprintf(buf, sizeof buf, "| residency guard, max (s ahead loaded first: %.1f x the slowest recent load, at least %.2f s) | %.3f | |\n",
                r.streamer.guard_latency_factor, r.streamer.residency.guard_s, s.guard_s_max);
  md << buf;
  if (r.options.path_ahead_step_s > 0.0)
    std::snprintf(buf, sizeof buf, "| look-ahead | along the flight path (%d points up to the guard and look-ahead, at least %.2f s apart) | |\n",
                  kPathAheadPoints, r.options.path_ahead_step_s);
  else
    std::snprintf(buf, sizeof buf, "| look-ahead | along the velocity | |\n");
  md << buf;
  if (!r.source_note.empty()) md << "| source | " << r.source_note << " | |\n";
  std::snprintf(buf, sizeof buf, "| frame CPU ms p50 / p99 / max | %.4f / %.4f / %.4f | p99 <= 1 |\n", s.frame_ms_p50,
                s.frame_ms_p99, s.frame_ms_max);
  md << buf;
  std::snprintf(buf, sizeof buf, "| p99 ms: streamer update / relight of loads / volume update | %.4f / %.4f / %.4f | |\n",
                s.update_ms_p99, s.relight_ms_p99, s.volume_ms_p99);
  md << buf;
  if (s.volume_worker) {
    std::snprintf(buf, sizeof buf,
                  "| the worker (the frame's adds and volume update): p99 ms; the frame's wait p99 ms, frames that waited; frames late | "
                  "%.4f; %.4f, %d; %d | |\n",
                  s.worker_ms_p99, s.wait_ms_p99, s.frames_waited, s.volume_late_frames);
    md << buf;
  }
  std::snprintf(buf, sizeof buf, "| full relights (time of day) | %d | |\n", s.full_relights);
  md << buf;
  if (r.options.technique_frame) {
    std::snprintf(buf, sizeof buf, "| technique %s: update ms p99, state bytes | %.4f, %zu B | |\n", r.options.technique.c_str(),
                  s.technique_ms_p99, r.options.technique_bytes);
    md << buf;
  }
  if (s.technique_streamed) {
    std::snprintf(buf, sizeof buf,
                  "| technique: sectors in the volume's reach without their fine state (sector-frames) | %lld in %lld frames "
                  "(reach up to %d sectors) | 0 |\n",
                  (long long)s.technique_misses, (long long)s.technique_frames_with_misses, s.technique_reach_max);
    md << buf;
    std::snprintf(buf, sizeof buf, "| technique: sectors holding fine state, max; stale (older time of day), max; its grids' bytes, max | %d; %d; %.1f MiB | |\n",
                  s.technique_held_max, s.technique_stale_max, double(s.technique_bytes_max) / (1024.0 * 1024.0));
    md << buf;
    if (deterministic) {
      std::snprintf(buf, sizeof buf, "| technique: per-sector jobs run inline (a worker's time), total | %.1f ms | off the frame |\n",
                    s.technique_inline_ms_total);
      md << buf;
    }
  }
  if (deterministic) {
    std::snprintf(buf, sizeof buf, "| I/O work per load (read+hash+zstd+decode+tile), inline | %.4f ms | off the frame |\n",
                  s.inline_io_ms_mean_per_load);
    md << buf;
  }
  md << "\nFrame CPU = streamer update + the runtime's relight of loaded sectors + Runtime::update (time-of-day "
        "relight when needed, volume scroll, publish). I/O is not in it.\n\n";
  md << "## Resident bytes per frame\n\nBlue: bytes of resident sectors (Sector::memoryBytes + tile); red dashed: "
        "the byte budget. y in KiB, x in frames.\n\n![resident bytes](resident-bytes.png)\n\n";
  md << "## Frame CPU time per frame\n\nGreen: frame CPU ms; red dashed: the 1 ms goal; orange dashed: p99. x in "
        "frames.\n\n![frame time](frame-time.png)\n\n";
  md << "## Top-down views\n\nGreen shades: resident sectors drawn as their occlusion tiles (brighter = more open "
        "sky); yellow: loading; dark red: evicted; magenta: failed, backing off (distant ambient); grey: not loaded "
        "yet; blue: sea (no sector). White square: the volume's footprint; blue line: the path; red dot: the "
        "camera.\n\n";
  for (const auto& n : snaps) md << "![" << n << "](" << n << ")\n";
  md << "\n## Failures\n\n";
  if (r.failures.empty()) md << "None.\n";
  for (const SectorFailure& f : r.failures) {
    std::snprintf(buf, sizeof buf, "- t = %.3f s, sector %s, attempt %d, retry at %.3f s: %s\n", f.time_s, toString(f.key).c_str(),
                  f.attempt, f.retry_at_s, f.message.c_str());
    md << buf;
  }
  if (!md) return fail(p.string() + ": write failed");
  return {};
}

}  // namespace drtv::fly
