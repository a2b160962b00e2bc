// drtv/formats/archive.h — a baked world: one file holding a manifest and zstd-compressed sector
// payloads, each readable on its own without touching the others (the streamer's unit of I/O).
//
// File layout (versions 1 and 2; integers and floats little-endian; offsets in bytes from file
// start). Version 2 differs only by the u32 representation after the effects; a writer writes
// version 1 for a kFc3 bake (so that its bytes are those of every earlier build) and version 2
// otherwise (so that a version-1-only reader refuses it, naming the version). A version-1 archive
// reads as kFc3.
//
//    0   8  char    magic "DRTVARC\0"
//    8   4  uint32  version (1 or 2)
//   12   4  uint32  header size (64)
//   16   8  uint64  manifest offset
//   24   8  uint64  manifest size
//   32   8  uint64  manifest hash      XXH3-64 of the manifest bytes
//   40   8  uint64  file size          the whole file; a shorter file was truncated
//   48  16  uint8   reserved           zero
//   64      sector payloads            each one zstd frame holding an encoded sector (sector.h)
//   ..      manifest:
//             f64 bounds min[3], max[3]   world metres
//             f64 sector size             64
//             u32 effects                 drtv::Effect mask baked into this archive
//             u32 representation          (version 2 only) drtv::Representation code; a code
//                                         this build does not know is refused, naming the codes
//                                         it reads and the option to rebake with
//             u32 settings count          then per setting: u16 key length, key, u32 value
//                                         length, value (UTF-8; bake settings for reports)
//             lighting (lighting.h), so that relighting needs no world file:
//               f64 latitude, declination, north (radians); f32 ground radiance scale;
//               3 gradients (sun irradiance, sky zenith, sky horizon), each u32 key count then
//               per key f32 hour, f32 r, g, b;
//               u32 light count, per light: u16 name length, name, f64 position[3],
//               f32 intensity[3], f32 radius;
//               u32 interior count, per interior: u16 name length, name, f64 min[3], max[3],
//               probe[3], f32 blend distance
//             u32 sector count            then per sector, 40 bytes, sorted by (ix, iy), unique:
//               i32 ix, i32 iy, u64 payload offset, u32 compressed size, u32 raw size,
//               u64 XXH3-64 of the compressed payload, u16 probes, u16 LPRT sources,
//               u16 covered probes (sector.h: those with visibility maps), u16 zero
//   No trailing bytes after the manifest.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/effects.h"
#include "drtv/formats/error.h"
#include "drtv/formats/lighting.h"
#include "drtv/formats/representation.h"
#include "drtv/formats/sector.h"

namespace drtv {

inline constexpr uint32_t kArchiveVersion = 3;          // the newest version this build reads and writes
inline constexpr uint32_t kArchiveVersionTalkBasis = 1;  // written for kFc3 bakes (no representation field)
// Version 2: sh-l1 with the direct sky as visibility moments (kProbeSkyMoments), no sun transfer;
// still read. Version 3: sh-l1 with the fitted direct sky (kProbeSkyFit) and the sector's sun
// transfer (sector.h SunBlock).
inline constexpr uint32_t kArchiveVersionShL1Moments = 2;
// The version a writer writes for `r`.
inline uint32_t archiveVersionFor(Representation r) { return r == Representation::kFc3 ? kArchiveVersionTalkBasis : kArchiveVersion; }
inline constexpr size_t kArchiveHeaderBytes = 64;
// The longest light or interior name the manifest stores (a u16 length).
inline constexpr size_t kMaxArchiveNameBytes = 65535;
inline constexpr size_t kArchiveSectorEntryBytes = 40;

struct SectorEntry {
  SectorKey key;
  uint64_t offset = 0;            // of the compressed payload in the file
  uint32_t compressed_bytes = 0;
  uint32_t raw_bytes = 0;         // encoded sector size after decompression
  uint64_t hash = 0;              // XXH3-64 of the compressed payload
  uint16_t probes = 0;
  uint16_t lprt_sources = 0;
  uint16_t covered = 0;           // probes with visibility maps (sector.h), <= probes
};

struct Manifest {
  uint32_t version = kArchiveVersion;            // as read (1, 2 or 3); the writer sets it from the representation
  glm::dvec3 bounds_min{0.0}, bounds_max{0.0};  // world metres
  double sector_size_m = kSectorSizeM;
  uint32_t effects = 0;                         // drtv::Effect mask baked
  Representation representation = Representation::kFc3;  // representation.h: how probes are baked
  std::vector<std::pair<std::string, std::string>> settings;  // bake settings, in order
  Sky sky = Sky::tropicalDefault();             // the world's sun path and sky gradients
  std::vector<PointLight> lights;               // dynamic point lights (LPRT sources' users)
  std::vector<InteriorVolume> interiors;        // artist interior volumes
  std::vector<SectorEntry> sectors;             // sorted by key, unique

  // The entry for `key`, or nullptr. O(log n).
  const SectorEntry* find(SectorKey key) const;
  // The value of setting `key`, or "" if absent.
  std::string setting(const std::string& key) const;
};

// Writes an archive. Sectors go to "<path>.partial" as they are added; finish() appends the
// manifest, fixes the header, flushes and renames onto `path`, so a reader never sees a half
// archive and an interrupted writer leaves the old file (if any) intact. Not thread-safe: one
// writer per file, sectors added from one thread.
class ArchiveWriter {
 public:
  // Opens "<path>.partial" for writing. `zstd_level` as in zstd (1..19; 3 is zstd's default).
  static Result<ArchiveWriter> create(const std::filesystem::path& path, int zstd_level = 3);
  ArchiveWriter(ArchiveWriter&&) noexcept;
  ArchiveWriter& operator=(ArchiveWriter&&) noexcept;
  ~ArchiveWriter();

  // Encodes, compresses and appends `sector`. Adding the same key twice is an error.
  Result<void> addSector(const Sector& sector);
  // Appends an already encoded sector (bytes as encodeSector wrote them; validated here).
  Result<void> addEncodedSector(std::span<const uint8_t> encoded);
  // Writes the manifest (`info`'s sectors are ignored: the added ones are used) and publishes.
  Result<void> finish(const Manifest& info);

 private:
  struct Impl;
  explicit ArchiveWriter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Reads an archive: open() reads and validates the header and manifest only; each readSector
// reads that sector's bytes alone. Errors name the file, the sector and the byte offset.
// Thread-safe after open(): readSector may run concurrently from many threads.
class ArchiveReader {
 public:
  static Result<ArchiveReader> open(const std::filesystem::path& path);
  ArchiveReader(ArchiveReader&&) noexcept;
  ArchiveReader& operator=(ArchiveReader&&) noexcept;
  ~ArchiveReader();

  const Manifest& manifest() const;
  const std::filesystem::path& path() const;

  // Reads, checks the hash, decompresses and decodes one sector.
  Result<Sector> readSector(SectorKey key) const;
  // Reads, checks the hash and decompresses one sector; returns its encoded bytes.
  Result<std::vector<uint8_t>> readSectorBytes(SectorKey key) const;
  // Reads one sector's compressed payload as stored, hash checked (for benchmarks and copies).
  Result<std::vector<uint8_t>> readCompressed(SectorKey key) const;

 private:
  struct Impl;
  explicit ArchiveReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Archive bytes <-> manifest, for tests and tools: decode checks everything open() checks.
Result<Manifest> decodeArchiveHeaderAndManifest(std::span<const uint8_t> file_bytes, const std::string& where);

// The two halves of that, for a reader that fetches the header and then the manifest itself (a
// sector source over HTTP range requests): ArchiveReader::open runs exactly these two checks.
// The 64-byte header as stored.
struct ArchiveHeader {
  uint32_t version = 0;          // 1, 2 or 3
  uint64_t manifest_offset = 0;  // bytes from file start
  uint64_t manifest_bytes = 0;   // the manifest ends the file
  uint64_t manifest_hash = 0;    // XXH3-64 of the manifest bytes
  uint64_t file_bytes = 0;       // the whole file
};
// Checks the first bytes of an archive (`head`, 64 or fewer if the file is shorter) against the
// size the file really has (`file_bytes`: from stat, or an HTTP Content-Range's total): magic,
// version, header size, reserved bytes, the size it records and where its manifest lies. Errors
// name `where` and the byte offset. Pure, thread-safe.
Result<ArchiveHeader> decodeArchiveHeader(std::span<const uint8_t> head, uint64_t file_bytes, const std::string& where);
// Checks and decodes the manifest bytes that `header` locates: their size, their XXH3 against the
// header's and every field as ArchiveReader::open does. Errors name `where` and the file offset.
// Pure, thread-safe.
Result<Manifest> decodeArchiveManifest(const ArchiveHeader& header, std::span<const uint8_t> manifest_bytes, const std::string& where);
// Reads the version of an archive file (after checking its magic).
Result<uint32_t> peekArchiveVersion(const std::filesystem::path& path);

// Decompresses a zstd frame whose decompressed size must equal `raw_bytes` exactly. Each thread
// that calls it keeps one decompression context (zstdContextBytes(), from malloc) for its life.
Result<std::vector<uint8_t>> zstdDecompress(std::span<const uint8_t> frame, size_t raw_bytes, const std::string& where);
// The size of that per-thread context (ZSTD_estimateDCtxSize).
size_t zstdContextBytes();

// The sector `entry` names, from its compressed payload as stored at entry.offset: the size and
// XXH3 checked against the manifest, zstd, decodeSector, then the key and counts against the
// manifest. `where` prefixes errors ("<archive>: sector (x,y)"). What ArchiveReader::readSector
// and the streamer's loads both run; thread-safe.
Result<Sector> decodeSectorPayload(const SectorEntry& entry, std::span<const uint8_t> compressed, const std::string& where);

}  // namespace drtv
