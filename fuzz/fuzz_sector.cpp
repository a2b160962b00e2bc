// fuzz_sector.cpp — libFuzzer target for the sector decoder (formats/src/sector.cpp).
//
// The input is an encoded sector (sector.h's byte table). Properties checked on every input:
//  - decodeSector never aborts, never reads out of bounds, never leaks (ASan/UBSan);
//  - what it accepts re-encodes to exactly the input bytes (the format has one encoding per
//    sector: reserved bytes zero, no trailing bytes), and peekSectorVersion agrees;
//  - the same bytes as a zstd payload through decodeSectorPayload (what the archive reader and
//    the streamer run) give the same verdict, with an entry made to match the bytes' header.
// After meshoptimizer's tools/codecfuzz.cpp. Run: docs/fuzzing.md.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include <xxhash.h>
#include <zstd.h>

#include "drtv/formats/archive.h"
#include "drtv/formats/sector.h"

namespace {

template <class T>
T readLe(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  const auto sector = drtv::decodeSector(bytes, "fuzz.sec");
  const auto version = drtv::peekSectorVersion(bytes, "fuzz.sec");
  if (sector) {
    DRTV_CHECK(version.has_value());
    DRTV_CHECK_EQ(*version, drtv::kSectorVersion);
    const std::vector<uint8_t> again = drtv::encodeSector(*sector);
    DRTV_CHECK_EQ(again.size(), size);
    DRTV_CHECK(std::memcmp(again.data(), data, size) == 0);
    DRTV_CHECK_EQ(again.size(), drtv::encodedSectorBytes(sector->probes.size(), sector->lprt.sources.size(), sector->has_ground,
                                                             sector->sun ? sector->sun->samples() : 0, drtv::coveredProbes(*sector)));
  }

  // The archive path: compress, describe it as the manifest would, decode the payload.
  if (size > drtv::maxEncodedSectorBytes()) return 0;
  // One context for the process: creating one per input cost more than the decode under test.
  static ZSTD_CCtx* const cctx = ZSTD_createCCtx();
  std::vector<uint8_t> frame(ZSTD_compressBound(size));
  const size_t frame_bytes = ZSTD_compressCCtx(cctx, frame.data(), frame.size(), data, size, 1);
  DRTV_CHECK(!ZSTD_isError(frame_bytes));
  frame.resize(frame_bytes);
  drtv::SectorEntry entry;
  if (size >= drtv::kSectorHeaderBytes) {
    entry.key = {readLe<int32_t>(data + 8), readLe<int32_t>(data + 12)};
    entry.probes = readLe<uint16_t>(data + 16);
    entry.lprt_sources = readLe<uint16_t>(data + 18);
    entry.covered = readLe<uint16_t>(data + 42);
  }
  entry.offset = drtv::kArchiveHeaderBytes;
  entry.compressed_bytes = uint32_t(frame.size());
  entry.raw_bytes = uint32_t(size);
  entry.hash = XXH3_64bits(frame.data(), frame.size());
  const auto payload = drtv::decodeSectorPayload(entry, frame, "fuzz.drtv: sector (0,0)");
  DRTV_CHECK_EQ(payload.has_value(), sector.has_value());
  return 0;
}
