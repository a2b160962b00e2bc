// drtv/sweep/grid_streamer.h — the sweep's hierarchy for a moving camera (seed 001): one coarse
// grid over the whole world, and fine grids for the sectors near the camera, swept on worker
// threads as they come near, their edges from the coarse grid; re-swept step by step when the time
// of day moves.
//
//  [1] ../shared/seeds/001, "Hierarchy": a coarse grid over the world when it loads, finer grids
//      for the sectors near the camera "built as the streamer brings sectors in, on its I/O
//      threads, their edges initialised from the coarser grid; lookups use the finest grid that
//      holds the point".
//
// Who calls what (the frame's thread unless said otherwise):
//   - setWanted(keys, best first): the sectors that should have a fine grid now, each with its
//     material (material_codec.h bytes, shared and read-only: the workers decode them). Fine grids
//     of sectors no longer wanted are dropped at the next update().
//   - update(time_s, hour): installs what the workers finished, queues what is missing, frees what
//     was dropped (on a worker: a 1 m grid is ~15 MB, and unmapping it is not the frame's work).
//     Never waits for a sweep.
//   - coarse(), fine(key): the grids to read, valid until the next update().
//
// Lighting steps. The time of day is quantised to steps of `resweep_hours` (hour h lights as
// stepHour(h), the nearest step): the coarse grid is re-swept (on a worker, first in the queue)
// when the hour enters a new step, then the fine grids, those missing first, then the stale ones,
// best first. A stale fine grid stays in use until its re-sweep lands, so a lookup never falls back
// to the coarse grid because the hour moved. Each grid is a pure function of its material and its
// step's hour: sweep(material, sky(stepHour), coarse grid of that step) with the options below,
// the same bytes whichever thread swept it and whenever (tests: bit for bit against sweep()).
// Only *when* a grid lands depends on the workers in kThreads mode.
//
// Modes. workers >= 1: that many background threads. workers == 0: deterministic, as the
// streamer's kDeterministic I/O: jobs run inline in update() (their time reported apart, as
// inline_ms: a worker would bear it) and land `simulated_job_s` camera seconds after they started,
// on `simulated_workers` virtual workers each running one job at a time; the same camera path
// and hours give the same grids in the same frames.
//
// Thread-safety: one frame's thread for every member; the grids returned are const and may be
// read by any number of threads until the next update(). The destructor stops the workers after
// their current sweep.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drtv/formats/lighting.h"
#include "drtv/formats/sector.h"
#include "drtv/sweep/sweep.h"

namespace drtv::sweep {

struct GridStreamerOptions {
  SweepOptions sweep;              // bottom_up, smoothing, direct_sun; keep_direct is set per grid
  double sun_disc_rad = 3.0 * 3.14159265358979323846 / 180.0;  // sunLight's disc radius
  // Lighting step, hours of the day, in (0, 24]. 0.1 h (6 minutes of the day): at `drtv fly`'s
  // 0.2 h/s a step every 0.5 s of flight, which one worker re-sweeps 10-20 fine grids within.
  double resweep_hours = 0.1;
  int workers = 1;                 // background threads; 0 = deterministic (see the header)
  double simulated_job_s = 0.05;   // workers == 0: camera seconds from a job's start to its landing
  int simulated_workers = 1;       // workers == 0: jobs running at once
};

// What one update() saw and did.
struct GridStreamerStats {
  int fine_grids = 0;          // installed fine grids after this update
  int stale = 0;               // of them, swept for another step than the coarse grid's
  int queued = 0;              // jobs waiting or running after this update
  int landed = 0;              // jobs installed in this update
  int failed = 0;              // jobs that failed in this update (a material that did not decode)
  double inline_ms = 0.0;      // workers == 0: the jobs and frees run inline in this update
  double coarse_hour = 0.0;    // the installed coarse grid's step hour
  size_t bytes = 0;            // light grids installed (coarse + fine)
  int spares = 0;              // retired grids kept for the next jobs to sweep into, after this update
  bool idle = false;           // nothing queued or running, nothing wanted missing or stale
};

class GridStreamer {
 public:
  using MaterialBytes = std::shared_ptr<const std::vector<uint8_t>>;  // material_codec.h
  struct Wanted {
    SectorKey key;
    MaterialBytes material;  // non-null
  };

  // Sweeps the coarse grid for `hour`'s step at once (on this thread) and starts the workers.
  // Preconditions (bugs): a consistent coarse material, resweep_hours in (0, 24], workers >= 0,
  // simulated_job_s >= 0, simulated_workers >= 1.
  GridStreamer(const Sky& sky, MaterialGrid coarse, const GridStreamerOptions& options, double hour);
  ~GridStreamer();
  GridStreamer(const GridStreamer&) = delete;
  GridStreamer& operator=(const GridStreamer&) = delete;

  void setWanted(std::vector<Wanted> wanted_best_first);
  // `time_s`: camera seconds, non-decreasing (the deterministic mode's clock); `hour`: the time of
  // day, any finite value (modulo 24).
  GridStreamerStats update(double time_s, double hour);

  const SweptGrid& coarse() const { return *coarse_; }
  const SweptGrid* fine(SectorKey key) const;        // nullptr while it has none
  double fineHour(SectorKey key) const;              // its step hour; NaN without one
  // The step hour that lights `hour` (see the header): resweep_hours x round(hour mod 24 / step),
  // 0 for the step that reaches 24.
  double stepHour(double hour) const;
  const std::vector<std::string>& errors() const { return errors_; }  // failed jobs, oldest first

 private:
  struct Job {
    bool coarse = false;
    SectorKey key;
    int64_t step = 0;
    MaterialBytes material;
    std::shared_ptr<const SweptGrid> parent;
  };
  struct Done {
    Job job;
    std::shared_ptr<const SweptGrid> grid;  // null on failure
    std::string error;
    double ready_s = 0.0;
  };
  struct Installed {
    std::shared_ptr<const SweptGrid> grid;
    int64_t step = 0;
  };

  int64_t stepOf(double hour) const;
  Done run(const Job& job);
  // Retired grids nobody else holds become spares (at most one per worker) that the next jobs
  // sweep into (sweepInto: no allocation, no zeroing of a 9-15 MB grid); the rest stay in
  // `retire`, to be freed.
  void keepSpares(std::vector<std::shared_ptr<const SweptGrid>>& retire);
  void workerLoop();

  Sky sky_;
  MaterialGrid coarse_material_;
  GridStreamerOptions options_;
  int64_t steps_per_day_ = 1;

  // Frame's thread only.
  std::shared_ptr<const SweptGrid> coarse_;
  int64_t coarse_step_ = 0, target_step_ = 0;
  std::map<SectorKey, Installed> fine_;
  std::vector<Wanted> wanted_;
  std::map<SectorKey, int64_t> fine_in_flight_;  // queued or running, by step
  bool coarse_in_flight_ = false;
  std::vector<Done> delayed_;                    // workers == 0: done, waiting for ready_s
  std::vector<double> busy_until_s_;             // workers == 0: per virtual worker
  std::vector<std::string> errors_;

  // Shared with the workers, under mutex_.
  std::mutex mutex_;
  std::condition_variable work_;
  std::vector<Job> queue_;                                  // best first
  std::vector<Done> done_;
  std::vector<std::shared_ptr<const SweptGrid>> retired_;   // freed by a worker
  // Grids made non-const (every grid here is: run() makes them so), held by nobody else.
  std::vector<std::shared_ptr<SweptGrid>> spares_;
  bool stop_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace drtv::sweep
