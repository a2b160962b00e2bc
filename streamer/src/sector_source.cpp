// The file-reading layer (pread) and the fault injector (sector_source.h).
#include "drtv/streamer/sector_source.h"

#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>

#include <fcntl.h>
#include <unistd.h>

namespace drtv::streamer {

Result<std::unique_ptr<FileSectorSource>> FileSectorSource::open(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return fail(path.string() + ": cannot open: " + std::strerror(errno));
  return std::unique_ptr<FileSectorSource>(new FileSectorSource(fd, path.string()));
}

FileSectorSource::~FileSectorSource() {
  if (fd_ >= 0) ::close(fd_);
}

Result<std::vector<uint8_t>> FileSectorSource::read(const SectorEntry& e) {
  std::vector<uint8_t> bytes(e.compressed_bytes);
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t got = ::pread(fd_, bytes.data() + done, bytes.size() - done, off_t(e.offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0)
      return fail(name_ + ": sector " + toString(e.key) + ": byte " + std::to_string(e.offset + done) + ": " + std::strerror(errno));
    if (got == 0) break;  // end of file: a short read, reported by the size check
    done += size_t(got);
  }
  bytes.resize(done);
  return bytes;
}

const char* faultName(Fault f) {
  switch (f) {
    case Fault::kNone: return "none";
    case Fault::kMissing: return "missing";
    case Fault::kTruncated: return "truncated";
    case Fault::kCorrupt: return "corrupt";
    case Fault::kSlow: return "slow";
    case Fault::kStall: return "stall";
  }
  return "?";
}

FaultInjectingSource::FaultInjectingSource(std::shared_ptr<SectorSource> inner, SlowReads slow_reads)
    : inner_(std::move(inner)), slow_reads_(slow_reads) {
  DRTV_CHECK(inner_ != nullptr);
}

void FaultInjectingSource::inject(SectorKey key, Fault fault, int times, double delay_s) {
  std::lock_guard lock(mutex_);
  rules_[key] = Rule{fault, times, delay_s};
}

void FaultInjectingSource::clear(SectorKey key) {
  std::lock_guard lock(mutex_);
  rules_.erase(key);
}

void FaultInjectingSource::releaseStalls() {
  {
    std::lock_guard lock(mutex_);
    ++release_epoch_;
    for (auto it = rules_.begin(); it != rules_.end();)
      it = it->second.fault == Fault::kStall ? rules_.erase(it) : std::next(it);
  }
  released_.notify_all();
}

int FaultInjectingSource::reads(SectorKey key) const {
  std::lock_guard lock(mutex_);
  auto it = reads_.find(key);
  return it == reads_.end() ? 0 : it->second;
}

int FaultInjectingSource::stalled() const {
  std::lock_guard lock(mutex_);
  return stalled_;
}

double FaultInjectingSource::simulatedLatencyS(SectorKey key) {
  std::lock_guard lock(mutex_);
  auto it = rules_.find(key);
  if (slow_reads_ != SlowReads::kSimulated) return 0.0;
  return it != rules_.end() && it->second.fault == Fault::kSlow ? it->second.delay_s : 0.0;
}

Result<std::vector<uint8_t>> FaultInjectingSource::read(const SectorEntry& e) {
  Rule rule;
  {
    std::unique_lock lock(mutex_);
    ++reads_[e.key];
    auto it = rules_.find(e.key);
    if (it != rules_.end()) {
      rule = it->second;
      if (it->second.times != kForever && --it->second.times <= 0) rules_.erase(it);
    }
    if (rule.fault == Fault::kStall) {
      ++stalled_;
      const uint64_t epoch = release_epoch_;
      released_.wait(lock, [&] { return release_epoch_ != epoch; });
      --stalled_;
    }
  }
  const std::string where = inner_->name() + ": sector " + toString(e.key);
  switch (rule.fault) {
    case Fault::kMissing:
      return fail(where + ": byte " + std::to_string(e.offset) + ": cannot read: no such file (injected)");
    case Fault::kSlow:
      if (slow_reads_ == SlowReads::kSleep && rule.delay_s > 0.0)
        std::this_thread::sleep_for(std::chrono::duration<double>(rule.delay_s));
      break;
    default: break;
  }
  auto bytes = inner_->read(e);
  if (!bytes) return bytes;
  if (rule.fault == Fault::kTruncated) bytes->resize(bytes->size() / 2);
  if (rule.fault == Fault::kCorrupt && !bytes->empty()) (*bytes)[bytes->size() / 2] ^= 0x5a;
  return bytes;
}

}  // namespace drtv::streamer
