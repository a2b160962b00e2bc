// Material grids of the sweep technique from a world's triangles (seed 001, "Material
// representation"), by ray casting through the cells' columns and rows with Embree. Offline
// (Embree), so here beside the technique and not in drtv::sweep.
//
//  [1] ../shared/seeds/001: per cell an RGB reflectance and a density; cells below the ground full
//      density with the ground's reflectance, "with a linear transition and a small terrain height
//      bias, to avoid unwanted shadows at hilltops".
//
// Per cell, with n x n parallel rays through each cell face along x, y and z (n = ceil(cell_m /
// ray_spacing_m), at most kMaxRaysPerEdge):
//  - objects: the share o of rays that hit a static or vegetation triangle in the cell, or pass
//    through it inside a static mesh (between a front-face and a back-face hit: rocks and
//    buildings are closed; a double-sided triangle is a surface only and bounds no inside),
//    averaged over the three axes;
//  - ground: each downward ray's first terrain hit at height h makes the cell's share below
//    h - ground_bias g = clamp((h - bias - z_cell_bottom) / cell_m, 0, 1): the seed's linear
//    transition; g is averaged over the cell's downward rays;
//  - ground_z per column: the highest terrain hit of its downward rays;
//  - density 1 - (1 - g)(1 - o); reflectance the mean albedo of the hits, the terrain's weighted by
//    g and the objects' by (1 - g) o.
// The grid's cells must not straddle sectors (64 / cell_m an integer, the origin on a sector
// corner's cell lattice): each sector's geometry is gathered and traced on its own.
// Deterministic: a fixed order of rays and sums. Thread-safety: reads `geometry` only.
#pragma once

#include "drtv/formats/error.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/sweep/grid.h"
#include "model_material.h"

namespace drtv::eval {

inline constexpr int kMaxRaysPerEdge = 16;

struct VoxelOptions {
  double ray_spacing_m = 0.34;    // spacing of the parallel rays, metres (3 per edge of a 1 m cell)
  double ground_bias_cells = 0.25;// the ground is lowered by this share of a cell [1]
  double halo_m = 2.0;            // geometry gathered around each sector, metres
};

// The material grid of `shape` from `geometry`'s terrain, static and vegetation triangles. Errors:
// Embree's (out of memory), a shape whose cells straddle sectors. With `ground_mean_z`, also the
// mean height of each column's downward rays' terrain hits (world metres, per column
// i + size.x j; NaN where none hit terrain): the ground under the column's centre, not its
// highest point (ground_z).
Result<sweep::MaterialGrid> voxelise(const raytrace::WorldGeometry& geometry, const sweep::GridShape& shape,
                                     const VoxelOptions& options, std::vector<float>* ground_mean_z = nullptr);

// As above, with `objects` (model_material.h: the placed models resampled over `shape`) combined
// with the ray-cast objects as transmittances multiply, o = 1 - (1 - o_rays)(1 - o_models), their
// reflectance the o-weighted mean; `geometry` may be null (nothing ray cast: no ground, no
// ground_z). Without objects it is the function above, bit for bit.
Result<sweep::MaterialGrid> voxelise(const raytrace::WorldGeometry* geometry, const sweep::GridShape& shape,
                                     const VoxelOptions& options, std::vector<float>* ground_mean_z, const ObjectLayer* objects);

}  // namespace drtv::eval
