// The streaming service (streamer.h): residency slots, I/O threads, hand-off, back-off.
#include "drtv/streamer/streamer.h"

#include <algorithm>
#include <functional>
#include <chrono>


namespace drtv::streamer {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

}  // namespace

const char* sectorStateName(SectorState s) {
  switch (s) {
    case SectorState::kAbsent: return "absent";
    case SectorState::kQueued: return "queued";
    case SectorState::kLoading: return "loading";
    case SectorState::kResident: return "resident";
    case SectorState::kBackingOff: return "backing-off";
  }
  return "?";
}

size_t predictedSectorBytes(const SectorEntry& e) {
  return sizeof(Sector) + size_t(e.probes) * sizeof(ProbeRecord) + size_t(e.lprt_sources) * sizeof(LprtSource) +
         size_t(e.probes) * e.lprt_sources * 12 * sizeof(int16_t) + size_t(e.covered) * kVisBytesPerProbe;
}

size_t budgetBytesFor(const Manifest& manifest) {
  bool lprt = false;
  size_t sun_samples = 0;
  std::vector<size_t> covered;
  for (const SectorEntry& e : manifest.sectors) {
    lprt |= e.lprt_sources > 0;
    // The archive reader checked that every entry's size fits its counts.
    sun_samples = std::max(sun_samples, sunSamplesOfEncodedSize(e.raw_bytes, e.probes, e.lprt_sources, e.covered).value_or(0));
    if (e.covered > 0) covered.push_back(e.covered);
  }
  // The visibility maps of the 51 sectors that hold the most (sector.h): a town's resident block.
  const size_t most = std::min(covered.size(), size_t(kMaxResidentSectors));
  std::partial_sort(covered.begin(), covered.begin() + ptrdiff_t(most), covered.end(), std::greater<>());
  size_t maps = 0;
  for (size_t i = 0; i < most; ++i) maps += covered[i] * kVisBytesPerProbe;
  return (lprt ? kBudgetBytesWithLprt : kBudgetBytesWithoutLprt) + size_t(kMaxResidentSectors) * sunTransferAllowanceBytes(sun_samples) +
         maps;
}

Result<std::unique_ptr<Streamer>> Streamer::open(const std::filesystem::path& archive, StreamerOptions options) {
  auto reader = ArchiveReader::open(archive);
  if (!reader) return std::unexpected(reader.error());
  auto source = FileSectorSource::open(archive);
  if (!source) return std::unexpected(source.error());
  return std::make_unique<Streamer>(reader->manifest(), std::shared_ptr<SectorSource>(std::move(*source)), std::move(options));
}

Streamer::Streamer(Manifest manifest, std::shared_ptr<SectorSource> source, StreamerOptions options)
    : manifest_(std::move(manifest)), source_(std::move(source)), options_(std::move(options)) {
  DRTV_CHECK(source_ != nullptr);
  DRTV_CHECK_LE(1, options_.residency.max_sectors);
  DRTV_CHECK_LE(1, options_.max_in_flight);
  DRTV_CHECK(options_.guard_latency_factor >= 0.0 && options_.guard_latency_factor <= 1e6);  // NaN fails too
  if (!options_.occlusion_tile) options_.occlusion_tile = runtime::makeOcclusionTile;
  max_bytes_ = options_.max_bytes ? options_.max_bytes : budgetBytesFor(manifest_);
  slots_.resize(size_t(options_.residency.max_sectors));
  const size_t n = slots_.size();
  backoff_.reserve(n);
  ranked_.reserve(256);
  held_.reserve(n);
  footprint_.reserve(64);
  drained_.reserve(n);
  last_latencies_.reserve(n);
  if (options_.io_mode == IoMode::kThreads) {
    DRTV_CHECK_LE(1, options_.io_threads);
    queue_.reserve(n);
    done_.reserve(n);
    for (int i = 0; i < options_.io_threads; ++i) threads_.emplace_back([this] { ioThread(); });
  }
}

Streamer::~Streamer() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  work_.notify_all();
  for (auto& t : threads_) t.join();
}

// ---- I/O side --------------------------------------------------------------------------------

Streamer::Done Streamer::load(const Job& job) const {
  Done d;
  d.ticket = job.ticket;
  d.key = job.entry.key;
  const SectorEntry& e = job.entry;
  const std::string where = source_->name() + ": sector " + toString(e.key);
  auto bytes = source_->read(e);
  if (!bytes) {
    d.error = bytes.error().message;
    return d;
  }
  auto sector = decodeSectorPayload(e, *bytes, where);
  if (!sector) {
    d.error = sector.error().message;
    return d;
  }
  d.sector = std::make_unique<Sector>(std::move(*sector));
  d.tile = options_.occlusion_tile(*d.sector);
  d.tile.key = e.key;
  return d;
}

void Streamer::ioThread() {
  std::unique_lock lock(mutex_);
  for (;;) {
    work_.wait(lock, [&] { return stop_ || !queue_.empty(); });
    if (stop_) return;
    auto best = std::min_element(queue_.begin(), queue_.end(), [](const Job& a, const Job& b) {
      return a.score != b.score ? a.score < b.score : a.ticket < b.ticket;
    });
    const Job job = *best;
    queue_.erase(best);
    ++running_;
    lock.unlock();
    Done d = load(job);
    lock.lock();
    --running_;
    done_.push_back(std::move(d));
  }
}

// ---- frame side ------------------------------------------------------------------------------

Streamer::Slot* Streamer::findSlot(SectorKey key) {
  for (Slot& s : slots_)
    if (s.state != SlotState::kFree && s.state != SlotState::kCancelling && s.key == key) return &s;
  return nullptr;
}
const Streamer::Slot* Streamer::findSlot(SectorKey key) const { return const_cast<Streamer*>(this)->findSlot(key); }

const Streamer::Backoff* Streamer::findBackoff(SectorKey key) const {
  for (const Backoff& b : backoff_)
    if (b.key == key) return &b;
  return nullptr;
}

void Streamer::handleDone(Done& d, double time_s, SectorSink& sink, FrameStats& st, double& sink_ms) {
  Slot* slot = nullptr;
  for (Slot& s : slots_)
    if (s.state != SlotState::kFree && s.ticket == d.ticket) slot = &s;
  DRTV_CHECK(slot != nullptr);  // every ticket keeps its slot until its Done is handled
  if (slot->state == SlotState::kCancelling) {
    *slot = Slot{};
    ++st.cancels;
    return;
  }
  DRTV_CHECK(slot->state == SlotState::kLoading || slot->state == SlotState::kQueued);
  if (!d.sector) {
    *slot = Slot{};
    ++st.failures;
    auto it = std::find_if(backoff_.begin(), backoff_.end(), [&](const Backoff& b) { return b.key == d.key; });
    if (it == backoff_.end()) {
      backoff_.push_back({d.key, 0, 0.0});
      it = backoff_.end() - 1;
    }
    ++it->attempts;
    const double wait = std::min(options_.retry_max_s, options_.retry_initial_s * double(1ull << std::min(it->attempts - 1, 30)));
    it->retry_at_s = time_s + wait;
    if (options_.failure_log > 0) {
      if (failures_.size() >= options_.failure_log) failures_.pop_front();
      failures_.push_back({d.key, it->attempts, time_s, it->retry_at_s, d.error});
    }
    const auto t0 = Clock::now();
    sink.onSectorFailed(d.key, Error{d.error});
    sink_ms += msSince(t0);
    return;
  }
  std::erase_if(backoff_, [&](const Backoff& b) { return b.key == d.key; });
  slot->state = SlotState::kResident;
  slot->sector = std::move(d.sector);
  slot->tile = d.tile;
  slot->bytes = slot->sector->memoryBytes() + sizeof(OcclusionTile);
  // Camera seconds from the request to the frame that hands the sector over: how far ahead of
  // the camera the residency must ask (the guard below).
  const double latency_s = std::max(0.0, time_s - slot->issued_s);
  latencies_[latency_next_++ % latencies_.size()] = latency_s;
  last_latencies_.push_back(latency_s);
  st.latency_max_s = std::max(st.latency_max_s, latency_s);
  ++st.loads;
  ++total_loads_;
  const auto t0 = Clock::now();
  sink.onSectorLoaded(*slot->sector, slot->tile);
  sink_ms += msSince(t0);
}

void Streamer::issue(Slot& slot, const RankedSector& r, double time_s, FrameStats& st) {
  slot.state = SlotState::kQueued;
  slot.key = r.key;
  slot.ticket = next_ticket_++;
  slot.issued_s = time_s;
  slot.bytes = predictedSectorBytes(*r.entry) + sizeof(OcclusionTile);
  ++st.started;
  Job job{slot.ticket, *r.entry, r.score_m + (r.tier == 0 ? -1e9 : 0.0)};
  if (options_.io_mode == IoMode::kDeterministic) {
    slot.state = SlotState::kLoading;
    // The latency is asked before the read: a fault rule with a count is used up by the read.
    const double latency_s = source_->simulatedLatencyS(r.key);
    const auto t0 = Clock::now();
    Done d = load(job);
    st.inline_io_ms += msSince(t0);
    d.ready_s = time_s + options_.simulated_latency_s + latency_s;
    // Keep delayed_ sorted by (ready time, ticket): completions are then handed over in a fixed
    // order whatever the latencies.
    auto pos = std::upper_bound(delayed_.begin(), delayed_.end(), d, [](const Done& a, const Done& b) {
      return a.ready_s != b.ready_s ? a.ready_s < b.ready_s : a.ticket < b.ticket;
    });
    delayed_.insert(pos, std::move(d));
    return;
  }
  {
    std::lock_guard lock(mutex_);
    queue_.push_back(job);
  }
  work_.notify_one();
}

FrameStats Streamer::update(const Camera& camera, double time_s, SectorSink& sink) {
  const auto t_start = Clock::now();
  FrameStats st;
  st.frame = frame_++;
  st.time_s = time_s;
  double sink_ms = 0.0;

  // 1. Finished loads, in completion order.
  drained_.clear();
  last_latencies_.clear();
  if (options_.io_mode == IoMode::kThreads) {
    std::lock_guard lock(mutex_);
    for (Done& d : done_) drained_.push_back(std::move(d));
    done_.clear();
    // Queued jobs that a thread has picked up are now loading.
    for (Slot& s : slots_)
      if (s.state == SlotState::kQueued &&
          std::none_of(queue_.begin(), queue_.end(), [&](const Job& j) { return j.ticket == s.ticket; }))
        s.state = SlotState::kLoading;
  } else {
    while (!delayed_.empty() && delayed_.front().ready_s <= time_s) {
      drained_.push_back(std::move(delayed_.front()));
      delayed_.pop_front();
    }
  }
  for (Done& d : drained_) handleDone(d, time_s, sink, st, sink_ms);
  drained_.clear();

  // 2. The wanted set: the ranking cut at the sector and byte budgets.
  held_.clear();
  for (const Slot& s : slots_)
    if (s.state != SlotState::kFree && s.state != SlotState::kCancelling) held_.push_back(s.key);
  std::sort(held_.begin(), held_.end());
  ResidencyOptions residency = options_.residency;
  residency.guard_s = guardS();
  st.guard_s = residency.guard_s;
  rankSectors(manifest_, camera, residency, held_, ranked_);
  // Forget back-off for sectors the camera has left behind (keeps backoff_ small); one that comes
  // back into range is tried again at once.
  std::erase_if(backoff_, [&](const Backoff& b) {
    return b.retry_at_s <= time_s &&
           std::none_of(ranked_.begin(), ranked_.end(), [&](const RankedSector& r) { return r.key == b.key; });
  });
  size_t wanted = 0, bytes = 0;
  // Cancelling slots still hold memory until their thread returns.
  for (const Slot& s : slots_)
    if (s.state == SlotState::kCancelling) bytes += s.bytes;
  int cancelling = 0;
  for (const Slot& s : slots_) cancelling += s.state == SlotState::kCancelling;
  const size_t max_wanted = size_t(options_.residency.max_sectors - cancelling);
  for (; wanted < ranked_.size() && wanted < max_wanted; ++wanted) {
    const RankedSector& r = ranked_[wanted];
    const Slot* s = findSlot(r.key);
    const size_t b = s ? s->bytes : predictedSectorBytes(*r.entry) + sizeof(OcclusionTile);
    if (bytes + b > max_bytes_) break;
    bytes += b;
  }
  for (size_t i = wanted; i < ranked_.size(); ++i) st.over_budget += ranked_[i].tier == 0 && wanted < max_wanted;
  st.wanted = int(wanted);
  auto isWanted = [&](SectorKey key) {
    for (size_t i = 0; i < wanted; ++i)
      if (ranked_[i].key == key) return true;
    return false;
  };

  // 3. Evict and cancel what is not wanted.
  {
    std::unique_lock lock(mutex_, std::defer_lock);
    if (options_.io_mode == IoMode::kThreads) lock.lock();
    for (Slot& s : slots_) {
      if (s.state == SlotState::kFree || s.state == SlotState::kCancelling || isWanted(s.key)) continue;
      if (s.state == SlotState::kResident) continue;  // evicted below, outside the lock
      if (s.state == SlotState::kQueued) {
        auto it = std::find_if(queue_.begin(), queue_.end(), [&](const Job& j) { return j.ticket == s.ticket; });
        if (it != queue_.end()) {
          queue_.erase(it);
          s = Slot{};
          ++st.cancels;
          continue;
        }
      }
      if (options_.io_mode == IoMode::kDeterministic) {
        auto it = std::find_if(delayed_.begin(), delayed_.end(), [&](const Done& d) { return d.ticket == s.ticket; });
        if (it != delayed_.end()) delayed_.erase(it);
        s = Slot{};
        ++st.cancels;
        continue;
      }
      s.state = SlotState::kCancelling;  // a thread has it; the slot frees when it returns
    }
    // Re-rank what is still queued, so that threads take the now-most-needed sector next.
    for (Job& j : queue_)
      for (size_t i = 0; i < wanted; ++i)
        if (ranked_[i].key == j.entry.key) j.score = ranked_[i].score_m + (ranked_[i].tier == 0 ? -1e9 : 0.0);
  }
  for (Slot& s : slots_) {
    if (s.state != SlotState::kResident || isWanted(s.key)) continue;
    const auto t0 = Clock::now();
    sink.onSectorEvicted(s.key);
    sink_ms += msSince(t0);
    s = Slot{};
    ++st.evictions;
    ++total_evictions_;
  }

  // 4. Start loads, best first.
  int in_flight = 0;
  size_t reserved = 0;
  for (const Slot& s : slots_) {
    in_flight += s.state == SlotState::kQueued || s.state == SlotState::kLoading || s.state == SlotState::kCancelling;
    reserved += s.state != SlotState::kFree ? s.bytes : 0;
  }
  for (size_t i = 0; i < wanted && in_flight < options_.max_in_flight; ++i) {
    const RankedSector& r = ranked_[i];
    if (findSlot(r.key)) continue;
    if (const Backoff* b = findBackoff(r.key); b && b->retry_at_s > time_s) continue;
    const size_t b = predictedSectorBytes(*r.entry) + sizeof(OcclusionTile);
    if (reserved + b > max_bytes_) break;
    auto free_slot = std::find_if(slots_.begin(), slots_.end(), [](const Slot& s) { return s.state == SlotState::kFree; });
    if (free_slot == slots_.end()) break;
    issue(*free_slot, r, time_s, st);
    reserved += free_slot->bytes;
    ++in_flight;
  }

  // 5. Stats: misses are footprint sectors that are not resident.
  footprintSectors(manifest_, camera.position_m, options_.residency, footprint_);
  for (SectorKey k : footprint_) {
    const Slot* s = findSlot(k);
    if (s && s->state == SlotState::kResident) continue;
    ++st.misses;
    if (const Backoff* b = findBackoff(k); b && !s) ++st.fallback;
  }
  for (const Slot& s : slots_) {
    if (s.state == SlotState::kResident) {
      ++st.resident;
      st.resident_bytes += s.bytes;
    } else if (s.state != SlotState::kFree) {
      ++st.in_flight;
    }
    st.reserved_bytes += s.state != SlotState::kFree ? s.bytes : 0;
  }
  st.sink_ms = sink_ms;
  st.update_ms = std::max(0.0, msSince(t_start) - sink_ms - st.inline_io_ms);
  return st;
}

double Streamer::latencyEstimateS() const {
  const size_t n = std::min(latency_next_, latencies_.size());
  return n ? *std::max_element(latencies_.begin(), latencies_.begin() + ptrdiff_t(n)) : 0.0;
}

double Streamer::guardS() const {
  const double g = std::max(options_.residency.guard_s, options_.guard_latency_factor * latencyEstimateS());
  return std::min(g, kMaxGuardS);
}

void Streamer::evictAll(SectorSink& sink) {
  std::unique_lock lock(mutex_, std::defer_lock);
  if (options_.io_mode == IoMode::kThreads) lock.lock();
  for (Slot& s : slots_) {
    if (s.state == SlotState::kQueued) {
      auto it = std::find_if(queue_.begin(), queue_.end(), [&](const Job& j) { return j.ticket == s.ticket; });
      if (it != queue_.end()) {
        queue_.erase(it);
        s = Slot{};
        continue;
      }
      s.state = SlotState::kCancelling;
    } else if (s.state == SlotState::kLoading) {
      s.state = SlotState::kCancelling;
    }
  }
  if (options_.io_mode == IoMode::kDeterministic) {
    delayed_.clear();
    for (Slot& s : slots_)
      if (s.state == SlotState::kCancelling) s = Slot{};
  }
  if (lock.owns_lock()) lock.unlock();
  for (Slot& s : slots_) {
    if (s.state != SlotState::kResident) continue;
    sink.onSectorEvicted(s.key);
    s = Slot{};
    ++total_evictions_;
  }
}

const Sector* Streamer::resident(SectorKey key) const {
  const Slot* s = findSlot(key);
  return s && s->state == SlotState::kResident ? s->sector.get() : nullptr;
}

const OcclusionTile* Streamer::occlusionTile(SectorKey key) const {
  const Slot* s = findSlot(key);
  return s && s->state == SlotState::kResident ? &s->tile : nullptr;
}

SectorState Streamer::state(SectorKey key) const {
  if (const Slot* s = findSlot(key)) {
    switch (s->state) {
      case SlotState::kQueued: return SectorState::kQueued;
      case SlotState::kLoading: return SectorState::kLoading;
      case SlotState::kResident: return SectorState::kResident;
      default: break;
    }
  }
  if (findBackoff(key)) return SectorState::kBackingOff;
  return SectorState::kAbsent;
}

double Streamer::retryAtS(SectorKey key) const {
  const Backoff* b = findBackoff(key);
  return b ? b->retry_at_s : 0.0;
}

std::vector<SectorKey> Streamer::residentKeys() const {
  std::vector<SectorKey> keys;
  for (const Slot& s : slots_)
    if (s.state == SlotState::kResident) keys.push_back(s.key);
  std::sort(keys.begin(), keys.end());
  return keys;
}

namespace {
size_t readers(const StreamerOptions& o) {
  return o.io_mode == IoMode::kThreads ? size_t(std::min(o.io_threads, o.max_in_flight)) : 1;
}
}  // namespace

size_t Streamer::ioBufferBytes() const {
  size_t largest = 0;
  for (const SectorEntry& e : manifest_.sectors) largest = std::max(largest, size_t(e.compressed_bytes) + size_t(e.raw_bytes));
  return readers(options_) * largest;
}

size_t Streamer::ioWorkingBytes() const { return ioBufferBytes() + readers(options_) * zstdContextBytes(); }

size_t Streamer::residentBytes() const {
  size_t n = 0;
  for (const Slot& s : slots_)
    if (s.state == SlotState::kResident) n += s.bytes;
  return n;
}

bool Streamer::idle() const {
  for (const Slot& s : slots_)
    if (s.state != SlotState::kFree && s.state != SlotState::kResident) return false;
  if (options_.io_mode == IoMode::kThreads) {
    std::lock_guard lock(mutex_);
    return queue_.empty() && running_ == 0 && done_.empty();
  }
  return delayed_.empty();
}

}  // namespace drtv::streamer
