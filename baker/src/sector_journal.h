// Sector journals: where a bake keeps its finished sectors until it packs the archive.
//
// One append-only file per writing process and kind (`sectors-<k>-of-<N>.log` for baked sectors,
// `placement-<k>-of-<N>.log` for the placement pass of an LPRT bake, in `<archive>.sectors/`):
// a finished sector is one record, written with a single write() and checked by an XXH3 hash,
// so a record either is whole or is ignored, and an interrupted bake resumes from the records
// that are whole. Reading stops at the first bad record of a journal (lengths after it cannot be
// trusted): that sector and any after it in the same journal are baked again. A record of
// another journal version is an error, not a torn tail. This replaced a pair of files per sector (stats + sector, each written to a
// temporary file and renamed): creating and deleting ~2 inodes per sector was 6% of a bake's CPU
// time on ext4, whose inode allocator scans recently deleted inodes.
//
// Record (little-endian): "DRTJ" u32 version  i32 ix  i32 iy  u32 stats_len  u32 sector_len,
// then the stats (a typed record, sector_stats.h; empty in placement journals) and the encoded
// sector, then XXH3-64 of everything before it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "drtv/formats/error.h"
#include "drtv/formats/sector.h"

namespace drtv::baker::detail {

// Where a whole record of one sector lies.
struct JournalEntry {
  std::filesystem::path file;
  uint64_t stats_offset = 0, sector_offset = 0;
  uint32_t stats_size = 0, sector_size = 0;
};

// The records held by every journal in `dir` whose name starts with `prefix` ("sectors-" or
// "placement-"), by key (a later record of a key wins; a bake is deterministic, so records of one
// key hold the same bytes). Torn or corrupt tails are skipped.
// Errors: a journal that cannot be opened or read.
Result<std::map<SectorKey, JournalEntry>> scanJournals(const std::filesystem::path& dir, std::string_view prefix = "sectors-");

// The bytes of an entry's stats or sector.
Result<std::vector<uint8_t>> readStats(const JournalEntry& e);
Result<std::vector<uint8_t>> readSector(const JournalEntry& e);

// Whether a process holds the journal `file` open for writing (its lock): true, false (nobody),
// or nullopt when it cannot be told (no such file yet, or a file system that keeps no locks). The
// test takes a shared lock for an instant: a writer opening it then waits, it is not refused.
// Errors: a file that exists but cannot be opened.
Result<std::optional<bool>> journalHeld(const std::filesystem::path& file);

// True for the names of the files journals and the bake's older per-sector files use.
bool isJournalFile(const std::string& filename);
// Removes every journal (and older per-sector file) in `dir` (--fresh). Errors: a journal another
// bake holds locked (its sectors would vanish under it), a file that cannot be removed.
Result<void> removeJournals(const std::filesystem::path& dir);

// Appends records to one journal. Opening takes an exclusive lock on the file (a second process
// with the same shard gets an error instead of interleaving) and cuts a torn tail off.
// append() is not thread-safe: callers serialise.
class JournalWriter {
 public:
  static Result<JournalWriter> open(const std::filesystem::path& file);
  JournalWriter(JournalWriter&&) noexcept;
  JournalWriter& operator=(JournalWriter&&) noexcept;
  ~JournalWriter();
  // Returns where the record lies, as scanJournals would name it.
  Result<JournalEntry> append(SectorKey key, std::span<const uint8_t> stats, std::span<const uint8_t> sector);

 private:
  JournalWriter() = default;
  int fd_ = -1;
  bool broken_ = false;  // a failed write could not be cut off: refuse further appends
  std::filesystem::path file_;
};

}  // namespace drtv::baker::detail
