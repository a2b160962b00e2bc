// make_seeds.cpp — writes the sector and archive seeds of fuzz/corpus/ with drtv's own encoder
// and writer, so that the fuzzers start from real, valid bytes of every shape the format has
// (no probes; probes with and without a ground map; LPRT on bases and as SH; archives with
// several sectors, settings, lights and interiors).
//
// Usage: drtv_fuzz_make_seeds <corpus dir>   (writes <dir>/sector/*.sec and <dir>/archive/*.drtv)
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "drtv/formats/archive.h"
#include "drtv/formats/sector.h"
#include "test_sectors.h"

namespace {

bool writeFile(const std::filesystem::path& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  return bool(out);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: drtv_fuzz_make_seeds <corpus dir>\n");
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  std::filesystem::create_directories(dir / "sector");
  std::filesystem::create_directories(dir / "archive");
  using drtv::testing::makeSector;

  drtv::Sector empty;
  empty.key = {0, 0};
  drtv::Sector no_ground = makeSector({-2, 5}, 3, 0, 11);
  no_ground.has_ground = false;
  drtv::Sector sh_lprt = makeSector({7, -7}, 2, 3, 12);
  sh_lprt.lprt_on_bases = false;
  // sh-l1 of archive version 3: a 6-sample sun transfer (sector.h SunBlock), so that the decoder's
  // sun branch is in the corpus, not only reached by growing a sector and mutating byte 40.
  drtv::Sector sun = makeSector({3, -2}, 5, 0, 14);
  sun.lprt_on_bases = false;
  {
    auto block = std::make_unique<drtv::SunBlock>();
    for (int k = 0; k < 6; ++k) {
      const float a = 3.14159265f * (float(k) + 0.5f) / 6.f;  // sunrise to sunset, east to west
      block->directions.push_back(glm::normalize(glm::vec3(std::cos(a), 0.2f, std::sin(a))));
    }
    for (size_t i = 0; i < sun.probes.size(); ++i) block->ranges.push_back(0.25f + 0.1f * float(i));
    block->coeffs.resize(sun.probes.size() * 6 * 12);
    for (size_t q = 0; q < block->coeffs.size(); ++q) block->coeffs[q] = int8_t(int(q * 37 % 255) - 127);
    sun.sun = std::move(block);
  }
  const std::vector<std::pair<std::string, drtv::Sector>> sectors = {
      {"sun_transfer_six_samples", sun},
      {"empty", empty},
      {"three_probes_no_ground", no_ground},
      {"four_probes_ground", makeSector({1, 1}, 4, 0, 13)},
      {"golden_lprt", drtv::testing::makeGoldenSector()},
      {"lprt_sh", sh_lprt},
  };
  for (const auto& [name, sector] : sectors)
    if (!writeFile(dir / "sector" / (name + ".sec"), drtv::encodeSector(sector))) return 1;

  drtv::Manifest m;
  m.bounds_min = {-128, -64, -10};
  m.bounds_max = {128, 64, 90};
  m.effects = 0x7f;
  m.settings = {{"quality", "draft"}, {"threads", "2"}};
  m.lights = {{"lamp", {10, 20, 3}, {5, 4, 3}, 12.f}};
  m.interiors = {{"hut", {0, 0, 0}, {4, 4, 3}, {2, 2, 1.5}, 1.f}};
  struct ArchiveSeed {
    std::string name;
    std::vector<drtv::Sector> sectors;
  };
  const std::vector<ArchiveSeed> archives = {
      {"no_sectors", {}},
      {"one_sector", {makeSector({0, 0}, 2, 0, 21)}},
      {"three_sectors_lprt", {makeSector({-1, 0}, 1, 0, 22), makeSector({0, 0}, 2, 2, 23), makeSector({0, 1}, 0, 0, 24)}},
  };
  for (const ArchiveSeed& a : archives) {
    const std::filesystem::path path = dir / "archive" / (a.name + ".drtv");
    auto w = drtv::ArchiveWriter::create(path, 1);
    if (!w) return std::fprintf(stderr, "%s\n", w.error().message.c_str()), 1;
    for (const drtv::Sector& s : a.sectors)
      if (auto ok = w->addSector(s); !ok) return std::fprintf(stderr, "%s\n", ok.error().message.c_str()), 1;
    if (auto ok = w->finish(m); !ok) return std::fprintf(stderr, "%s\n", ok.error().message.c_str()), 1;
  }
  return 0;
}
