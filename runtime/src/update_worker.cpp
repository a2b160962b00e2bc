// runtime::UpdateWorker (update_worker.h).
#include "drtv/runtime/update_worker.h"

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

#include <algorithm>
#include <cerrno>
#include <chrono>

#include "drtv/formats/error.h"
#include "drtv/runtime/runtime.h"

namespace drtv::runtime {

UpdateWorker::UpdateWorker(Runtime& runtime, int nice_increment)
    : runtime_(runtime), nice_increment_(nice_increment), thread_([this] { run(); }) {}

UpdateWorker::~UpdateWorker() {
  // The owner may be unwinding from an exception of its own: an update's error is dropped here.
  while (busy()) done_.wait(done_.load(std::memory_order_acquire), std::memory_order_acquire);
  stop_.store(true, std::memory_order_release);
  requested_.fetch_add(1, std::memory_order_release);
  requested_.notify_one();
  thread_.join();
}

void UpdateWorker::addSector(const Sector& sector, const OcclusionTile* tile, SectorBlock block) {
  DRTV_CHECK(!busy());
  queued_.push_back({&sector, tile, block});
}

bool UpdateWorker::cancelAdd(SectorKey key) {
  DRTV_CHECK(!busy());
  const auto it = std::find_if(queued_.begin(), queued_.end(), [&](const PendingAdd& a) { return a.sector->key == key; });
  if (it == queued_.end()) return false;
  queued_.erase(it);
  return true;
}

std::vector<std::pair<SectorKey, Error>> UpdateWorker::takeAddErrors() {
  DRTV_CHECK(!busy());
  return std::exchange(add_errors_, {});
}

void UpdateWorker::start(const glm::dvec3& camera) {
  DRTV_CHECK(!busy());
  camera_ = camera;
  handed_.swap(queued_);
  queued_.clear();
  requested_.fetch_add(1, std::memory_order_release);
  requested_.notify_one();
}

void UpdateWorker::wait() {
  const uint32_t want = requested_.load(std::memory_order_relaxed);
  for (uint32_t d = done_.load(std::memory_order_acquire); d != want; d = done_.load(std::memory_order_acquire))
    done_.wait(d, std::memory_order_acquire);
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void UpdateWorker::run() {
#ifdef __linux__
  // Raising a thread's own nice value needs no privilege; if it fails the worker runs as before.
  if (nice_increment_ > 0) {
    const pid_t tid = pid_t(syscall(SYS_gettid));
    errno = 0;
    const int now = getpriority(PRIO_PROCESS, id_t(tid));
    if (errno == 0) (void)setpriority(PRIO_PROCESS, id_t(tid), std::min(19, now + nice_increment_));
  }
#endif
  uint32_t finished = 0;
  for (;;) {
    requested_.wait(finished, std::memory_order_acquire);  // sleeps while nothing new is handed over
    if (stop_.load(std::memory_order_acquire)) return;
    using Clock = std::chrono::steady_clock;
    const auto ms = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
    const auto t0 = Clock::now();
    auto t1 = t0;
    try {
      for (const PendingAdd& a : handed_)
        if (auto ok = runtime_.addSector(*a.sector, a.tile, a.block); !ok) add_errors_.emplace_back(a.sector->key, ok.error());
      handed_.clear();
      t1 = Clock::now();
      runtime_.update(camera_);
    } catch (...) {
      error_ = std::current_exception();
    }
    const auto t2 = Clock::now();
    last_adds_ms_.store(ms(t0, t1), std::memory_order_relaxed);
    last_update_ms_.store(ms(t0, t2), std::memory_order_relaxed);
    done_.store(++finished, std::memory_order_release);
    done_.notify_one();
  }
}

}  // namespace drtv::runtime
