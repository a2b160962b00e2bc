// Archive: round trip, per-sector reads, atomic publish, and untrusted-input safety.
#include <cstring>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <xxhash.h>

#include "drtv/formats/archive.h"
#include "test_sectors.h"

namespace drtv {
namespace {

namespace fs = std::filesystem;

std::vector<uint8_t> readFile(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}
void writeFile(const fs::path& p, std::span<const uint8_t> b) {
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

class ArchiveTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("drtv_archive_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Writes an archive of 6 sectors around the origin; returns its path.
  fs::path writeSample(const char* name = "w.drtv") {
    const fs::path path = dir_ / name;
    auto w = ArchiveWriter::create(path);
    EXPECT_TRUE(w.has_value()) << w.error().message;
    for (int iy = -1; iy <= 0; ++iy)
      for (int ix = -1; ix <= 1; ++ix) {
        sectors_.push_back(testing::makeSector({ix, iy}, 10 + ix * 3 + iy, ix == 1 ? 8 : 0, uint32_t(ix * 7 + iy)));
        if (ix == 0) testing::coverProbes(sectors_.back(), 3, uint32_t(5 - iy));  // visibility maps (sector.h)
        auto ok = w->addSector(sectors_.back());
        EXPECT_TRUE(ok.has_value()) << ok.error().message;
      }
    Manifest m;
    m.bounds_min = {-64, -64, 0};
    m.bounds_max = {128, 64, 40};
    m.effects = kEffectSunBounce | kEffectSkyBounce | kEffectDirectSky | kEffectLocalLights;
    m.settings = {{"quality", "default"}, {"seed", "1"}};
    auto ok = w->finish(m);
    EXPECT_TRUE(ok.has_value()) << ok.error().message;
    return path;
  }

  fs::path dir_;
  std::vector<Sector> sectors_;
};

TEST_F(ArchiveTest, RoundTripsManifestAndEverySector) {
  const fs::path path = writeSample();
  auto r = ArchiveReader::open(path);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  const Manifest& m = r->manifest();
  EXPECT_EQ(m.sectors.size(), 6u);
  EXPECT_EQ(m.sector_size_m, 64.0);
  EXPECT_EQ(m.setting("quality"), "default");
  EXPECT_EQ(m.bounds_max, glm::dvec3(128, 64, 40));
  EXPECT_TRUE(m.effects & kEffectLocalLights);
  for (const Sector& s : sectors_) {
    auto got = r->readSector(s.key);
    ASSERT_TRUE(got.has_value()) << got.error().message;
    EXPECT_EQ(encodeSector(*got), encodeSector(s));
    EXPECT_EQ(m.find(s.key)->probes, s.probes.size());
    EXPECT_EQ(m.find(s.key)->covered, coveredProbes(s));
    EXPECT_EQ(got->visibility ? got->visibility->values : std::vector<uint8_t>{},
              s.visibility ? s.visibility->values : std::vector<uint8_t>{});
  }
  auto missing = r->readSector({5, 5});
  ASSERT_FALSE(missing.has_value());
  EXPECT_NE(missing.error().message.find("sector (5,5): not in this archive"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "w.drtv.partial"));
}

TEST_F(ArchiveTest, ReadsOneSectorWithoutTouchingTheOthers) {
  const fs::path path = writeSample();
  std::vector<uint8_t> bytes = readFile(path);
  auto r0 = ArchiveReader::open(path);
  ASSERT_TRUE(r0.has_value());
  // Destroy every payload byte of sector (0,0); all others still read.
  const SectorEntry* e = r0->manifest().find({0, 0});
  std::memset(bytes.data() + e->offset, 0xee, e->compressed_bytes);
  writeFile(path, bytes);
  auto r = ArchiveReader::open(path);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  for (const Sector& s : sectors_) {
    auto got = r->readSector(s.key);
    if (s.key == SectorKey{0, 0}) {
      ASSERT_FALSE(got.has_value());
      EXPECT_NE(got.error().message.find("w.drtv: sector (0,0): byte " + std::to_string(e->offset) + ": payload hash mismatch"),
                std::string::npos)
          << got.error().message;
    } else {
      EXPECT_TRUE(got.has_value()) << got.error().message;
    }
  }
}

TEST_F(ArchiveTest, EveryTruncatedPrefixIsRejected) {
  const std::vector<uint8_t> bytes = readFile(writeSample());
  for (size_t n = 0; n < bytes.size(); ++n) {
    auto m = decodeArchiveHeaderAndManifest(std::span(bytes.data(), n), "w.drtv");
    ASSERT_FALSE(m.has_value()) << n;
    EXPECT_EQ(m.error().message.rfind("w.drtv: byte ", 0), 0u) << m.error().message;
  }
  // And through the file reader, at a spread of lengths.
  for (size_t n : {size_t(0), size_t(7), size_t(63), size_t(64), bytes.size() / 2, bytes.size() - 1}) {
    writeFile(dir_ / "t.drtv", std::span(bytes.data(), n));
    auto r = ArchiveReader::open(dir_ / "t.drtv");
    ASSERT_FALSE(r.has_value()) << n;
    EXPECT_NE(r.error().message.find("t.drtv"), std::string::npos);
  }
}

// What a reader that fetches the header and the manifest apart (the HTTP source) runs: the same
// manifest as open(), and a manifest cut short or one byte off refused, naming the file offset.
TEST_F(ArchiveTest, TheHeaderAndManifestDecodedApartGiveOpensManifest) {
  const fs::path path = writeSample();
  const std::vector<uint8_t> bytes = readFile(path);
  auto header = decodeArchiveHeader(std::span(bytes.data(), kArchiveHeaderBytes), bytes.size(), "w.drtv");
  ASSERT_TRUE(header.has_value()) << header.error().message;
  EXPECT_EQ(header->file_bytes, bytes.size());
  EXPECT_EQ(header->manifest_offset + header->manifest_bytes, bytes.size());
  const auto manifest_bytes = std::span(bytes).subspan(header->manifest_offset);
  auto m = decodeArchiveManifest(*header, manifest_bytes, "w.drtv");
  ASSERT_TRUE(m.has_value()) << m.error().message;
  auto r = ArchiveReader::open(path);
  ASSERT_TRUE(r.has_value());
  ASSERT_EQ(m->sectors.size(), r->manifest().sectors.size());
  for (size_t i = 0; i < m->sectors.size(); ++i) {
    EXPECT_EQ(m->sectors[i].key, r->manifest().sectors[i].key);
    EXPECT_EQ(m->sectors[i].offset, r->manifest().sectors[i].offset);
    EXPECT_EQ(m->sectors[i].hash, r->manifest().sectors[i].hash);
  }
  EXPECT_EQ(m->settings, r->manifest().settings);

  // A file size other than the header's (a server's Content-Range total): refused at byte 40.
  auto other = decodeArchiveHeader(std::span(bytes.data(), kArchiveHeaderBytes), bytes.size() + 1, "w.drtv");
  ASSERT_FALSE(other.has_value());
  EXPECT_EQ(other.error().message.rfind("w.drtv: byte 40: ", 0), 0u) << other.error().message;
  // A manifest body cut short (a server that closed early).
  auto short_body = decodeArchiveManifest(*header, manifest_bytes.first(manifest_bytes.size() - 1), "w.drtv");
  ASSERT_FALSE(short_body.has_value());
  EXPECT_NE(short_body.error().message.find("manifest truncated"), std::string::npos) << short_body.error().message;
  // One byte flipped in it.
  std::vector<uint8_t> flipped(manifest_bytes.begin(), manifest_bytes.end());
  flipped[flipped.size() / 2] ^= 1;
  auto bad = decodeArchiveManifest(*header, flipped, "w.drtv");
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().message, "w.drtv: byte " + std::to_string(header->manifest_offset) + ": manifest hash mismatch (corrupt)");
}

TEST_F(ArchiveTest, EveryFlippedByteIsDetected) {
  const fs::path path = writeSample();
  const std::vector<uint8_t> bytes = readFile(path);
  for (size_t i = 0; i < bytes.size(); ++i) {
    std::vector<uint8_t> flipped = bytes;
    flipped[i] ^= 0x01;
    writeFile(path, flipped);
    auto r = ArchiveReader::open(path);
    bool detected = !r.has_value();
    if (!detected)
      for (const Sector& s : sectors_)
        if (!r->readSector(s.key).has_value()) detected = true;
    ASSERT_TRUE(detected) << "flip at byte " << i << " went unnoticed";
  }
}

// Rewrites the manifest and reseals the header (sizes and hash) so that only the manifest's own
// checks stand between a forged count and the reader.
std::vector<uint8_t> forgeManifest(std::vector<uint8_t> file, size_t manifest_offset, const std::vector<uint8_t>& manifest) {
  file.resize(manifest_offset);
  file.insert(file.end(), manifest.begin(), manifest.end());
  const uint64_t size = manifest.size(), hash = XXH3_64bits(manifest.data(), manifest.size()), total = file.size();
  std::memcpy(file.data() + 24, &size, 8);
  std::memcpy(file.data() + 32, &hash, 8);
  std::memcpy(file.data() + 40, &total, 8);
  return file;
}

// The representation (representation.h): fc3 archives stay version 1 without the field (their
// bytes are those of every earlier build); others are version 2 with it; a code this build does
// not know is refused with the option to rebake with.
TEST_F(ArchiveTest, StoresTheRepresentationAsVersion2AndRefusesAnUnknownOne) {
  const fs::path fc3 = writeSample("fc3.drtv");
  EXPECT_EQ(*peekArchiveVersion(fc3), kArchiveVersionTalkBasis);
  EXPECT_EQ(ArchiveReader::open(fc3)->manifest().representation, Representation::kFc3);

  const fs::path path = dir_ / "shl1.drtv";
  {
    auto w = ArchiveWriter::create(path);
    ASSERT_TRUE(w.has_value());
    ASSERT_TRUE(w->addSector(testing::makeSector({0, 0}, 5, 0, 3)).has_value());
    Manifest m;
    m.bounds_max = {64, 64, 10};
    m.effects = kEffectSunBounce | kEffectSkyBounce;
    m.representation = Representation::kShL1;
    ASSERT_TRUE(w->finish(m).has_value());
  }
  EXPECT_EQ(*peekArchiveVersion(path), kArchiveVersion);
  auto r = ArchiveReader::open(path);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  EXPECT_EQ(r->manifest().representation, Representation::kShL1);
  EXPECT_EQ(r->manifest().version, kArchiveVersion);

  std::vector<uint8_t> file = readFile(path);
  uint64_t manifest_offset = 0;
  std::memcpy(&manifest_offset, file.data() + 16, 8);
  std::vector<uint8_t> manifest(file.begin() + ptrdiff_t(manifest_offset), file.end());
  const size_t code_at = 6 * 8 + 8 + 4;  // bounds, sector size, effects
  uint32_t code = 0;
  std::memcpy(&code, manifest.data() + code_at, 4);
  ASSERT_EQ(code, uint32_t(Representation::kShL1));
  code = 9;
  std::memcpy(manifest.data() + code_at, &code, 4);
  writeFile(path, forgeManifest(file, manifest_offset, manifest));
  auto bad = ArchiveReader::open(path);
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("representation 9 unknown"), std::string::npos) << bad.error().message;
  EXPECT_NE(bad.error().message.find("rebake"), std::string::npos) << bad.error().message;
}

TEST_F(ArchiveTest, AbsurdCountsAreRejectedBeforeAllocating) {
  const fs::path path = writeSample();
  const std::vector<uint8_t> bytes = readFile(path);
  uint64_t moff = 0;
  std::memcpy(&moff, bytes.data() + 16, 8);
  std::vector<uint8_t> manifest(bytes.begin() + long(moff), bytes.end());
  const size_t settings_count_at = 6 * 8 + 8 + 4;
  {
    std::vector<uint8_t> m = manifest;
    const uint32_t absurd = 0xffffffffu;
    std::memcpy(m.data() + settings_count_at, &absurd, 4);
    auto got = decodeArchiveHeaderAndManifest(forgeManifest(bytes, moff, m), "f.drtv");
    ASSERT_FALSE(got.has_value());
    EXPECT_NE(got.error().message.find("settings count 4294967295 is absurd"), std::string::npos) << got.error().message;
  }
  {
    std::vector<uint8_t> m = manifest;
    const size_t count_at = m.size() - 6 * kArchiveSectorEntryBytes - 4;
    const uint32_t absurd = 0x7fffffffu;
    std::memcpy(m.data() + count_at, &absurd, 4);
    auto got = decodeArchiveHeaderAndManifest(forgeManifest(bytes, moff, m), "f.drtv");
    ASSERT_FALSE(got.has_value());
    EXPECT_NE(got.error().message.find("byte " + std::to_string(moff + count_at) + ": sector count"), std::string::npos)
        << got.error().message;
  }
  {
    // A payload offset pointing past the payload area.
    std::vector<uint8_t> m = manifest;
    const size_t entry0 = m.size() - 6 * kArchiveSectorEntryBytes;
    const uint64_t far = 1ull << 40;
    std::memcpy(m.data() + entry0 + 8, &far, 8);
    auto got = decodeArchiveHeaderAndManifest(forgeManifest(bytes, moff, m), "f.drtv");
    ASSERT_FALSE(got.has_value());
    EXPECT_NE(got.error().message.find("outside the payload area"), std::string::npos) << got.error().message;
  }
}

TEST_F(ArchiveTest, RejectsBadMagicAndVersionAndMissingFiles) {
  const fs::path path = writeSample();
  std::vector<uint8_t> bytes = readFile(path);
  auto v = peekArchiveVersion(path);
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(*v, kArchiveVersionTalkBasis);
  bytes[8] = 9;
  writeFile(path, bytes);
  auto r = ArchiveReader::open(path);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("w.drtv: byte 8: version 9 unsupported"), std::string::npos) << r.error().message;
  bytes[0] = 'X';
  writeFile(path, bytes);
  r = ArchiveReader::open(path);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("bad magic"), std::string::npos);
  r = ArchiveReader::open(dir_ / "nope.drtv");
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("nope.drtv: cannot open"), std::string::npos);
}

TEST_F(ArchiveTest, AnUnfinishedWriterLeavesNoFileAndKeepsTheOldOne) {
  const fs::path path = writeSample();
  const std::vector<uint8_t> before = readFile(path);
  {
    auto w = ArchiveWriter::create(path);
    ASSERT_TRUE(w.has_value());
    ASSERT_TRUE(w->addSector(testing::makeSector({9, 9}, 4, 0, 1)).has_value());
    EXPECT_TRUE(fs::exists(dir_ / "w.drtv.partial"));
    // Dropped without finish(): an interrupted bake.
  }
  EXPECT_FALSE(fs::exists(dir_ / "w.drtv.partial"));
  EXPECT_EQ(readFile(path), before);
}

TEST_F(ArchiveTest, AddingASectorTwiceIsAnError) {
  auto w = ArchiveWriter::create(dir_ / "d.drtv");
  ASSERT_TRUE(w.has_value());
  const Sector s = testing::makeSector({1, 1}, 4, 0, 1);
  ASSERT_TRUE(w->addSector(s).has_value());
  auto again = w->addSector(s);
  ASSERT_FALSE(again.has_value());
  EXPECT_NE(again.error().message.find("sector (1,1) added twice"), std::string::npos);
}

// Run with DRTV_WRITE_GOLDEN=1 to regenerate the file after a deliberate version bump.
void writeGoldenArchive(const fs::path& path) {
  auto w = ArchiveWriter::create(path, 19);
  ASSERT_TRUE(w.has_value());
  ASSERT_TRUE(w->addSector(testing::makeGoldenSector()).has_value());
  Manifest m;
  m.bounds_min = {192, -64, 48};
  m.bounds_max = {256, 0, 64};
  m.effects = kEffectSunBounce | kEffectLocalLights;
  m.settings = {{"written_by", "drtv formats golden test"}};
  ASSERT_TRUE(w->finish(m).has_value());
}

TEST(ArchiveGolden, ReadsTheCheckedInVersion1Archive) {
  if (std::getenv("DRTV_WRITE_GOLDEN")) writeGoldenArchive(fs::path(DRTV_SOURCE_DIR) / "tests/formats/data/golden_v1.drtv");
  // tests/formats/data/golden_v1.drtv was written by this code at format version 1 (zstd 1.5.4).
  // Reading it pins the container layout; the sector inside must equal the golden sector.
  auto r = ArchiveReader::open(fs::path(DRTV_SOURCE_DIR) / "tests/formats/data/golden_v1.drtv");
  ASSERT_TRUE(r.has_value()) << r.error().message;
  EXPECT_EQ(r->manifest().setting("written_by"), "drtv formats golden test");
  EXPECT_EQ(r->manifest().effects, uint32_t(kEffectSunBounce | kEffectLocalLights));
  auto s = r->readSector({3, -1});
  ASSERT_TRUE(s.has_value()) << s.error().message;
  EXPECT_EQ(encodeSector(*s), encodeSector(testing::makeGoldenSector()));
}

}  // namespace
}  // namespace drtv
