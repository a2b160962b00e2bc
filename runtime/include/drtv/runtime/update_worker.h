// drtv/runtime/update_worker.h — Runtime::update() on a thread of its own, off the frame's
// critical path, its volume published a frame late.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slide 59: the volume
//      update runs as jobs beside the frame (the G-buffer pass), its result double-buffered.
//
// A frame with a worker (what `drtv fly` does, tools/fly):
//
//   worker.wait();               // the update handed over last frame is done (usually already)
//   streamer.update(cam, t, sink);   // the sink: worker.addSector(sector, &tile) for a load (queued),
//                                    // worker.cancelAdd(key) and rt.removeSector(key) for an eviction
//   rt.setLights(...); rt.setTime(hour);
//   worker.start(cam.position_m);    // the queued adds, then the update (relight if needed, scroll,
//                                    // fill, blur, publish): on the worker
//   ... the frame's own work; its shading reads rt.volume().read()
//
// A queued sector is added by the worker before its update, in the order queued, exactly as
// Runtime::addSector would have been called inline at that point; its relight and the slabs it
// fills leave the frame's thread too. The sector (and tile) must stay valid until the wait()
// after the start() that handed it over returns, and, with SectorBlock::kBorrow, until it is
// removed: a streamer's sink has both (streamer.h).
// The volume a frame reads from its start until the worker publishes is the one the previous
// frame's update published: one frame late. PublishedVolume double-buffers (publish.h), so every
// read sees one complete volume. The worker's thread is started by the constructor and sleeps on
// an atomic between updates (a futex, no spinning): handing an update over wakes it, nothing is
// created per frame. It runs at a lower priority than the thread that made it (nice + 5 on Linux):
// waking a thread of equal priority let the kernel run it on the waker's core at once and leave
// the frame's thread waiting for the other core, 0.7-3.6 ms in 1 % of the town's frames (`drtv
// fly` above the town, docs/runtime.md). The sequence of runtime calls, and so every colour and texel, is the same as
// the same calls made inline (tests/runtime/update_worker_test.cpp).
//
// Thread-safety: start() and wait() from one thread, the one that owns the runtime. Between
// start() and the wait() that follows, that thread (and every other) may call nothing on the
// runtime but volume().read(): the update writes the probe cache, the lighting and the volume's
// back buffer. A start() while an update is in flight is a bug (checked).
#pragma once

#include <atomic>
#include <cstdint>
#include <exception>
#include <thread>

#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"
#include "drtv/formats/sector.h"
#include "drtv/runtime/occlusion.h"
#include "drtv/runtime/probe_cache.h"

namespace drtv::runtime {

class Runtime;

class UpdateWorker {
 public:
  // Starts the worker's thread for `runtime`, which must outlive this object. `nice_increment`:
  // how much lower than its creator's the worker's priority is (Linux nice steps; 0: the same).
  explicit UpdateWorker(Runtime& runtime, int nice_increment = kDefaultNiceIncrement);
  static constexpr int kDefaultNiceIncrement = 5;
  // Waits for an update in flight, then stops the thread.
  ~UpdateWorker();
  UpdateWorker(const UpdateWorker&) = delete;
  UpdateWorker& operator=(const UpdateWorker&) = delete;

  // Queues runtime.addSector(sector, tile, block) for the next start(). Owner's thread, with no
  // update in flight (checked).
  void addSector(const Sector& sector, const OcclusionTile* tile = nullptr, SectorBlock block = SectorBlock::kCopy);
  // Drops the queued add of `key` (a sector evicted before it was handed over); true if one was.
  bool cancelAdd(SectorKey key);
  // Hands the queued adds and runtime.update(camera) to the worker and returns at once.
  void start(const glm::dvec3& camera);
  // Returns once the update handed over last is done (at once when none is in flight). If that
  // update threw (an allocation failed), the exception is rethrown here.
  void wait();
  // An update was handed over and has not finished yet (the owner's thread).
  bool busy() const { return done_.load(std::memory_order_acquire) != requested_.load(std::memory_order_relaxed); }
  // Wall-clock milliseconds the worker spent in the last update it finished, its adds included,
  // and in those adds alone.
  double lastUpdateMs() const { return last_update_ms_.load(std::memory_order_acquire); }
  double lastAddsMs() const { return last_adds_ms_.load(std::memory_order_acquire); }
  // The sectors the runtime refused in the adds done since the last call, each with
  // Runtime::addSector's error (after wait()).
  std::vector<std::pair<SectorKey, Error>> takeAddErrors();
  // Updates the worker finished since it started.
  uint64_t updates() const { return done_.load(std::memory_order_acquire); }

 private:
  void run();

  Runtime& runtime_;
  int nice_increment_;
  struct PendingAdd {
    const Sector* sector;
    const OcclusionTile* tile;
    SectorBlock block;
  };
  glm::dvec3 camera_{0.0};              // written by start() before requested_ is released
  std::vector<PendingAdd> queued_;      // the owner's, until start() hands them over
  std::vector<PendingAdd> handed_;      // the worker's, from start() to done_
  std::vector<std::pair<SectorKey, Error>> add_errors_;  // the worker's until done_
  std::atomic<uint32_t> requested_{0};  // updates handed over (32-bit: a futex word)
  std::atomic<uint32_t> done_{0};       // updates finished (wraps; compared for equality only)
  std::atomic<bool> stop_{false};
  std::atomic<double> last_update_ms_{0.0}, last_adds_ms_{0.0};
  std::exception_ptr error_;            // written by the worker before done_ is released
  std::thread thread_;
};

}  // namespace drtv::runtime
