// Per-model material grids for the sweep (seed 001, "Material representation"): each distinct
// model (a worlds::Mesh placed by small instances: a tree's trunk or crown, a rock, a box) is
// voxelised ONCE, offline, in its own frame with OpenVDB; a sector's 1 m material is then built by
// resampling each placed instance (its transform) into the cells it overlaps.
//
//  [1] ../shared/seeds/001: "For each 3D model used in the terrain (trees, rocks etc.), a material
//      grid is generated offline from the geometry and surface material properties. During the
//      game, when a light grid is being updated for an area of terrain, a material grid is formed
//      first for the area, with one cell for each light grid cell [...] by sampling the model
//      material grids according to the positions and orientations of the models".
//  [2] OpenVDB, openvdb::tools::meshToLevelSet and meshToUnsignedDistanceField
//      (openvdb/tools/MeshToVolume.h): a narrow-band signed distance of a closed mesh (its inside
//      flood-filled negative), an unsigned distance of any triangle soup.
//
// The model grid: voxels whose edge along each model axis (model units) is chosen so that under
// the largest scale any of the model's placements gives that axis, a voxel is at most
// ModelVoxelOptions::voxel_m in the world (the mesh is voxelised in that index space, where
// OpenVDB's voxels are cubes). A voxel blocks light when
//  - solid models (class static, not double-sided: the ray caster's closed rocks and buildings,
//    sweep_material.h): the signed distance at its centre is <= 0 (inside or on the surface);
//  - surface models (vegetation, double-sided): the unsigned distance (in voxels) at its centre is
//    within a shell half-width of max(0.87, half a lattice spacing at the smallest scale), so
//    that a line of samples crossing the surface meets at least one blocking voxel.
// One reflectance per model: a worlds::Mesh has one albedo, so a per-voxel RGB grid would be
// that constant.
//
// Resampling, per placement: a lattice of 4 x 4 x 4 points per light-grid cell (0.25 m apart in a
// 1 m cell) over the cells its world box overlaps, each point taken into the model's frame and
// read from its nearest voxel. The ray caster counts the share of a cell's parallel rays (along
// x, y and z) blocked in it; here the lattice's lines along each axis stand for the rays: a run of
// blocking points along a line blocks, for a solid model, every cell it passes (the ray caster's
// inside between front and back faces), for a surface model only the cell of the run's middle
// (the ray caster's hit; the shell is thicker than the surface, and counting every cell it
// touched made crowns 1.5 times as dense as the rays found). The instance's share o_i is the
// share of each cell's 16 lines per axis that are blocked in it, averaged over the 3 axes. Instances combine as transmittances multiply:
// o = 1 - prod_i (1 - o_i), and the objects' reflectance is the o_i-weighted mean of the models'.
// Deterministic: instances in world order, cells in index order. Thread-safety: const members
// from any number of threads.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"
#include "drtv/sweep/grid.h"
#include "drtv/worlds/world.h"

namespace drtv::eval {

struct ModelVoxelOptions {
  // A model voxel's edge in the world at its largest placement scale, metres. 0.125: of 0.125,
  // 0.25 and 0.5 the closest to the ray-cast grids and the fastest to resample (the shell and the
  // placements' boxes shrink with the voxels), `drtv accuracy --knobs sweep` and
  // drtv_sweep_material_bench on the island (docs/sweep.md).
  double voxel_m = 0.125;
  size_t max_voxels = 1u << 24;  // per model; a model needing more gets coarser voxels (bytes: 1 each)
};

// The objects a material grid gets besides the ray-cast ones: per cell of a shape, the share that
// blocks light (o above) and the reflectance of it.
struct ObjectLayer {
  std::vector<float> share;            // per cell, [0, 1]
  std::vector<glm::vec3> reflectance;  // per cell, RGB in [0, 1] (0 where share is 0)
};

// Whether an instance of `world` is placed as a model (resampled) rather than ray cast: a static
// or vegetation instance of a mesh of at most raytrace::kLargeMeshTriangles triangles with a
// finite, invertible transform. Terrain and large meshes (one-off static meshes) are ray cast.
bool placedAsModel(const worlds::World& world, const worlds::Instance& instance);

class ModelMaterial {
 public:
  struct Stats {
    size_t models = 0;      // distinct (mesh, solid) models voxelised
    size_t placements = 0;  // instances placed as models
    size_t voxels = 0;      // voxels of all model grids (1 byte each)
    double build_s = 0;     // wall time of the voxelisation
  };

  // Voxelises each distinct model of `world`'s instances that placedAsModel accepts, once.
  // Errors: OpenVDB's (translated), naming the mesh. Not thread-safe to build.
  static Result<ModelMaterial> build(const worlds::World& world, const ModelVoxelOptions& options);

  // The placed models' layer over `shape` (each placement resampled into the cells it overlaps).
  ObjectLayer resample(const sweep::GridShape& shape) const;

  const Stats& stats() const { return stats_; }

 private:
  struct Model {
    glm::dvec3 origin{0.0};  // model-frame position of voxel (0, 0, 0)'s min corner
    glm::dvec3 reach_min{0.0}, reach_max{0.0};  // model-frame box holding every blocking voxel
    glm::dvec3 voxel{1.0};   // voxel edges, model units, per model axis
    glm::ivec3 size{0};
    std::vector<uint8_t> blocks;  // per voxel i + size.x (j + size.y k): 1 = blocks light
    glm::vec3 reflectance{0.f};
    bool solid = false;           // a closed mesh's inside blocks (else its surface only)
  };
  struct Placement {
    uint32_t model = 0;
    glm::dmat4 to_model{1.0};       // world -> the model's voxel index space (continuous)
    glm::dvec3 min{0.0}, max{0.0};  // world box
  };
  std::vector<Model> models_;
  std::vector<Placement> placements_;
  Stats stats_;
};

}  // namespace drtv::eval
