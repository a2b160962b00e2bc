// `drtv export-vdb` (vdb.h): the grids read back with OpenVDB hold what the archive holds.
#include <unistd.h>
#include <gtest/gtest.h>

#include <openvdb/openvdb.h>

#include <cmath>
#include <filesystem>

#include "baked_world.h"
#include "drtv/eval/vdb.h"
#include "drtv/worlds/load.h"

namespace drtv::baker {
using namespace eval;
namespace {

TEST(ExportVdb, WritesGridsThatReadBackWithTheArchivesProbesAndFiniteLight) {
  const auto world = worlds::loadWorld(DRTV_SOURCE_DIR "/worlds/fc3_testbox.json");
  ASSERT_TRUE(world.has_value());
  auto baked = bakeInMemory(*world, "fc3_testbox", BakeSettings::forQuality(Quality::kDraft, 1));
  ASSERT_TRUE(baked.has_value());
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("drtv_vdb_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  auto writer = ArchiveWriter::create(dir / "box.drtv");
  ASSERT_TRUE(writer.has_value());
  for (const Sector& s : baked->sectors) ASSERT_TRUE(writer->addSector(s).has_value());
  ASSERT_TRUE(writer->finish(baked->manifest).has_value());

  auto stats = exportVdb(dir / "box.drtv", dir / "box.vdb", VdbExportOptions{9.0, 4.0});
  ASSERT_TRUE(stats.has_value()) << stats.error().message;
  EXPECT_EQ(stats->probes, baked->probes);

  openvdb::initialize();
  openvdb::io::File file((dir / "box.vdb").string());
  file.open();
  auto sky = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("sky_visibility"));
  auto density = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("probe_density"));
  auto irradiance = openvdb::gridPtrCast<openvdb::Vec3SGrid>(file.readGrid("irradiance"));
  file.close();
  ASSERT_TRUE(sky && density && irradiance);
  EXPECT_EQ(sky->activeVoxelCount(), stats->active_voxels);
  EXPECT_GT(sky->activeVoxelCount(), 0u);
  for (auto it = sky->cbeginValueOn(); it; ++it) {
    EXPECT_GE(*it, 0.f);
    EXPECT_LE(*it, 1.f);
  }
  double probes = 0;
  for (auto it = density->cbeginValueOn(); it; ++it) probes += *it;
  EXPECT_EQ(probes, double(baked->probes));
  bool some_light = false;
  for (auto it = irradiance->cbeginValueOn(); it; ++it)
    for (int c = 0; c < 3; ++c) {
      EXPECT_TRUE(std::isfinite((*it)[c]) && (*it)[c] >= 0.f);
      some_light = some_light || (*it)[c] > 0.f;
    }
  EXPECT_TRUE(some_light);
  // Voxel (i, j, k) sits at the centre of index-grid cell column (i, j): 4 m + 2 m.
  const openvdb::Vec3d p = sky->transform().indexToWorld(openvdb::Coord(-3, 5, 0));
  EXPECT_DOUBLE_EQ(p.x(), -10.0);
  EXPECT_DOUBLE_EQ(p.y(), 22.0);
  EXPECT_DOUBLE_EQ(p.z(), 2.0);
  EXPECT_EQ(sky->metaValue<std::string>("drtv_units"), "metres");
  std::filesystem::remove_all(dir);
}

TEST(ExportVdb, RefusesVoxelsTooThinToBeAGrid) {
  VdbExportOptions o;
  o.voxel_height_m = 1e-300;
  auto r = exportVdb("/nonexistent/box.drtv", "/tmp/never.vdb", o);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("--voxel-height"), std::string::npos) << r.error().message;
}

TEST(ExportVdb, NamesTheArchiveWhenItCannotBeRead) {
  auto r = exportVdb("/nonexistent/box.drtv", "/tmp/never.vdb");
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("/nonexistent/box.drtv"), std::string::npos);
}

}  // namespace
}  // namespace drtv::baker
