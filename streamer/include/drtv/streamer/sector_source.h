// drtv/streamer/sector_source.h — the file-reading layer under the streamer, and a fault
// injector to put between them.
//
// A SectorSource returns a sector's compressed payload as stored: the streamer then checks its
// size and XXH3 hash against the manifest, decompresses it (zstd), decodes and validates it
// (formats/sector.h) and checks the key. So a source may be as dumb as pread, and a fault anywhere
// below the streamer (short read, flipped byte, missing file, slow disk) arrives as either an
// Error or bytes that fail one of those checks.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "drtv/formats/archive.h"
#include "drtv/formats/error.h"

namespace drtv::streamer {

class SectorSource {
 public:
  virtual ~SectorSource() = default;
  // The compressed payload of `entry`: entry.compressed_bytes bytes at entry.offset, unchecked.
  // On failure an Error naming the file, sector and byte offset. Called from the streamer's I/O
  // threads concurrently: implementations must be thread-safe.
  virtual Result<std::vector<uint8_t>> read(const SectorEntry& entry) = 0;
  // Extra latency, seconds, that the streamer's deterministic I/O mode adds to this read (a slow
  // disk simulated in frame time). 0 for real sources. Thread-safe.
  virtual double simulatedLatencyS(SectorKey key) { return 0.0; }
  // The file or device, for messages ("island.drtv").
  virtual const std::string& name() const = 0;
};

// Reads payloads from an archive file with one pread each. Thread-safe.
class FileSectorSource final : public SectorSource {
 public:
  // Opens `path` read-only. Error if it cannot be opened.
  static Result<std::unique_ptr<FileSectorSource>> open(const std::filesystem::path& path);
  ~FileSectorSource() override;
  Result<std::vector<uint8_t>> read(const SectorEntry& entry) override;
  const std::string& name() const override { return name_; }

 private:
  FileSectorSource(int fd, std::string name) : fd_(fd), name_(std::move(name)) {}
  int fd_ = -1;
  std::string name_;
};

// Faults the injector can put on a sector's reads.
enum class Fault {
  kNone,       // read through
  kMissing,    // the read fails as if the file or sector were gone
  kTruncated,  // half the payload comes back (a short read)
  kCorrupt,    // the payload comes back with one byte flipped (bit rot, a bad block)
  kSlow,       // the read succeeds after delay_s (a sleep, or simulated latency: SlowReads)
  kStall,      // the read blocks until releaseStalls() (a hung device), then reads through
};
const char* faultName(Fault fault);

// Wraps a source and injects faults per sector, for tests and `drtv fly --fault`. Thread-safe.
// Destroying the streamer while a kStall read is blocked deadlocks its join: release first.
class FaultInjectingSource final : public SectorSource {
 public:
  static constexpr int kForever = -1;
  // How kSlow delays: a real sleep in read() (for I/O threads), or simulatedLatencyS() (for the
  // streamer's deterministic mode, which runs reads inline on the frame's thread).
  enum class SlowReads { kSleep, kSimulated };
  explicit FaultInjectingSource(std::shared_ptr<SectorSource> inner, SlowReads slow_reads = SlowReads::kSleep);

  // The next `times` reads of `key` (kForever: all) get `fault`. Replaces an earlier rule.
  void inject(SectorKey key, Fault fault, int times = kForever, double delay_s = 0.0);
  // Removes the rule for `key`: its reads go through again.
  void clear(SectorKey key);
  // Unblocks every kStall read, now and from now on, until the next inject(kStall).
  void releaseStalls();
  // How many reads of `key` were attempted; how many reads are blocked in kStall now.
  int reads(SectorKey key) const;
  int stalled() const;

  Result<std::vector<uint8_t>> read(const SectorEntry& entry) override;
  double simulatedLatencyS(SectorKey key) override;
  const std::string& name() const override { return inner_->name(); }

 private:
  struct Rule {
    Fault fault = Fault::kNone;
    int times = kForever;
    double delay_s = 0.0;
  };
  std::shared_ptr<SectorSource> inner_;
  SlowReads slow_reads_;
  mutable std::mutex mutex_;
  std::condition_variable released_;
  std::map<SectorKey, Rule> rules_;
  std::map<SectorKey, int> reads_;
  uint64_t release_epoch_ = 0;
  int stalled_ = 0;
};

}  // namespace drtv::streamer
