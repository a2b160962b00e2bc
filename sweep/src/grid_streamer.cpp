// The sweep's streamed hierarchy (grid_streamer.h).
#include "drtv/sweep/grid_streamer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "drtv/sweep/material_codec.h"

namespace drtv::sweep {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

}  // namespace

GridStreamer::GridStreamer(const Sky& sky, MaterialGrid coarse, const GridStreamerOptions& options, double hour)
    : sky_(sky), coarse_material_(std::move(coarse)), options_(options) {
  DRTV_CHECK(options_.resweep_hours > 0.0 && options_.resweep_hours <= 24.0);
  DRTV_CHECK(options_.workers >= 0 && options_.simulated_workers >= 1 && options_.simulated_job_s >= 0.0);
  DRTV_CHECK(std::isfinite(hour));
  target_step_ = coarse_step_ = stepOf(hour);
  Job first;
  first.coarse = true;
  first.step = coarse_step_;
  coarse_ = run(first).grid;
  busy_until_s_.assign(size_t(options_.simulated_workers), -std::numeric_limits<double>::infinity());
  for (int i = 0; i < options_.workers; ++i) threads_.emplace_back([this] { workerLoop(); });
}

GridStreamer::~GridStreamer() {
  {
    std::lock_guard lk(mutex_);
    stop_ = true;
  }
  work_.notify_all();
  for (std::thread& t : threads_) t.join();
}

int64_t GridStreamer::stepOf(double hour) const {
  double h = std::fmod(hour, 24.0);
  if (h < 0) h += 24.0;
  const int64_t s = std::llround(h / options_.resweep_hours);
  // The step that reaches 24 h is midnight's, step 0.
  return double(s) * options_.resweep_hours >= 24.0 - 1e-9 ? 0 : s;
}

double GridStreamer::stepHour(double hour) const { return double(stepOf(hour)) * options_.resweep_hours; }

const SweptGrid* GridStreamer::fine(SectorKey key) const {
  const auto it = fine_.find(key);
  return it == fine_.end() ? nullptr : it->second.grid.get();
}

double GridStreamer::fineHour(SectorKey key) const {
  const auto it = fine_.find(key);
  return it == fine_.end() ? std::numeric_limits<double>::quiet_NaN() : double(it->second.step) * options_.resweep_hours;
}

void GridStreamer::setWanted(std::vector<Wanted> wanted) {
  for (const Wanted& w : wanted) DRTV_CHECK(w.material != nullptr);
  wanted_ = std::move(wanted);
}

GridStreamer::Done GridStreamer::run(const Job& job) {
  Done d;
  d.job = job;
  const double hour = double(job.step) * options_.resweep_hours;
  SweepOptions o = options_.sweep;
  if (job.coarse) {
    // As the technique's prepare-time sweep: the coarse grid keeps the sun's unscattered part for
    // the fine grids' edges.
    const SkyInput sky{skyLight(sky_, hour), sunLight(sky_, hour, options_.sun_disc_rad)};
    o.keep_direct = true;
    d.grid = std::make_shared<SweptGrid>(sweep(coarse_material_, sky, nullptr, o));
    return d;
  }
  auto m = decodeMaterial(*job.material);
  if (!m) {
    d.error = "sweep: sector " + toString(job.key) + ": " + m.error().message;
    return d;
  }
  o.keep_direct = false;
  std::shared_ptr<SweptGrid> into;
  {
    std::lock_guard lk(mutex_);
    if (!spares_.empty()) {
      into = std::move(spares_.back());
      spares_.pop_back();
    }
  }
  if (!into) into = std::make_shared<SweptGrid>();
  sweepInto(*m, job.parent->sky, job.parent.get(), o, *into);  // bit for bit sweep()'s
  d.grid = std::move(into);
  return d;
}

void GridStreamer::keepSpares(std::vector<std::shared_ptr<const SweptGrid>>& retire) {
  const size_t most = size_t(std::max(1, threads_.empty() ? options_.simulated_workers : int(threads_.size())));
  std::lock_guard lk(mutex_);
  for (auto& r : retire)
    if (r && r.use_count() == 1 && spares_.size() < most) spares_.push_back(std::const_pointer_cast<SweptGrid>(std::move(r)));
}

void GridStreamer::workerLoop() {
  for (;;) {
    std::unique_lock lk(mutex_);
    work_.wait(lk, [&] { return stop_ || !queue_.empty() || !retired_.empty(); });
    if (stop_) return;
    if (!retired_.empty()) {
      std::vector<std::shared_ptr<const SweptGrid>> dead;
      dead.swap(retired_);
      lk.unlock();
      dead.clear();  // frees the grids here, not on the frame's thread
      continue;
    }
    Job job = std::move(queue_.front());
    queue_.erase(queue_.begin());
    lk.unlock();
    Done d = run(job);
    lk.lock();
    done_.push_back(std::move(d));
  }
}

GridStreamerStats GridStreamer::update(double time_s, double hour) {
  DRTV_CHECK(std::isfinite(hour));
  GridStreamerStats st;
  const bool inline_mode = threads_.empty();
  std::vector<std::shared_ptr<const SweptGrid>> retire;
  target_step_ = stepOf(hour);

  // 1. Land what the workers finished, in the order they finished (inline: the order started).
  std::vector<Done> landed;
  if (inline_mode) {
    auto ready = std::stable_partition(delayed_.begin(), delayed_.end(), [&](const Done& d) { return d.ready_s <= time_s; });
    landed.assign(std::make_move_iterator(delayed_.begin()), std::make_move_iterator(ready));
    delayed_.erase(delayed_.begin(), ready);
  } else {
    std::lock_guard lk(mutex_);
    landed.swap(done_);
  }
  std::vector<SectorKey> wanted_keys;
  wanted_keys.reserve(wanted_.size());
  for (const Wanted& w : wanted_) wanted_keys.push_back(w.key);
  std::sort(wanted_keys.begin(), wanted_keys.end());
  auto isWanted = [&](SectorKey k) { return std::binary_search(wanted_keys.begin(), wanted_keys.end(), k); };
  for (Done& d : landed) {
    if (d.job.coarse) {
      coarse_in_flight_ = false;
      retire.push_back(std::move(coarse_));
      coarse_ = std::move(d.grid);
      coarse_step_ = d.job.step;
      ++st.landed;
      continue;
    }
    fine_in_flight_.erase(d.job.key);
    if (!d.grid) {
      ++st.failed;
      errors_.push_back(std::move(d.error));
      continue;
    }
    if (!isWanted(d.job.key)) {
      retire.push_back(std::move(d.grid));
      continue;
    }
    Installed& slot = fine_[d.job.key];
    retire.push_back(std::move(slot.grid));
    slot = {std::move(d.grid), d.job.step};
    ++st.landed;
  }

  // 2. Drop the fine grids of sectors that left.
  for (auto it = fine_.begin(); it != fine_.end();) {
    if (isWanted(it->first)) {
      ++it;
    } else {
      retire.push_back(std::move(it->second.grid));
      it = fine_.erase(it);
    }
  }

  // 3. Take back the jobs no worker has started, and decide again: the coarse grid of a new step
  //    first, then the wanted sectors without a fine grid, then the stale ones, best first.
  std::vector<Job> jobs;
  if (!inline_mode) {
    std::lock_guard lk(mutex_);
    for (const Job& j : queue_) {
      if (j.coarse) coarse_in_flight_ = false;
      else fine_in_flight_.erase(j.key);
    }
    queue_.clear();
  }
  if (coarse_step_ != target_step_ && !coarse_in_flight_) {
    Job j;
    j.coarse = true;
    j.step = target_step_;
    jobs.push_back(std::move(j));
  }
  std::vector<Job> stale;
  for (const Wanted& w : wanted_) {
    if (fine_in_flight_.count(w.key)) continue;
    const auto it = fine_.find(w.key);
    Job j{false, w.key, coarse_step_, w.material, coarse_};
    if (it == fine_.end()) jobs.push_back(std::move(j));
    // A stale grid waits for its step's coarse grid: swept against the old one it would be stale
    // again at once.
    else if (it->second.step != coarse_step_ && coarse_step_ == target_step_) stale.push_back(std::move(j));
  }
  for (Job& j : stale) jobs.push_back(std::move(j));

  keepSpares(retire);

  // 4. Hand them out.
  auto markInFlight = [&](const Job& j) {
    if (j.coarse) coarse_in_flight_ = true;
    else fine_in_flight_[j.key] = j.step;
  };
  if (inline_mode) {
    const auto t0 = Clock::now();
    size_t next = 0;
    for (double& busy : busy_until_s_) {
      if (next == jobs.size()) break;
      if (busy > time_s) continue;
      const Job& j = jobs[next++];
      markInFlight(j);
      Done d = run(j);
      d.ready_s = time_s + options_.simulated_job_s;
      busy = d.ready_s;
      delayed_.push_back(std::move(d));
    }
    retire.clear();
    st.inline_ms = msSince(t0);
    st.queued = int(delayed_.size());
  } else {
    for (const Job& j : jobs) markInFlight(j);
    {
      std::lock_guard lk(mutex_);
      queue_ = std::move(jobs);
      for (auto& r : retire)
        if (r) retired_.push_back(std::move(r));
    }
    work_.notify_all();
    st.queued = int(fine_in_flight_.size()) + (coarse_in_flight_ ? 1 : 0);
  }

  {
    std::lock_guard lk(mutex_);
    st.spares = int(spares_.size());
  }
  st.fine_grids = int(fine_.size());
  st.bytes = coarse_->bytes();
  for (const auto& [k, f] : fine_) {
    st.bytes += f.grid->bytes();
    st.stale += f.step != coarse_step_;
  }
  st.coarse_hour = double(coarse_step_) * options_.resweep_hours;
  st.idle = st.queued == 0 && st.stale == 0 && coarse_step_ == target_step_ && fine_.size() == wanted_.size();
  return st;
}

}  // namespace drtv::sweep
