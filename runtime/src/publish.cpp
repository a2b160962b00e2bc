// publish.cpp — see publish.h for the reference [1] and the protocol.
#include "drtv/runtime/publish.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <vector>

namespace drtv::runtime {

PublishedVolume::PublishedVolume(const VolumeOptions& options, int rebuild_updates) : rebuild_updates_(rebuild_updates) {
  DRTV_CHECK_LE(1, rebuild_updates);
  buffers_[0].volume = Volume(options);
  buffers_[1].volume = Volume(options);
}

void PublishedVolume::invalidateAll() {
  events_.clear();  // a full refill supersedes every earlier event
  events_.push_back({next_event_++, true, {}, glm::dvec3(0.0), glm::dvec3(0.0)});
}

void PublishedVolume::invalidateSector(SectorKey k) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const glm::dvec3 lo(k.ix * kSectorSizeM, k.iy * kSectorSizeM, -kInf);
  events_.push_back({next_event_++, false, k, lo, glm::dvec3(lo.x + kSectorSizeM, lo.y + kSectorSizeM, kInf)});
}

void PublishedVolume::invalidateBox(SectorKey k, const glm::dvec3& lo, const glm::dvec3& hi) {
  events_.push_back({next_event_++, false, k, lo, hi});
}

namespace {
// What an update of a time-sliced refill blurs, in layers of `n_z`: the updates share the fill
// and the blur equally, the first doing the fill and the rest of its share in blurred layers. A
// fill costs about as much as blurring 0.38 of the layers (BM_FullRefillNearest 200 us beside
// the blur's 530 us of BM_FullRefillNearestBlurred, 2026-12-02).
constexpr double kFillInBlurredVolumes = 0.38;
int blurLayersPerUpdate(int n_z, int updates) { return int(std::ceil(n_z * (1.0 + kFillInBlurredVolumes) / updates)); }
int blurLayersOfFirstUpdate(int n_z, int updates) {
  return std::max(0, blurLayersPerUpdate(n_z, updates) - int(std::lround(n_z * kFillInBlurredVolumes)));
}
}  // namespace

void PublishedVolume::update(const glm::ivec3& origin, const ProbeCache& cache) {
  const int back = 1 - front_.load(std::memory_order_relaxed);
  Buffer& b = buffers_[back];
  bool publish = true;
  {
    std::unique_lock lock(b.mutex);
    const uint64_t before = b.volume.texelsFilled();
    bool relit = false;  // a full refill asked for since this buffer last caught up
    for (const Event& e : events_)
      if (e.seq > b.seen && e.all) relit = true;
    // A refill reads the cache as it is now, so a sector named by several missed events (lights
    // moving frame after frame) is refilled once, over the union of their boxes.
    struct Box {
      SectorKey key;
      glm::dvec3 lo, hi;
    };
    std::vector<Box> boxes;
    for (const Event& e : events_) {
      if (e.seq <= b.seen || e.all) continue;
      auto it = std::find_if(boxes.begin(), boxes.end(), [&](const Box& x) { return x.key == e.key; });
      if (it == boxes.end()) {
        boxes.push_back({e.key, e.lo, e.hi});
      } else {
        it->lo = glm::min(it->lo, e.lo);
        it->hi = glm::max(it->hi, e.hi);
      }
    }
    // Boxes that together reach half the volume cost more than a full refill (they overlap and
    // each has its own set-up): they are then refilled as after a relight, time-sliced with blur.
    auto boxesReachHalf = [&] {
      uint64_t texels = 0;
      for (const Box& x : boxes) texels += b.volume.refillTexels(x.lo, x.hi);
      const glm::ivec3 n = b.volume.period();
      return 2 * texels >= uint64_t(n.x) * uint64_t(n.y) * uint64_t(n.z);
    };
    auto catchUp = [&] {
      b.volume.scrollTo(origin, cache);
      for (const Box& x : boxes) b.volume.refillBox(x.lo, x.hi, cache);
      b.seen = next_event_ - 1;
    };
    const int n_z = b.volume.period().z;
    if (b.refilling) {
      b.volume.advanceRebuild(blurLayersPerUpdate(n_z, rebuild_updates_));
      b.refilling = !b.volume.built();
      publish = !b.refilling;
      // Else (or with boxes that call for a refill) published as it is; its next turn refills it.
      if (publish && !relit && !boxesReachHalf()) catchUp();
    } else if (!b.volume.built() || relit || boxesReachHalf()) {
      const bool sliced = rebuild_updates_ > 1 && b.volume.options().blur && publishes_ > 0;
      b.volume.beginRebuild(origin, cache, sliced ? blurLayersOfFirstUpdate(n_z, rebuild_updates_) : n_z);
      b.seen = next_event_ - 1;
      b.refilling = !b.volume.built();
      publish = !b.refilling;
    } else {
      catchUp();
    }
    if (publish) b.published = ++publishes_;
    last_update_texels_ = b.volume.texelsFilled() - before;
  }
  if (publish) front_.store(back, std::memory_order_release);
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
