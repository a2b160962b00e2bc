// The OpenVDB export. See vdb.h for the grids and references [1], [2].
#include "drtv/eval/vdb.h"

#include <openvdb/openvdb.h>

#include <cmath>
#include <mutex>

#include "drtv/formats/archive.h"
#include "drtv/formats/sh.h"
#include "render_support.h"

namespace drtv::eval {

namespace {
// Thinner voxels than 1 cm say nothing the 16 index-grid layers do not; more than 4096 layers in
// one sector's column is a grid no tool wants (and bounds the work per sector).
constexpr double kMinVoxelHeightM = 0.01;
constexpr int kMaxVoxelLayersPerSector = 4096;
}  // namespace

Result<VdbExportStats> exportVdb(const std::filesystem::path& archive, const std::filesystem::path& output,
                                 const VdbExportOptions& options) {
  if (!std::isfinite(options.hour)) return fail("--time: not a finite hour");
  if (!(options.voxel_height_m >= kMinVoxelHeightM) || !std::isfinite(options.voxel_height_m))
    return fail("--voxel-height: must be a finite number >= " + std::to_string(kMinVoxelHeightM) + " m");
  auto reader = ArchiveReader::open(archive);
  if (!reader) return std::unexpected(reader.error());
  const Manifest& m = reader->manifest();
  std::vector<Sector> sectors;
  for (const SectorEntry& e : m.sectors) {
    auto s = reader->readSector(e.key);
    if (!s) return std::unexpected(s.error());
    sectors.push_back(std::move(*s));
  }
  runtime::RuntimeOptions ro = detail::runtimeOptionsFor(m.effects, false);
  auto rt = runtime::runtimeForSectors(m, ro, options.hour, sectors);
  if (!rt) return std::unexpected(rt.error().context(archive.string()));
  (*rt)->update(glm::dvec3(0.0));
  const runtime::ProbeCache& cache = (*rt)->cache();

  static std::once_flag init;
  std::call_once(init, [] { openvdb::initialize(); });
  const double cell = kGridCellSizeM, h = options.voxel_height_m;
  openvdb::math::Mat4d mat = openvdb::math::Mat4d::identity();
  mat.preScale(openvdb::Vec3d(cell, cell, h));
  mat.postTranslate(openvdb::Vec3d(cell / 2, cell / 2, h / 2));
  const openvdb::math::Transform::Ptr xform = openvdb::math::Transform::createLinearTransform(mat);
  auto sky = openvdb::FloatGrid::create(0.f);
  auto density = openvdb::FloatGrid::create(0.f);
  auto irradiance = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.f));
  auto sky_acc = sky->getAccessor();
  auto den_acc = density->getAccessor();
  auto irr_acc = irradiance->getAccessor();
  VdbExportStats stats;
  stats.sectors = sectors.size();
  for (const Sector& s : sectors) {
    const int ix0 = s.key.ix * kGridDim, iy0 = s.key.iy * kGridDim;
    const double z0 = s.grid.z_min_m, z1 = s.grid.z_min_m + kGridDim * double(s.grid.cell_height_m);
    // A sector's grid may be tall (the decoder accepts cell heights up to 1e5 m): its layers are
    // bounded before any loop runs.
    const double layers = std::ceil(z1 / h) - std::floor(z0 / h);
    if (!(layers <= double(kMaxVoxelLayersPerSector)))
      return fail(archive.string() + ": sector " + toString(s.key) + ": its grid spans " + std::to_string(z1 - z0) + " m, more than " +
                  std::to_string(kMaxVoxelLayersPerSector) + " voxels of " + std::to_string(h) + " m: raise --voxel-height");
    const int k0 = int(std::floor(z0 / h)), k1 = int(std::ceil(z1 / h)) - 1;
    for (int k = k0; k <= k1; ++k)
      for (int j = 0; j < kGridDim; ++j)
        for (int i = 0; i < kGridDim; ++i) {
          const openvdb::Coord c(ix0 + i, iy0 + j, k);
          const glm::dvec3 centre((c.x() + 0.5) * cell, (c.y() + 0.5) * cell, (k + 0.5) * h);
          const runtime::ProbeRef p = cache.probeAt(centre);
          if (!p.valid()) continue;
          const glm::vec4 v = cache.skyVisibility(p);
          sky_acc.setValue(c, (v.x + v.y + v.z) / 3.f);
          // The probe's colours shaded for +Z in the archive's representation (fc3: the talk's weights).
          const glm::vec3 e = runtime::shade(cache.representation(), cache.colours(p), glm::vec3(0, 0, 1));
          irr_acc.setValue(c, openvdb::Vec3s(e.r, e.g, e.b));
        }
    for (const ProbeRecord& r : s.probes) {
      const glm::dvec3 w = glm::dvec3(s.key.ix * kSectorSizeM, s.key.iy * kSectorSizeM, 0.0) +
                           glm::dvec3(r.position[0], r.position[1], r.position[2]);
      const openvdb::Coord c(int(std::floor(w.x / cell)), int(std::floor(w.y / cell)), int(std::floor(w.z / h)));
      den_acc.setValue(c, den_acc.getValue(c) + 1.f);
      ++stats.probes;
    }
  }
  stats.active_voxels = sky->activeVoxelCount();
  openvdb::GridPtrVec grids;
  for (openvdb::GridBase::Ptr g : {openvdb::GridBase::Ptr(sky), openvdb::GridBase::Ptr(density), openvdb::GridBase::Ptr(irradiance)}) {
    g->setTransform(xform);
    g->insertMeta("drtv_archive", openvdb::StringMetadata(archive.filename().string()));
    g->insertMeta("drtv_hour", openvdb::DoubleMetadata(options.hour));
    g->insertMeta("drtv_units", openvdb::StringMetadata("metres"));
    grids.push_back(g);
  }
  sky->setName("sky_visibility");
  sky->setGridClass(openvdb::GRID_FOG_VOLUME);
  density->setName("probe_density");
  irradiance->setName("irradiance");
  try {
    openvdb::io::File file(output.string());
    file.write(grids);
    file.close();
  } catch (const std::exception& e) {
    return fail(output.string() + ": openvdb: " + e.what());
  }
  return stats;
}

}  // namespace drtv::eval
