// drtv/baker/vdb.h — a baked archive as OpenVDB grids, to look at the probes in Houdini or
// Blender: `drtv export-vdb`. OpenVDB stays in src/ (STYLE.md): this header names none of it.
//
//  [1] Museth, "VDB: High-Resolution Sparse Volumes with Dynamic Topology", ACM TOG 32(3), 2013.
//  [2] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slides 17 (the
//      nearest-probe index grid), 21 (sky visibility), 25-32 (relighting).
//
// Grids (one voxel per index-grid cell column: 4 m x 4 m horizontally and `voxel_height_m`
// vertically; the grid transform maps voxel (i, j, k) to the world-space cell centre
// (4 i + 2, 4 j + 2, h k + h/2) metres, Z up as everywhere in drtv; empty space is inactive):
//   "sky_visibility"  float   mean of the three upward bases' sky visibility of the probe the
//                             index grid names for the voxel centre [2, slide 21], in [0, 1];
//   "probe_density"   float   probes whose position lies in the voxel (integers as floats);
//   "irradiance"      Vec3s   the relit irradiance of that probe for a surface facing up (+Z,
//                             the talk's shading weights), linear RGB, at `hour`.
// Voxels are written where a sector's index grid has cells (its 16 x 16 columns over the z range
// of its grid). Grid metadata: "drtv_archive", "drtv_hour", "drtv_units" = "metres".
#pragma once

#include <cstddef>
#include <filesystem>

#include "drtv/formats/error.h"

namespace drtv::eval {

struct VdbExportOptions {
  double hour = 12.0;           // time of day of the irradiance grid, finite (modulo 24)
  double voxel_height_m = 4.0;  // vertical voxel size, metres, > 0 (horizontal is the grid's 4 m)
};

struct VdbExportStats {
  size_t sectors = 0;
  size_t probes = 0;
  size_t active_voxels = 0;  // per grid (sky_visibility and irradiance share the topology)
};

// Reads every sector of `archive`, relights it at `hour` and writes the three grids to `output`.
// Errors name the archive or the output (OpenVDB exceptions are translated here).
Result<VdbExportStats> exportVdb(const std::filesystem::path& archive, const std::filesystem::path& output,
                                 const VdbExportOptions& options = {});

}  // namespace drtv::eval
