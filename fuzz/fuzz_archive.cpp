// fuzz_archive.cpp — libFuzzer target for the archive header and manifest
// (formats/src/archive.cpp), and for every sector payload the manifest then points at.
//
// The input is a whole archive file (archive.h's layout). A mutated file nearly always fails the
// manifest's XXH3, or the header's file and manifest sizes once the mutation changed the length,
// which would hide the manifest parser from the fuzzer; so, like PNG fuzzers that fix CRCs, this
// target writes the true file size, manifest size (to the end of the file, where the manifest
// must end) and manifest hash into a copy of the header before decoding. Those checks are
// covered by tests/formats (every truncated prefix, every flipped byte). The same is done for
// each payload's hash. The fixed-up bytes are also written to an in-memory file (memfd) and read
// back through ArchiveReader, the file reader that drtv and the streamer use.
// Properties: never an abort, an out-of-bounds read or a leak; ArchiveReader::open accepts
// exactly what decodeArchiveHeaderAndManifest accepts; an accepted manifest's entries lie
// inside the file, sorted and unique.
// After meshoptimizer's tools/codecfuzz.cpp. Run: docs/fuzzing.md.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include <sys/mman.h>
#include <unistd.h>
#include <xxhash.h>

#include "drtv/formats/archive.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> file(data, data + size);
  if (size >= drtv::kArchiveHeaderBytes) {
    uint64_t offset = 0;
    std::memcpy(&offset, data + 16, 8);
    const uint64_t file_bytes = size;
    std::memcpy(file.data() + 40, &file_bytes, 8);
    if (offset <= size) {
      const uint64_t bytes = size - offset;
      const uint64_t hash = XXH3_64bits(data + offset, bytes);
      std::memcpy(file.data() + 24, &bytes, 8);
      std::memcpy(file.data() + 32, &hash, 8);
    }
  }
  const auto manifest = drtv::decodeArchiveHeaderAndManifest(file, "fuzz.drtv");

  // The same bytes through the file reader.
  const int fd = memfd_create("fuzz.drtv", MFD_CLOEXEC);
  DRTV_CHECK(fd >= 0);
  DRTV_CHECK_EQ(write(fd, file.data(), file.size()), ssize_t(file.size()));
  const auto reader = drtv::ArchiveReader::open("/proc/self/fd/" + std::to_string(fd));
  DRTV_CHECK_EQ(reader.has_value(), manifest.has_value());
  if (reader)
    for (const drtv::SectorEntry& e : reader->manifest().sectors) (void)reader->readSector(e.key);
  close(fd);
  if (!manifest) return 0;
  const drtv::SectorEntry* previous = nullptr;
  for (const drtv::SectorEntry& e : manifest->sectors) {
    DRTV_CHECK_LE(e.offset, size);
    DRTV_CHECK_LE(e.compressed_bytes, size - e.offset);
    if (previous) DRTV_CHECK(previous->key < e.key);
    previous = &e;
    const std::span<const uint8_t> payload(file.data() + e.offset, e.compressed_bytes);
    drtv::SectorEntry fixed = e;
    fixed.hash = XXH3_64bits(payload.data(), payload.size());
    (void)drtv::decodeSectorPayload(fixed, payload, "fuzz.drtv: sector " + drtv::toString(e.key));
  }
  return 0;
}
