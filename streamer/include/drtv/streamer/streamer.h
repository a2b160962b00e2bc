// drtv/streamer/streamer.h — keeps the sectors around the camera in memory: at most 51, the
// volume's footprint first, loaded on background I/O threads and handed to the runtime on the
// frame's thread without ever waiting for I/O.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slide 24 (sectors of
//      ~15 KB, +210 KB of LPRT; at most 51 resident: ~760 KB without LPRT, ~11.5 MB with it),
//      slides 34-36 (the camera-following volume), slide 58 (occlusion tiles regenerated when a
//      sector streams in).
//
// Frame loop (one thread, "the frame's thread"):
//
//     Streamer::update(camera, time_s, sink)
//       1. drains finished loads: each becomes resident and goes to sink.onSectorLoaded (the
//          runtime relights its probes and fills its volume slabs); each failure goes to
//          sink.onSectorFailed and is retried later with exponential back-off;
//       2. ranks the sectors for the camera (residency.h) and cuts the ranking at the sector and
//          byte budgets: that prefix is the wanted set;
//       3. evicts what is not wanted (sink.onSectorEvicted; its occlusion tile goes with it) and
//          cancels loads nobody wants any more;
//       4. starts loads for wanted sectors, best first, while slots, bytes and in-flight room last.
//     update() takes a mutex only to exchange job lists with the I/O threads (microseconds) and
//     never waits for a read.
//
// Budgets. A slot is taken from the moment a load is queued until its sector is evicted, so the
// sectors in memory (resident, in flight, or decoded and waiting for the frame) never exceed
// max_sectors. Bytes: resident sectors count Sector::memoryBytes() (their real allocations; the
// tests check this against a counting operator new), loads in flight count the manifest's
// prediction for them (exact for sectors the decoder sized, see predictedSectorBytes).
//
// Faults. A sector whose read, hash, decompression or decode fails is reported (failures(),
// FrameStats::failures, sink.onSectorFailed) and retried after retry_initial_s, doubling up to
// retry_max_s; meanwhile its area falls back to distant ambient (the runtime's business: it was
// told) and nothing already resident is touched. A slow read ties up one I/O thread and one slot;
// the other threads keep loading.
//
// I/O modes. kThreads: io_threads background threads; completion order depends on the OS, so the
// frame in which a sector arrives is not reproducible. kDeterministic: reads run inline in
// update() (their cost reported apart, as inline_io_ms, because threads would bear it) and
// complete simulated_latency_s later in *camera* time: the same camera path always gives the same
// loads, evictions and misses in the same frames. Tests and `drtv fly` reports use it.
#pragma once

#include <array>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "drtv/formats/archive.h"
#include "drtv/formats/error.h"
#include "drtv/formats/sector.h"
#include "drtv/runtime/occlusion.h"
#include "drtv/streamer/residency.h"
#include "drtv/streamer/sector_source.h"

namespace drtv::streamer {

// The distant-occlusion tile of a sector (runtime/occlusion.h): built by the streamer on its I/O
// threads, handed to the runtime as is.
using runtime::OcclusionTile;

// The talk's resident totals [1], read as binary units (15 KiB and 225 KiB per sector x 51).
inline constexpr size_t kBudgetBytesWithoutLprt = 760 * 1024;
inline constexpr size_t kBudgetBytesWithLprt = size_t(11.5 * 1024 * 1024);
// The budget for `manifest`'s archive: the one above for its LPRT, plus, when its sectors carry a
// sun transfer (sh-l1 of archive version 3), that transfer for 51 sectors of the talk's 70 probes
// at the most samples any sector holds (sector.h sunTransferAllowanceBytes). With the default 6
// samples: 778,240 + 51 x 5,392 = 1,053,232 B without LPRT. Plus the visibility maps of covered
// probes (sector.h, the fine level of issue 35) of the 51 sectors that hold the most.
size_t budgetBytesFor(const Manifest& manifest);

// The runtime's side of the hand-off. Called only from update() / evictAll(), on the frame's
// thread, in this order per frame: loaded and failed (in completion order), then evicted.
class SectorSink {
 public:
  virtual ~SectorSink() = default;
  // `sector` is resident: relight it, fill its volume slabs, install its occlusion tile. Both
  // references stay valid (and unchanged) until onSectorEvicted(sector.key) returns, so the sink
  // may keep pointers instead of copies.
  virtual void onSectorLoaded(const Sector& sector, const OcclusionTile& tile) = 0;
  // `key` is going away: drop every pointer into it. Its memory is freed after this returns.
  virtual void onSectorEvicted(SectorKey key) = 0;
  // A load of `key` failed (`error` names file, sector and byte offset); it will be retried. Until
  // it loads, shade its area with distant ambient. Default: ignore.
  virtual void onSectorFailed(SectorKey key, const Error& error) {}
};

enum class IoMode {
  kThreads,        // background I/O threads; nondeterministic arrival frames
  kDeterministic,  // inline reads, completion simulated in camera time; reproducible
};

struct StreamerOptions {
  ResidencyOptions residency;       // which sectors, at most how many (51)
  // Byte budget for sectors in memory (resident + in flight). 0 = the talk's for the archive
  // (budgetBytesFor): kBudgetBytesWithLprt when it holds LPRT, else kBudgetBytesWithoutLprt, plus
  // the sun transfer's allowance when its sectors carry one.
  size_t max_bytes = 0;
  IoMode io_mode = IoMode::kThreads;
  int io_threads = 2;               // kThreads: background readers (>= 1)
  int max_in_flight = 8;            // loads queued or running at once (>= 1)
  // kDeterministic: each read completes this long after it was started, camera seconds. Two
  // frames at 60 Hz: a 15 KB read from an SSD plus a decode is well under that.
  double simulated_latency_s = 2.0 / 60.0;
  // Residency looks ahead at least this many times the load latency it measures (the slowest of
  // the last kLatencyWindow loads, camera seconds from request to hand-over): tier 0 is every
  // sector the moving footprint reaches within max(residency.guard_s, factor x latency), at most
  // kMaxGuardS. 2: a load asked for when its sector enters the guard arrives with one latency to
  // spare, for queueing behind a row of other loads.
  double guard_latency_factor = 2.0;
  double retry_initial_s = 0.25;    // first back-off after a failed load, seconds
  double retry_max_s = 8.0;         // back-off doubles up to this
  size_t failure_log = 256;         // failures() keeps the latest this many
  // Builds a loaded sector's occlusion tile on the I/O thread; empty = runtime::makeOcclusionTile.
  std::function<OcclusionTile(const Sector&)> occlusion_tile;
};

// Where a sector stands in the streamer.
enum class SectorState {
  kAbsent,      // not in memory, not wanted (or not in the archive)
  kQueued,      // waiting for an I/O thread
  kLoading,     // being read / decoded, or waiting for the frame to take it
  kResident,    // in memory and handed to the sink
  kBackingOff,  // its last load failed; retried at retryAtS()
};
const char* sectorStateName(SectorState state);

// What one update() did, for reports and tests.
struct FrameStats {
  uint64_t frame = 0;          // update() calls so far, from 0
  double time_s = 0.0;         // as passed to update()
  int resident = 0;            // sectors resident after this update
  int in_flight = 0;           // loads queued or running (slots taken, not yet resident)
  int wanted = 0;              // size of the wanted set (<= max_sectors)
  int loads = 0;               // sectors that became resident in this update
  int evictions = 0;           // resident sectors dropped in this update
  int cancels = 0;             // loads dropped because their sector was no longer wanted
  int failures = 0;            // loads that failed in this update
  int started = 0;             // loads started in this update
  int misses = 0;              // archive sectors overlapping the volume footprint, not resident
  int fallback = 0;            // of those, sectors backing off after a failure (distant ambient)
  int over_budget = 0;         // footprint sectors left out of the wanted set by the byte budget
  size_t resident_bytes = 0;   // sum of memoryBytes() + tile of resident sectors
  size_t reserved_bytes = 0;   // resident_bytes + predicted bytes of loads in flight
  double guard_s = 0.0;        // the residency's guard this frame (seconds ahead that are tier 0)
  double latency_max_s = 0.0;  // the slowest load handed over in this update, camera seconds; 0 if none
  double update_ms = 0.0;      // frame-thread time in update(), less sink calls and inline I/O
  double sink_ms = 0.0;        // frame-thread time inside the sink's callbacks
  double inline_io_ms = 0.0;   // kDeterministic: time spent reading/decoding inline
};

// One failed load, as failures() reports it.
struct SectorFailure {
  SectorKey key;
  int attempt = 0;        // 1 for the first failure of this sector since it last loaded
  double time_s = 0.0;    // update() time at which it was seen
  double retry_at_s = 0.0;
  std::string message;    // names file, sector, byte offset
};

// Bytes a sector with this manifest entry occupies once decoded: sizeof(Sector) plus its vectors
// sized exactly (what decodeSector allocates). Pure.
size_t predictedSectorBytes(const SectorEntry& entry);

class Streamer {
 public:
  // Opens `archive` (header and manifest) and streams from it with a FileSectorSource.
  static Result<std::unique_ptr<Streamer>> open(const std::filesystem::path& archive, StreamerOptions options = {});
  // Streams `manifest`'s sectors from `source` (e.g. a FaultInjectingSource). Starts the I/O
  // threads in kThreads mode. Preconditions (bugs): source non-null, max_sectors >= 1,
  // io_threads >= 1 in kThreads mode, max_in_flight >= 1.
  Streamer(Manifest manifest, std::shared_ptr<SectorSource> source, StreamerOptions options = {});
  // Stops the I/O threads (after their current read) and frees everything. Does not call a sink:
  // call evictAll first if one holds pointers. A read blocked forever blocks this too.
  ~Streamer();
  Streamer(const Streamer&) = delete;
  Streamer& operator=(const Streamer&) = delete;

  // One frame (see the top of this file). `time_s` is the camera's clock in seconds, non-
  // decreasing across calls (it drives back-off and the deterministic mode's latency). Frame's
  // thread only.
  FrameStats update(const Camera& camera, double time_s, SectorSink& sink);
  // Evicts every resident sector through `sink` and cancels every load (e.g. at shutdown or on a
  // teleport). Frame's thread only.
  void evictAll(SectorSink& sink);

  // Queries; frame's thread only (they read state that update() changes).
  const Manifest& manifest() const { return manifest_; }
  const StreamerOptions& options() const { return options_; }
  size_t maxBytes() const { return max_bytes_; }
  const Sector* resident(SectorKey key) const;             // nullptr unless kResident
  const OcclusionTile* occlusionTile(SectorKey key) const; // nullptr unless kResident
  SectorState state(SectorKey key) const;
  double retryAtS(SectorKey key) const;                    // kBackingOff: when; else 0
  std::vector<SectorKey> residentKeys() const;             // sorted
  size_t residentBytes() const;                            // as FrameStats::resident_bytes
  // The most the loads' working memory can hold at once, outside the sector budget: a load holds
  // its compressed bytes and the decompressed payload only while it runs, one load per reader
  // (min(io_threads, max_in_flight); 1 in kDeterministic mode, where loads run inside update()),
  // and each reader keeps one zstd context for its life (zstdContextBytes()):
  // readers x (the archive's largest compressed + raw sector + the zstd context).
  size_t ioWorkingBytes() const;
  // The buffers' part of it alone (no zstd context): readers x largest compressed + raw sector.
  size_t ioBufferBytes() const;
  bool idle() const;                                       // no load queued or running
  const std::deque<SectorFailure>& failures() const { return failures_; }  // oldest first
  uint64_t totalLoads() const { return total_loads_; }
  // Load latency, camera seconds from the update that requested a sector to the one that handed
  // it over (in kDeterministic mode the simulated latency, rounded up to frames).
  static constexpr size_t kLatencyWindow = 32;
  static constexpr double kMaxGuardS = 8.0;
  // The slowest of the last kLatencyWindow loads; 0 before the first.
  double latencyEstimateS() const;
  // The guard the next update ranks with: max(residency.guard_s, guard_latency_factor x
  // latencyEstimateS()), at most kMaxGuardS.
  double guardS() const;
  // The latencies of the loads the latest update handed over, in hand-over order.
  std::span<const double> lastLoadLatenciesS() const { return last_latencies_; }
  uint64_t totalEvictions() const { return total_evictions_; }

 private:
  enum class SlotState : uint8_t { kFree, kQueued, kLoading, kCancelling, kResident };
  struct Slot {
    SlotState state = SlotState::kFree;
    SectorKey key;
    uint64_t ticket = 0;
    double issued_s = 0.0;             // update() time at which its load was requested
    size_t bytes = 0;                  // predicted until resident, then memoryBytes()
    std::unique_ptr<Sector> sector;    // kResident
    OcclusionTile tile;                // kResident
  };
  struct Job {
    uint64_t ticket = 0;
    SectorEntry entry;
    double score = 0.0;                // lower first; the frame re-ranks queued jobs
  };
  struct Done {
    uint64_t ticket = 0;
    SectorKey key;
    std::unique_ptr<Sector> sector;    // null on failure
    OcclusionTile tile;
    std::string error;
    double ready_s = 0.0;              // kDeterministic: camera time at which it completes
  };
  struct Backoff {
    SectorKey key;
    int attempts = 0;
    double retry_at_s = 0.0;
  };

  void ioThread();
  Done load(const Job& job) const;
  void issue(Slot& slot, const RankedSector& r, double time_s, FrameStats& stats);
  void handleDone(Done& done, double time_s, SectorSink& sink, FrameStats& stats, double& sink_ms);
  Slot* findSlot(SectorKey key);
  const Slot* findSlot(SectorKey key) const;
  const Backoff* findBackoff(SectorKey key) const;

  Manifest manifest_;
  std::shared_ptr<SectorSource> source_;
  StreamerOptions options_;
  size_t max_bytes_ = 0;

  // Frame's thread only.
  std::vector<Slot> slots_;            // max_sectors, fixed
  std::vector<Backoff> backoff_;
  std::deque<SectorFailure> failures_;
  std::vector<RankedSector> ranked_;   // scratch, reused every frame
  std::vector<SectorKey> held_, footprint_;
  std::vector<Done> drained_;
  std::deque<Done> delayed_;           // kDeterministic: done, waiting for their ready time
  uint64_t next_ticket_ = 1, frame_ = 0, total_loads_ = 0, total_evictions_ = 0;
  std::array<double, kLatencyWindow> latencies_{};  // a ring of the latest loads' latencies
  size_t latency_next_ = 0;                         // loads recorded so far
  std::vector<double> last_latencies_;              // the latest update's

  // Shared with the I/O threads, under mutex_.
  mutable std::mutex mutex_;
  std::condition_variable work_;
  std::vector<Job> queue_;
  std::vector<Done> done_;
  int running_ = 0;
  bool stop_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace drtv::streamer
