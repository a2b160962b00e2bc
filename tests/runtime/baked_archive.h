// A world baked to a real .drtv archive and read back, and a runtime for it as `drtv query` sets
// one up: what the shader-run tests compare the shaders on (shader_run_test.cpp,
// fine_shader_run_test.cpp). Test code only.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "drtv/baker/bake.h"
#include "drtv/formats/archive.h"
#include "drtv/formats/representation.h"
#include "drtv/runtime/runtime.h"
#include "drtv/worlds/world.h"

namespace drtv::testing {

struct BakedArchive {
  Manifest manifest;
  std::vector<Sector> sectors;
};

// `world` baked by baker::bake with `options` into an archive in a temporary directory, read back
// with ArchiveReader, the directory removed. Failures are the test's (empty sectors then).
inline BakedArchive bakeArchive(const worlds::World& world, const std::string& name, const baker::BakeOptions& options) {
  namespace fs = std::filesystem;
  BakedArchive b;
  const fs::path dir = fs::temp_directory_path() / ("drtv_baked_archive_" + name + "_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto report = baker::bake(world, name, dir / (name + ".drtv"), options);
  EXPECT_TRUE(report.has_value()) << (report ? "" : report.error().message);
  if (report) {
    auto reader = ArchiveReader::open(dir / (name + ".drtv"));
    EXPECT_TRUE(reader.has_value()) << (reader ? "" : reader.error().message);
    if (reader) {
      b.manifest = reader->manifest();
      for (const SectorEntry& e : b.manifest.sectors) {
        auto s = reader->readSector(e.key);
        EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().message);
        if (s) b.sectors.push_back(std::move(*s));
      }
    }
  }
  fs::remove_all(dir);
  return b;
}

// A runtime for the archive as `drtv query` builds one (`options`, else what the manifest's effects
// ask for), every sector added, lit at `hour`, its volume on `camera`.
inline std::unique_ptr<runtime::Runtime> relitArchive(const BakedArchive& b, double hour, const glm::dvec3& camera,
                                                      std::optional<runtime::RuntimeOptions> options = std::nullopt) {
  auto made = runtime::runtimeForArchive(b.manifest, options ? *options : runtime::optionsForEffects(b.manifest.effects), hour);
  EXPECT_TRUE(made.has_value());
  if (!made) return nullptr;
  std::unique_ptr<runtime::Runtime> rt = std::move(*made);
  for (const Sector& s : b.sectors) EXPECT_TRUE(rt->addSector(s).has_value());
  rt->update(camera);
  return rt;
}

// One bake per representation, made on first use and kept for the test program's life: the
// shader-run tests bake each world once for all their cases. Each test keeps its own (a static).
class BakedPerRepresentation {
 public:
  using Bake = BakedArchive (*)(Representation);
  explicit BakedPerRepresentation(Bake bake) : bake_(bake) {}
  const BakedArchive& operator()(Representation r) {
    std::optional<BakedArchive>& b = baked_[size_t(r)];
    if (!b) b = bake_(r);
    return *b;
  }

 private:
  Bake bake_;
  std::array<std::optional<BakedArchive>, kRepresentationCount> baked_;
};

// A unit normal drawn uniformly on the sphere: z, then the azimuth, from `u` (two draws, in that
// order, so that a test's points stay what they were).
template <class Rng>
glm::vec3 randomUnitNormal(Rng& rng, std::uniform_real_distribution<double>& u) {
  const double z = 2.0 * u(rng) - 1.0, phi = 2.0 * M_PI * u(rng), r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return glm::normalize(glm::vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)));
}

}  // namespace drtv::testing
