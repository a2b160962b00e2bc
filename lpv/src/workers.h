// The LPV's worker threads (CascadedLpv::Workers, lpv.h's `threads`). Private to drtv::lpv.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "drtv/lpv/lpv.h"

namespace drtv::lpv {

// Threads beside the caller, started once and asleep between calls: a propagation has 3 jobs of
// ~0.3 ms, and starting a thread per call cost about as much as it saved (DESIGN.md: waking an idle
// worker costs 75-100 us, starting one more).
class CascadedLpv::Workers {
 public:
  explicit Workers(int count) {
    for (int w = 1; w <= count; ++w) threads_.emplace_back([this, w] { loop(w); });
  }
  ~Workers() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
  }
  int count() const { return int(threads_.size()); }
  // Runs job(index, worker) for every index in [0, jobs), each once, on the caller (worker 0) and
  // the workers (1..count()); returns when all have finished. Which thread runs which index is
  // not fixed: jobs must not depend on it beyond choosing the worker's scratch.
  void run(int jobs, const std::function<void(int, int)>& job) {
    {
      std::lock_guard lock(mutex_);
      job_ = &job;
      jobs_ = jobs;
      next_.store(0);
      busy_ = count();
      ++generation_;
    }
    wake_.notify_all();
    work(0);
    std::unique_lock lock(mutex_);
    done_.wait(lock, [&] { return busy_ == 0; });
    job_ = nullptr;
  }

 private:
  void work(int worker) {
    for (int i = next_.fetch_add(1); i < jobs_; i = next_.fetch_add(1)) (*job_)(i, worker);
  }
  void loop(int worker) {
    uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
      }
      work(worker);
      {
        std::lock_guard lock(mutex_);
        --busy_;
      }
      done_.notify_one();
    }
  }
  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(int, int)>* job_ = nullptr;
  int jobs_ = 0;
  std::atomic<int> next_{0};
  int busy_ = 0;
  uint64_t generation_ = 0;
  bool stop_ = false;
};

}  // namespace drtv::lpv
