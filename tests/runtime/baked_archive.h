// A world baked to a real .drtv archive and read back, and a runtime for it as `drtv query` sets
// one up: what the shader-run tests compare the shaders on (shader_run_test.cpp,
// fine_shader_run_test.cpp). Test code only.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "drtv/baker/bake.h"
#include "drtv/formats/archive.h"
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

}  // namespace drtv::testing
