// Synthetic archives and fake sinks for the streamer tests.
#pragma once

#include <algorithm>
#include <filesystem>
#include <random>
#include <string>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>

#include "drtv/formats/archive.h"
#include "drtv/streamer/streamer.h"
#include "test_sectors.h"  // makeSector

namespace drtv::testing {

struct WorldSpec {
  int sectors_x = 16, sectors_y = 16;  // 16 x 16 = 1 km^2
  int min_probes = 66, max_probes = 74;  // about 70 (talk slide 24), mean 70
  int lprt_sources = 0;
  std::vector<SectorKey> holes;          // keys left out (sea)
};

// Writes a world of spec.sectors_x x spec.sectors_y sectors from key (0, 0) to `path`.
inline Manifest writeWorld(const std::filesystem::path& path, const WorldSpec& spec = {}) {
  auto w = ArchiveWriter::create(path, 1);
  EXPECT_TRUE(w.has_value()) << w.error().message;
  uint32_t seed = 1;
  for (int ix = 0; ix < spec.sectors_x; ++ix)
    for (int iy = 0; iy < spec.sectors_y; ++iy) {
      if (std::find(spec.holes.begin(), spec.holes.end(), SectorKey{ix, iy}) != spec.holes.end()) continue;
      const int probes = spec.min_probes + int(seed * 2654435761u % uint32_t(spec.max_probes - spec.min_probes + 1));
      auto ok = w->addSector(makeSector({ix, iy}, probes, spec.lprt_sources, seed++));
      EXPECT_TRUE(ok.has_value()) << ok.error().message;
    }
  Manifest m;
  m.bounds_min = {0, 0, 0};
  m.bounds_max = {64.0 * spec.sectors_x, 64.0 * spec.sectors_y, 60};
  m.effects = kEffectSunBounce | kEffectSkyBounce | kEffectDirectSky | kEffectDistantOcclusion |
              (spec.lprt_sources ? uint32_t(kEffectLocalLights) : 0u);
  auto ok = w->finish(m);
  EXPECT_TRUE(ok.has_value()) << ok.error().message;
  auto r = ArchiveReader::open(path);
  EXPECT_TRUE(r.has_value()) << r.error().message;
  return r->manifest();
}

// A temporary directory per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    // A parameterised test's name holds a '/' ("Name/param"): one folder, or removing it would
    // leave its parent behind.
    std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::replace(name.begin(), name.end(), '/', '_');
    path_ = std::filesystem::temp_directory_path() / ("drtv_streamer_test_" + std::to_string(::getpid()) + "_" + name);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// A sink that checks the hand-off contract: every load is of a sector not already held, every
// eviction of a held one, the references stay valid until eviction. Allocates only up front.
class CheckingSink : public streamer::SectorSink {
 public:
  CheckingSink() { held_.reserve(256); }
  void onSectorLoaded(const Sector& sector, const runtime::OcclusionTile& tile) override {
    EXPECT_EQ(sector.key, tile.key);
    EXPECT_EQ(find(sector.key), held_.end()) << "loaded twice: " << toString(sector.key);
    held_.push_back({sector.key, &sector, &tile, sector.probes.size()});
    ++loads;
  }
  void onSectorEvicted(SectorKey key) override {
    auto it = find(key);
    ASSERT_NE(it, held_.end()) << "evicted without a load: " << toString(key);
    // The sector must still be intact while we are told about it.
    EXPECT_EQ(it->sector->key, key);
    EXPECT_EQ(it->sector->probes.size(), it->probes);
    EXPECT_EQ(it->tile->key, key);
    held_.erase(it);
    ++evictions;
  }
  void onSectorFailed(SectorKey key, const Error& error) override {
    ++failures;
    last_error = error.message;
  }
  size_t held() const { return held_.size(); }
  bool holds(SectorKey key) { return find(key) != held_.end(); }

  int loads = 0, evictions = 0, failures = 0;
  std::string last_error;

 private:
  struct Held {
    SectorKey key;
    const Sector* sector;
    const runtime::OcclusionTile* tile;
    size_t probes;
  };
  std::vector<Held>::iterator find(SectorKey key) {
    return std::find_if(held_.begin(), held_.end(), [&](const Held& h) { return h.key == key; });
  }
  std::vector<Held> held_;
};

}  // namespace drtv::testing
