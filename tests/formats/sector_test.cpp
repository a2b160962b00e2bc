// Sector encoding: round trip, memory budget, golden bytes, and untrusted-input safety.
#include <atomic>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <new>

#include <gtest/gtest.h>

#include <bitset>
#include <xxhash.h>

#include "drtv/formats/sector.h"
#include "test_sectors.h"

// The replacement operator new pairs with free() below; GCC cannot see that.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
// Counts heap bytes allocated while g_counting is set: the memory test measures real allocations.
static std::atomic<bool> g_counting{false};
static std::atomic<size_t> g_counted_bytes{0};
void* operator new(size_t n) {
  if (g_counting.load(std::memory_order_relaxed)) g_counted_bytes += n;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, size_t) noexcept { std::free(p); }

namespace drtv {
namespace {

TEST(Sector, RoundTripsBitForBit) {
  for (bool lprt : {false, true}) {
    const Sector s = testing::makeSector({3, -1}, 70, lprt ? 128 : 0, 11);
    const std::vector<uint8_t> bytes = encodeSector(s);
    EXPECT_EQ(bytes.size(), encodedSectorBytes(70, lprt ? 128 : 0, true));
    auto d = decodeSector(bytes, "mem");
    ASSERT_TRUE(d.has_value()) << d.error().message;
    EXPECT_EQ(encodeSector(*d), bytes);
    EXPECT_EQ(d->key, s.key);
    EXPECT_EQ(d->grid.cells, s.grid.cells);
    EXPECT_EQ(d->hasLprt(), lprt);
  }
}

TEST(Sector, RoundTripsWithoutProbesAndWithTheMostProbes) {
  for (int probes : {0, 1, kMaxProbesPerSector}) {
    const Sector s = testing::makeSector({0, 0}, probes, 0, 5);
    const std::vector<uint8_t> bytes = encodeSector(s);
    auto d = decodeSector(bytes, "mem");
    ASSERT_TRUE(d.has_value()) << probes << " probes: " << d.error().message;
    EXPECT_EQ(d->probes.size(), size_t(probes));
    EXPECT_EQ(encodeSector(*d), bytes);
  }
}

TEST(Sector, RoundTripsTheCoveredProbesVisibilityMaps) {
  Sector s = testing::makeSector({2, 5}, 70, 0, 4);
  testing::coverProbes(s, 3, 9);
  const size_t covered = coveredProbes(s);
  ASSERT_EQ(covered, 24u);
  const std::vector<uint8_t> bytes = encodeSector(s);
  EXPECT_EQ(bytes.size(), encodedSectorBytes(70, 0, true, 0, covered));
  EXPECT_EQ(bytes.size() - encodedSectorBytes(70, 0, true), covered * kVisBytesPerProbe);
  EXPECT_EQ(size_t(bytes[42]) | size_t(bytes[43]) << 8, covered);
  auto d = decodeSector(bytes, "mem");
  ASSERT_TRUE(d.has_value()) << d.error().message;
  ASSERT_TRUE(d->visibility);
  EXPECT_EQ(d->visibility->values, s.visibility->values);
  EXPECT_EQ(encodeSector(*d), bytes);
  // A sector without covered probes has no block and its bytes are those of every build before.
  EXPECT_FALSE(decodeSector(encodeSector(testing::makeSector({2, 5}, 70, 0, 4)), "mem")->visibility);
}

// A light source (kProbeLightSource) is read by no lookup: a cell naming it, or the flag on a
// covered or interior probe, is refused; on a probe no cell names it decodes.
TEST(Sector, ALightSourceThatACellNamesOrThatIsCoveredIsRefused) {
  Sector s = testing::makeSector({0, 0}, 30, 0, 2);
  testing::coverProbes(s, 2, 1);  // probes 0, 2, 4, ... covered (coverProbes' stride 2, offset 0)
  std::bitset<256> named;
  for (uint8_t c : s.grid.cells)
    if (c != kNoProbe) named.set(c);
  const std::vector<uint8_t> good = encodeSector(s);
  auto flagged = [&](size_t probe) {
    std::vector<uint8_t> bytes = good;
    bytes[kSectorHeaderBytes + probe * sizeof(ProbeRecord) + 12] |= uint8_t(kProbeLightSource);
    return decodeSector(bytes, "x.drtv");
  };
  int refused_named = 0, decoded = 0, refused_covered = 0;
  for (size_t i = 0; i < s.probes.size(); ++i) {
    auto d = flagged(i);
    if (s.probes[i].flags & kProbeCovered) {
      ASSERT_FALSE(d.has_value()) << i;
      EXPECT_NE(d.error().message.find("a light source is flagged covered or interior"), std::string::npos) << d.error().message;
      ++refused_covered;
    } else if (named.test(i)) {
      ASSERT_FALSE(d.has_value()) << i;
      EXPECT_NE(d.error().message.find("names probe " + std::to_string(i) + ", a light source"), std::string::npos) << d.error().message;
      ++refused_named;
    } else {
      EXPECT_TRUE(d.has_value()) << i << ": " << d.error().message;
      ++decoded;
    }
  }
  EXPECT_GT(refused_covered, 0);
  EXPECT_GT(refused_named, 0) << decoded << " probes named by no cell decoded with the flag";
}

// A stacked probe (kProbeStacked, placed up a tall space under a roof) is always a covered one: the
// flag decodes on a covered probe and is refused on any other.
TEST(Sector, AStackedProbeThatIsNotCoveredIsRefused) {
  Sector s = testing::makeSector({0, 0}, 30, 0, 2);
  testing::coverProbes(s, 2, 1);
  const std::vector<uint8_t> good = encodeSector(s);
  int decoded = 0, refused = 0;
  for (size_t i = 0; i < s.probes.size(); ++i) {
    std::vector<uint8_t> bytes = good;
    bytes[kSectorHeaderBytes + i * sizeof(ProbeRecord) + 13] |= uint8_t(kProbeStacked >> 8);  // flags, little-endian
    auto d = decodeSector(bytes, "x.drtv");
    if (s.probes[i].flags & kProbeCovered) {
      ASSERT_TRUE(d.has_value()) << i << ": " << d.error().message;
      EXPECT_NE(d->probes[i].flags & kProbeStacked, 0);
      ++decoded;
    } else {
      ASSERT_FALSE(d.has_value()) << i;
      EXPECT_NE(d.error().message.find("a stacked probe is not flagged covered"), std::string::npos) << d.error().message;
      ++refused;
    }
  }
  EXPECT_GT(decoded, 0);
  EXPECT_GT(refused, 0);
}

TEST(Sector, ACoveredCountThatDisagreesWithTheFlagsIsRefused) {
  Sector s = testing::makeSector({0, 0}, 30, 0, 2);
  testing::coverProbes(s, 2, 1);
  const std::vector<uint8_t> good = encodeSector(s);
  {
    std::vector<uint8_t> bytes = good;
    bytes[42] = uint8_t(bytes[42] + 1);  // one more map than the size holds
    auto d = decodeSector(bytes, "x.drtv");
    ASSERT_FALSE(d.has_value());
    EXPECT_NE(d.error().message.find("x.drtv: byte "), std::string::npos) << d.error().message;
  }
  {
    std::vector<uint8_t> bytes = good;
    bytes[42] = 31;  // more covered probes than probes
    auto d = decodeSector(bytes, "x.drtv");
    ASSERT_FALSE(d.has_value());
    EXPECT_NE(d.error().message.find("byte 42: covered probe count 31 exceeds the probe count 30"), std::string::npos)
        << d.error().message;
  }
  {
    // A probe flagged covered whose map is missing: the count says 15, the flags 16.
    std::vector<uint8_t> bytes = good;
    const size_t flags_at = kSectorHeaderBytes + 1 * sizeof(ProbeRecord) + 12;
    bytes[flags_at] = uint8_t(bytes[flags_at] | kProbeCovered);
    auto d = decodeSector(bytes, "x.drtv");
    ASSERT_FALSE(d.has_value());
    EXPECT_NE(d.error().message.find("covered probe count 15, but 16 probes are flagged covered"), std::string::npos)
        << d.error().message;
  }
}

// DESIGN.md, "Near surfaces and indoors": a sector with buildings takes at most 256 KB without
// LPRT. The most a sector can hold: 255 probes, every one covered with its map, the ground map and
// an 8-sample sun transfer.
TEST(Sector, ASectorOfBuildingsStaysWithinItsBudget) {
  EXPECT_LE(encodedSectorBytes(kMaxProbesPerSector, 0, true, kMaxSunSamples, kMaxProbesPerSector), 256u * 1000u);
  Sector s = testing::makeSector({0, 0}, kMaxProbesPerSector, 0, 3);
  testing::coverProbes(s, 1, 3);
  const std::vector<uint8_t> bytes = encodeSector(s);
  auto d = decodeSector(bytes, "mem");
  ASSERT_TRUE(d.has_value()) << d.error().message;
  EXPECT_LE(d->memoryBytes(), 256u * 1000u);
}

TEST(Sector, SeventyProbesWithoutLprtTakeUnder15KBInMemory) {
  // The talk: "a little under 15KB" per sector with its grid (slide 22). Measured from the heap
  // allocations that decoding makes, plus the Sector object itself.
  const std::vector<uint8_t> bytes = encodeSector(testing::makeSector({0, 0}, 70, 0, 1));
  g_counted_bytes = 0;
  g_counting = true;
  auto s = decodeSector(bytes, "mem");
  g_counting = false;
  ASSERT_TRUE(s.has_value());
  const size_t heap = g_counted_bytes.load();
  EXPECT_EQ(heap + sizeof(Sector), s->memoryBytes());
  EXPECT_LT(s->memoryBytes(), 15000u);
  EXPECT_FALSE(s->hasLprt());
}

TEST(Sector, LprtFor128SourcesCostsTheTalksFigurePerProbe) {
  // 128 sources x 4 x 3 channels x 2 bytes = 3 KiB per probe (~210 KB for ~70 probes), plus a
  // 4-byte entry per source. A sector without local lights carries no LPRT bytes at all.
  const Sector with = testing::makeSector({0, 0}, 70, 128, 1);
  const Sector without = testing::makeSector({0, 0}, 70, 0, 1);
  const size_t extra = encodeSector(with).size() - encodeSector(without).size();
  EXPECT_EQ(extra, 70u * 128 * 4 * 3 * 2 + 128 * 4);
  EXPECT_EQ(with.memoryBytes() - without.memoryBytes(), 70u * 128 * 4 * 3 * 2 + 128 * sizeof(LprtSource));
}

TEST(Sector, GoldenBytesPinVersion1) {
  // If this fails, the format changed: bump kSectorVersion and keep a reader for version 1.
  const std::vector<uint8_t> bytes = encodeSector(testing::makeGoldenSector());
  ASSERT_EQ(bytes.size(), 64u + 2 * 152 + 4096 + 128 + 2 * 4 + 2 * 2 * 12 * 2);
  const uint8_t header[64] = {'D', 'R', 'T', 'S', 1, 0, 64, 0,   3,   0, 0, 0, 0xff, 0xff, 0xff, 0xff,
                              2,   0,   2,   0,   3, 0, 0,  0,   0,   0, 0x48, 0x42, 0, 0, 0x80, 0x3f,
                              0,   0,   0x40, 0x42, 0, 0, 0x80, 0x42};
  EXPECT_EQ(0, std::memcmp(bytes.data(), header, 64));
  EXPECT_EQ(XXH3_64bits(bytes.data(), bytes.size()), testing::kGoldenSectorHash)
      << std::hex << XXH3_64bits(bytes.data(), bytes.size());
}

TEST(SectorReader, RejectsEveryTruncatedPrefix) {
  const std::vector<uint8_t> bytes = encodeSector(testing::makeSector({1, 2}, 20, 16, 3));
  for (size_t n = 0; n < bytes.size(); ++n) {
    auto d = decodeSector(std::span(bytes.data(), n), "s.sec");
    ASSERT_FALSE(d.has_value()) << n;
    EXPECT_EQ(d.error().message.rfind("s.sec: byte ", 0), 0u) << d.error().message;
  }
}

TEST(SectorReader, RejectsTrailingBytes) {
  std::vector<uint8_t> bytes = encodeSector(testing::makeSector({1, 2}, 5, 0, 3));
  bytes.push_back(0);
  auto d = decodeSector(bytes, "s.sec");
  ASSERT_FALSE(d.has_value());
  EXPECT_NE(d.error().message.find("trailing"), std::string::npos) << d.error().message;
}

TEST(SectorReader, SurvivesEveryFlippedByte) {
  // A flip either yields a sector that re-encodes to exactly the flipped bytes (the flip landed
  // in a value with no invalid encodings) or an error naming the file; never a crash.
  const std::vector<uint8_t> bytes = encodeSector(testing::makeSector({1, 2}, 12, 8, 4));
  size_t rejected = 0;
  for (size_t i = 0; i < bytes.size(); ++i) {
    std::vector<uint8_t> flipped = bytes;
    flipped[i] ^= 0x5a;
    auto d = decodeSector(flipped, "s.sec");
    if (d) {
      EXPECT_EQ(encodeSector(*d), flipped) << "byte " << i;
    } else {
      ++rejected;
      EXPECT_EQ(d.error().message.rfind("s.sec: byte ", 0), 0u);
    }
  }
  EXPECT_GT(rejected, 64u);  // at least the whole header's worth is checked
}

TEST(SectorReader, RejectsBadMagicVersionAndAbsurdCounts) {
  const std::vector<uint8_t> good = encodeSector(testing::makeSector({0, 0}, 3, 0, 5));
  auto expectError = [&](size_t at, uint8_t v, const char* says) {
    std::vector<uint8_t> b = good;
    b[at] = v;
    auto d = decodeSector(b, "w/s_0_0.sec");
    ASSERT_FALSE(d.has_value());
    EXPECT_NE(d.error().message.find(says), std::string::npos) << d.error().message;
  };
  expectError(0, 'X', "bad magic");
  expectError(4, 7, "version 7 unsupported");
  expectError(16, 0xff, "");         // 255 probes: the size no longer matches
  expectError(17, 0xff, "exceeds");  // 65,280 probes: rejected before any allocation
  expectError(19, 0xff, "exceeds");  // LPRT sources
  expectError(20, 0x80, "unknown flag");
  auto v = peekSectorVersion(good, "x");
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(*v, kSectorVersion);
}

// A sector with a sun-transfer block of `samples` samples (sector.h SunBlock).
Sector withSun(Sector s, size_t samples) {
  auto sun = std::make_unique<SunBlock>();
  for (size_t k = 0; k < samples; ++k) {
    const float a = float(k) * 0.5f;
    sun->directions.push_back(glm::normalize(glm::vec3(std::cos(a), std::sin(a) * 0.3f, 0.2f + 0.1f * float(k))));
  }
  for (size_t p = 0; p < s.probes.size(); ++p) sun->ranges.push_back(0.01f * float(p + 1));
  for (size_t q = 0; q < s.probes.size() * samples * 12; ++q) sun->coeffs.push_back(int8_t(int(q % 255) - 127));
  s.sun = std::move(sun);
  return s;
}

TEST(Sector, RoundTripsItsSunTransferBitForBit) {
  for (int lprt : {0, 128}) {
    const Sector s = withSun(testing::makeSector({2, 5}, 70, lprt, 3), 6);
    const std::vector<uint8_t> bytes = encodeSector(s);
    // 6 directions and, per probe, a range and 6 x 12 int8: 76 bytes a probe, half the record.
    EXPECT_EQ(bytes.size(), encodedSectorBytes(70, size_t(lprt), true) + 6 * 12 + 70 * 76);
    EXPECT_EQ(bytes.size(), encodedSectorBytes(70, size_t(lprt), true, 6));
    auto d = decodeSector(bytes, "mem");
    ASSERT_TRUE(d.has_value()) << d.error().message;
    ASSERT_TRUE(d->sun);
    EXPECT_EQ(d->sun->directions, s.sun->directions);
    EXPECT_EQ(d->sun->ranges, s.sun->ranges);
    EXPECT_EQ(d->sun->coeffs, s.sun->coeffs);
    EXPECT_EQ(encodeSector(*d), bytes);
  }
  // Without one, nothing is allocated for it and the bytes are version 1's as before.
  auto plain = decodeSector(encodeSector(testing::makeSector({0, 0}, 3, 0, 5)), "mem");
  ASSERT_TRUE(plain.has_value());
  EXPECT_FALSE(plain->sun);
}

TEST(SectorReader, RejectsABadSunTransferNamingTheByte) {
  const std::vector<uint8_t> good = encodeSector(withSun(testing::makeSector({0, 0}, 3, 0, 5), 4));
  const size_t sun_at = good.size() - (4 * 12 + 3 * 4 + 3 * 4 * 12);  // its directions
  auto expectError = [&](const std::function<void(std::vector<uint8_t>&)>& edit, const std::string& says) {
    std::vector<uint8_t> b = good;
    edit(b);
    auto d = decodeSector(b, "w.drtv: sector (0,0)");
    ASSERT_FALSE(d.has_value()) << says;
    EXPECT_NE(d.error().message.find(says), std::string::npos) << d.error().message;
  };
  expectError([](std::vector<uint8_t>& b) { b[40] = 9; }, "byte 40: sun sample count 9 exceeds 8");
  expectError([](std::vector<uint8_t>& b) { b[40] = 3; }, "trailing bytes");
  expectError([&](std::vector<uint8_t>& b) {
    const float twice = 2.f;
    std::memcpy(&b[sun_at + 12], &twice, 4);  // sample 1's x: no longer a unit vector
  }, "byte " + std::to_string(sun_at + 12) + ": sun sample 1: not a unit vector");
  expectError([&](std::vector<uint8_t>& b) {
    const float nan = NAN;
    std::memcpy(&b[sun_at + 48 + 4], &nan, 4);  // probe 1's range
  }, "probe 1: sun-transfer range");
  expectError([&](std::vector<uint8_t>& b) { b[b.size() - 1] = 0x80; }, "sun-transfer coefficient -128 is never written");
  // The byte named is the first -128, wherever it lies (the check is a reduction, then a search).
  const size_t coeff_at = good.size() - 3 * 4 * 12;
  expectError([&](std::vector<uint8_t>& b) { b[coeff_at + 70] = 0x80, b[coeff_at + 17] = 0x80; },
              "byte " + std::to_string(coeff_at + 17) + ": sun-transfer coefficient -128");
}

TEST(SectorReader, RejectsGridIndicesPastTheProbeCount) {
  Sector s = testing::makeSector({0, 0}, 3, 0, 5);
  std::vector<uint8_t> b = encodeSector(s);
  b[64 + 3 * 152 + 100] = 3;  // probe 3 of 3
  auto d = decodeSector(b, "s");
  ASSERT_FALSE(d.has_value());
  EXPECT_NE(d.error().message.find("byte " + std::to_string(64 + 3 * 152 + 100)), std::string::npos);
}

TEST(SectorKey, SectorAtFloorsNegativeCoordinates) {
  EXPECT_EQ(sectorAt(0.0, 0.0), (SectorKey{0, 0}));
  EXPECT_EQ(sectorAt(-0.5, 63.9), (SectorKey{-1, 0}));
  EXPECT_EQ(sectorAt(128.0, -64.0), (SectorKey{2, -1}));
  EXPECT_EQ(toString(SectorKey{3, -1}), "(3,-1)");
  EXPECT_EQ(sectorAt(1e300, -1e300), (SectorKey{INT32_MAX, INT32_MIN}));
  EXPECT_EQ(sectorAt(NAN, 0.0), (SectorKey{0, 0}));
}

}  // namespace
}  // namespace drtv
