// drtv/runtime/publish.h — double-buffered volumes: readers never see a half-updated volume.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slide 59: the CPU
//      writing volume texels while the GPU reads them flickers; "the common approach here is to
//      double-buffer the volume maps" (the PS3 avoided the memory with job scheduling instead).
//
// Two Volumes. The writer updates the back one and then publishes it with one atomic store; a
// reader takes the front one under a shared lock for as long as it reads (a GPU upload, a batch of
// lookups). The writer takes the back buffer's lock exclusively while writing, so a reader that
// still holds an old front delays the writer (never the reverse tearing). Each buffer catches up
// on its own: it scrolls from its own origin and replays the content changes (full or per sector)
// it missed since its last update, so the back buffer costs a slab per frame, not a refill. A
// sector named by several missed changes (per sector or per box of one) is refilled once, over
// their union; changes that together reach half the volume are refilled as after a relight.
//
// A full refill with blur can be spread over `rebuild_updates` updates (time slicing, as the
// talk's consoles spread their volume jobs): the back buffer fills its unblurred texels once,
// from the cache as it is then, and blurs a share of its layers per update; the front stays
// published until the back is complete. The refill shows the lighting of the update that began
// it, one or more updates late, and is bit for bit a rebuild() of that update's origin and cache.
// If no relight came since it began, the finished buffer then scrolls to the current origin and
// replays the sector changes it missed before it is published; after a relight it is published
// as it is, and its next turn refills it. The first volume ever published, and any refill
// without blur (a fill alone reads the cache: it cannot be split across relights), takes one
// update.
//
// Thread-safety: invalidate*, update: one writer thread. read(): any number of threads, any time.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <shared_mutex>

#include "drtv/runtime/volume.h"

namespace drtv::runtime {

class PublishedVolume {
 public:
  // rebuild_updates >= 1: the most updates a blurred full refill is spread over (1 = each
  // update publishes its own origin and cache).
  explicit PublishedVolume(const VolumeOptions& options = {}, int rebuild_updates = 1);

  // Content changes the buffers must replay (writer thread).
  void invalidateAll();               // relit or rescaled: every texel
  void invalidateSector(SectorKey k); // one sector streamed in, was relit alone, or left
  // Part of sector k's footprint: the texels whose centres lie in [lo, hi] (world metres; z may
  // be infinite), as Volume::refillBox. Its probes changed there only.
  void invalidateBox(SectorKey k, const glm::dvec3& lo, const glm::dvec3& hi);

  // Brings the back buffer to `origin` and the current content of `cache`, then publishes it.
  void update(const glm::ivec3& origin, const ProbeCache& cache);
  // Texels the last update() computed (for benchmarks and tests).
  uint64_t lastUpdateTexels() const { return last_update_texels_; }

  // A consistent, complete volume, held for the reader's lifetime.
  class ReadView {
   public:
    const Volume& volume() const { return *volume_; }
    const Volume* operator->() const { return volume_; }
    uint64_t sequence() const { return sequence_; }  // publish count when this was written

   private:
    friend class PublishedVolume;
    ReadView(const Volume* v, std::shared_mutex* m, uint64_t seq) : volume_(v), lock_(*m), sequence_(seq) {}
    const Volume* volume_;
    std::shared_lock<std::shared_mutex> lock_;
    uint64_t sequence_;
  };
  // Precondition for a meaningful result: update() has run at least once (else an empty volume).
  ReadView read() const;

  const VolumeOptions& options() const { return buffers_[0].volume.options(); }

 private:
  struct Event {
    uint64_t seq;
    bool all;
    SectorKey key;
    glm::dvec3 lo, hi;  // the part of key's footprint (the whole sector for invalidateSector)
  };
  struct Buffer {
    Volume volume;
    mutable std::shared_mutex mutex;
    uint64_t seen = 0;      // events up to this sequence are applied
    uint64_t published = 0; // publish count when written
    bool refilling = false;  // a time-sliced refill is in progress (not built)
  };
  Buffer buffers_[2];
  std::atomic<int> front_{0};
  std::deque<Event> events_;
  uint64_t next_event_ = 1;
  uint64_t publishes_ = 0;
  uint64_t last_update_texels_ = 0;
  int rebuild_updates_ = 1;
};

}  // namespace drtv::runtime
