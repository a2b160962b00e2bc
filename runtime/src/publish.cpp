// publish.cpp — see publish.h for the reference [1] and the protocol.
#include "drtv/runtime/publish.h"

#include <algorithm>
#include <mutex>

namespace drtv::runtime {

PublishedVolume::PublishedVolume(const VolumeOptions& options) {
  buffers_[0].volume = Volume(options);
  buffers_[1].volume = Volume(options);
}

void PublishedVolume::invalidateAll() {
  events_.clear();  // a full refill supersedes every earlier event
  events_.push_back({next_event_++, true, {}});
}

void PublishedVolume::invalidateSector(SectorKey k) { events_.push_back({next_event_++, false, k}); }

void PublishedVolume::update(const glm::ivec3& origin, const ProbeCache& cache) {
  const int back = 1 - front_.load(std::memory_order_relaxed);
  Buffer& b = buffers_[back];
  {
    std::unique_lock lock(b.mutex);
    const uint64_t before = b.volume.texelsFilled();
    bool full = !b.volume.built();
    for (const Event& e : events_)
      if (e.seq > b.seen && e.all) full = true;
    if (full) {
      b.volume.rebuild(origin, cache);
    } else {
      b.volume.scrollTo(origin, cache);
      for (const Event& e : events_)
        if (e.seq > b.seen) b.volume.refillSector(e.key, cache);
    }
    b.seen = next_event_ - 1;
    b.published = ++publishes_;
    last_update_texels_ = b.volume.texelsFilled() - before;
  }
  front_.store(back, std::memory_order_release);
  // Events both buffers have applied are dropped.
  const uint64_t both = std::min(buffers_[0].seen, buffers_[1].seen);
  while (!events_.empty() && events_.front().seq <= both) events_.pop_front();
}

PublishedVolume::ReadView PublishedVolume::read() const {
  const int f = front_.load(std::memory_order_acquire);
  const Buffer& b = buffers_[f];
  ReadView v(&b.volume, &b.mutex, 0);
  v.sequence_ = b.published;
  return v;
}

}  // namespace drtv::runtime
