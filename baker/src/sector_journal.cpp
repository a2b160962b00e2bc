// Sector journals (see sector_journal.h).
#include "sector_journal.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>
#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <chrono>
#include <system_error>
#include <thread>
#include <utility>

namespace drtv::baker::detail {
namespace fs = std::filesystem;
namespace {

constexpr uint32_t kMagic = 0x4a525444;  // "DRTJ"
constexpr uint32_t kVersion = 6;  // 2: typed stats (sector_stats.h) instead of JSON text; 3: cells_searched; 4: sun_rays, sun_s; 5: dropped_gap; 6: cells_other_side, visibility_s
constexpr size_t kHeaderBytes = 24, kHashBytes = 8;
// A sector with LPRT is < 256 KB and its stats a few KB; anything far larger is not a record.
constexpr uint32_t kMaxPayload = 64u << 20;

std::string errnoText() { return std::error_code(errno, std::generic_category()).message(); }

uint32_t loadU32(const uint8_t* p) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}
void storeU32(uint8_t* p, uint32_t v) { std::memcpy(p, &v, 4); }

// Reads exactly n bytes at offset; false at end of file (a torn tail), an error otherwise.
Result<bool> preadAll(int fd, void* out, size_t n, uint64_t offset, const fs::path& file) {
  auto* p = static_cast<uint8_t*>(out);
  while (n > 0) {
    const ssize_t r = ::pread(fd, p, n, off_t(offset));
    if (r < 0) {
      if (errno == EINTR) continue;
      return fail(file.string() + ": read failed: " + errnoText());
    }
    if (r == 0) return false;
    p += r;
    n -= size_t(r);
    offset += uint64_t(r);
  }
  return true;
}

struct Fd {
  int fd = -1;
  explicit Fd(int f) : fd(f) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

// Takes the journal's exclusive lock. Ok(true): locked; Ok(false): the file system has no locks
// (NFS without lockd, some FUSE mounts), so the bake runs unlocked as it did with per-sector
// files; an error when another process holds it for half a second (a `drtv farm status` looking
// at the journal holds a shared lock for microseconds, never that long).
Result<bool> lockJournal(int fd, const fs::path& file) {
  for (int attempt = 0;; ++attempt) {
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return true;
    if (errno != EWOULDBLOCK || attempt == 25) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (errno == EWOULDBLOCK) return fail(file.string() + ": another bake is writing this shard's journal");
  if (errno == ENOLCK || errno == EOPNOTSUPP || errno == ENOSYS || errno == EINVAL) return false;
  return fail(file.string() + ": cannot lock: " + errnoText());
}

// Scans one journal: calls `take` for every whole record; returns where the whole records end.
template <class Take>
Result<uint64_t> scanOne(int fd, const fs::path& file, Take&& take) {
  uint64_t offset = 0;
  std::vector<uint8_t> record;
  for (;;) {
    uint8_t header[kHeaderBytes];
    auto got = preadAll(fd, header, kHeaderBytes, offset, file);
    if (!got) return std::unexpected(got.error());
    if (!*got || loadU32(header) != kMagic) return offset;
    if (loadU32(header + 4) != kVersion)
      return fail(file.string() + ": a record of journal version " + std::to_string(loadU32(header + 4)) + " (this drtv writes " +
                  std::to_string(kVersion) + "); pass --fresh to discard it");
    const uint32_t stats_size = loadU32(header + 16), sector_size = loadU32(header + 20);
    if (stats_size > kMaxPayload || sector_size > kMaxPayload) return offset;
    const size_t total = kHeaderBytes + size_t(stats_size) + sector_size + kHashBytes;
    record.resize(total);
    std::memcpy(record.data(), header, kHeaderBytes);
    got = preadAll(fd, record.data() + kHeaderBytes, total - kHeaderBytes, offset + kHeaderBytes, file);
    if (!got) return std::unexpected(got.error());
    if (!*got) return offset;
    uint64_t hash;
    std::memcpy(&hash, record.data() + total - kHashBytes, kHashBytes);
    if (hash != XXH3_64bits(record.data(), total - kHashBytes)) return offset;
    JournalEntry e;
    e.file = file;
    e.stats_offset = offset + kHeaderBytes;
    e.stats_size = stats_size;
    e.sector_offset = e.stats_offset + stats_size;
    e.sector_size = sector_size;
    take(SectorKey{int32_t(loadU32(header + 8)), int32_t(loadU32(header + 12))}, e);
    offset += total;
  }
}

Result<std::vector<uint8_t>> readRange(const fs::path& file, uint64_t offset, uint32_t size) {
  Fd f(::open(file.c_str(), O_RDONLY | O_CLOEXEC));
  if (f.fd < 0) return fail(file.string() + ": cannot open: " + errnoText());
  std::vector<uint8_t> out(size);
  auto got = preadAll(f.fd, out.data(), size, offset, file);
  if (!got) return std::unexpected(got.error());
  if (!*got) return fail(file.string() + ": shorter than when it was scanned (was it changed during the bake?)");
  return out;
}

}  // namespace

Result<std::optional<bool>> journalHeld(const fs::path& file) {
  Fd f(::open(file.c_str(), O_RDONLY | O_CLOEXEC));
  if (f.fd < 0) {
    if (errno == ENOENT) return std::optional<bool>();
    return fail(file.string() + ": cannot open: " + errnoText());
  }
  if (::flock(f.fd, LOCK_SH | LOCK_NB) == 0) return false;  // closing the file releases it
  if (errno == EWOULDBLOCK) return true;
  if (errno == ENOLCK || errno == EOPNOTSUPP || errno == ENOSYS || errno == EINVAL) return std::optional<bool>();
  return fail(file.string() + ": cannot test its lock: " + errnoText());
}

Result<void> removeJournals(const fs::path& dir) {
  std::error_code ec;
  std::vector<fs::path> doomed;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec))
    if (isJournalFile(it->path().filename().string())) doomed.push_back(it->path());
  if (ec) return fail(dir.string() + ": cannot list: " + ec.message());
  for (const fs::path& file : doomed) {
    // A journal another bake still writes is not ours to discard: its sectors would vanish.
    Fd f(::open(file.c_str(), O_RDWR | O_CLOEXEC));
    if (f.fd >= 0)
      if (auto locked = lockJournal(f.fd, file); !locked) return std::unexpected(locked.error());
    std::error_code rm;
    fs::remove(file, rm);
    if (rm) return fail(file.string() + ": cannot remove: " + rm.message());
  }
  return {};
}

bool isJournalFile(const std::string& name) {
  // shard-<k>-of-<N>.json (shard.h) goes with its journals: a status of a discarded bake would
  // make the merge name a shard that no longer exists.
  return ((name.starts_with("sectors-") || name.starts_with("placement-")) && name.ends_with(".log")) || name.starts_with("s_") ||
         (name.starts_with("shard-") && name.ends_with(".json"));
}

Result<std::map<SectorKey, JournalEntry>> scanJournals(const fs::path& dir, std::string_view prefix) {
  std::map<SectorKey, JournalEntry> out;
  std::error_code ec;
  std::vector<fs::path> files;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.starts_with(prefix) && name.ends_with(".log")) files.push_back(it->path());
  }
  if (ec) return fail(dir.string() + ": cannot list: " + ec.message());
  std::sort(files.begin(), files.end());  // a fixed order: which record of a key wins is not up to the file system
  for (const fs::path& file : files) {
    Fd f(::open(file.c_str(), O_RDONLY | O_CLOEXEC));
    if (f.fd < 0) return fail(file.string() + ": cannot open: " + errnoText());
    auto end = scanOne(f.fd, file, [&](SectorKey key, const JournalEntry& e) { out[key] = e; });
    if (!end) return std::unexpected(end.error());
  }
  return out;
}

Result<std::vector<uint8_t>> readStats(const JournalEntry& e) { return readRange(e.file, e.stats_offset, e.stats_size); }
Result<std::vector<uint8_t>> readSector(const JournalEntry& e) { return readRange(e.file, e.sector_offset, e.sector_size); }

Result<JournalWriter> JournalWriter::open(const fs::path& file) {
  JournalWriter w;
  w.file_ = file;
  w.fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (w.fd_ < 0) return fail(file.string() + ": cannot open for writing: " + errnoText());
  if (auto locked = lockJournal(w.fd_, file); !locked) return std::unexpected(locked.error());
  // Keep the whole records; cut off what an interrupted append left.
  auto end = scanOne(w.fd_, file, [](SectorKey, const JournalEntry&) {});
  if (!end) return std::unexpected(end.error());
  if (::ftruncate(w.fd_, off_t(*end)) != 0) return fail(file.string() + ": cannot truncate a torn record: " + errnoText());
  if (::lseek(w.fd_, off_t(*end), SEEK_SET) < 0) return fail(file.string() + ": cannot seek: " + errnoText());
  return w;
}

JournalWriter::JournalWriter(JournalWriter&& o) noexcept
    : fd_(std::exchange(o.fd_, -1)), broken_(o.broken_), file_(std::move(o.file_)) {}
JournalWriter& JournalWriter::operator=(JournalWriter&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(o.fd_, -1);
    broken_ = o.broken_;
    file_ = std::move(o.file_);
  }
  return *this;
}
JournalWriter::~JournalWriter() {
  if (fd_ >= 0) ::close(fd_);  // also releases the lock
}

Result<JournalEntry> JournalWriter::append(SectorKey key, std::span<const uint8_t> stats, std::span<const uint8_t> sector) {
  if (broken_) return fail(file_.string() + ": an earlier write failed and could not be undone; no more records are appended");
  if (stats.size() > kMaxPayload || sector.size() > kMaxPayload)
    return fail(file_.string() + ": sector " + toString(key) + " is too large for a journal record");
  std::vector<uint8_t> record(kHeaderBytes + stats.size() + sector.size() + kHashBytes);
  storeU32(record.data(), kMagic);
  storeU32(record.data() + 4, kVersion);
  storeU32(record.data() + 8, uint32_t(key.ix));
  storeU32(record.data() + 12, uint32_t(key.iy));
  storeU32(record.data() + 16, uint32_t(stats.size()));
  storeU32(record.data() + 20, uint32_t(sector.size()));
  if (!stats.empty()) std::memcpy(record.data() + kHeaderBytes, stats.data(), stats.size());
  if (!sector.empty()) std::memcpy(record.data() + kHeaderBytes + stats.size(), sector.data(), sector.size());
  const uint64_t hash = XXH3_64bits(record.data(), record.size() - kHashBytes);
  std::memcpy(record.data() + record.size() - kHashBytes, &hash, kHashBytes);
  const off_t start = ::lseek(fd_, 0, SEEK_CUR);
  size_t done = 0;
  while (done < record.size()) {
    const ssize_t r = ::write(fd_, record.data() + done, record.size() - done);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) {
      const std::string why = r < 0 ? errnoText() : "no progress";
      // Leave no torn record behind for the next append to follow; if that fails too, append
      // nothing more (a record after a torn one would never be read).
      if (start < 0 || ::ftruncate(fd_, start) != 0 || ::lseek(fd_, start, SEEK_SET) < 0) broken_ = true;
      return fail(file_.string() + ": write failed: " + why);
    }
    done += size_t(r);
  }
  if (start < 0) return fail(file_.string() + ": cannot tell where the record was written: " + errnoText());
  JournalEntry e;
  e.file = file_;
  e.stats_offset = uint64_t(start) + kHeaderBytes;
  e.stats_size = uint32_t(stats.size());
  e.sector_offset = e.stats_offset + stats.size();
  e.sector_size = uint32_t(sector.size());
  return e;
}

}  // namespace drtv::baker::detail
