// drtv/baker/world_geometry.h — the World's static geometry, validated and binned by sector, and
// the per-sector gather that lets every sector be baked on its own (shards, resumption).
//
// What takes part (talk [1] slides 7, 15-16): terrain, static and vegetation instances contribute
// bounce and occlusion; dynamic instances never do (they receive GI only).
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012.
//
// Bad input never aborts: an instance naming a missing mesh or an out-of-range index is an Error
// naming the mesh; non-finite transforms, non-finite vertices and zero-area triangles are skipped
// and each skip is one line in notes() ("skipped: mesh 'rock': 3 degenerate triangles").
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <optional>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"
#include "drtv/formats/sector.h"
#include "drtv/worlds/world.h"

namespace drtv::raytrace {

// Worlds wider than this (either axis, metres) are refused as absurd: 1024 x 1024 sectors.
inline constexpr double kMaxWorldExtentM = 65536.0;
// Where the geometry may lie: within +-1e7 m of the origin horizontally (sector keys stay far
// inside int32; the stability suite bakes a world 100 km out) and +-1e5 m vertically (probe
// heights must stay below the 1e6 m the probe record accepts).
inline constexpr double kMaxWorldOffsetM = 1e7;
inline constexpr double kMaxWorldHeightM = 1e5;
// Meshes with more triangles than this are binned triangle by triangle (terrain); smaller ones
// are binned as whole instances and transformed at gather time (trees, boxes), which keeps the
// memory of a forest of shared meshes at one copy. Tuned on the island: the terrain mesh is
// 125 k triangles per km^2 and a tree 92, so any value in [1e3, 1e5] splits them alike.
inline constexpr size_t kLargeMeshTriangles = 4096;

// An axis-aligned box in the gather's local frame (metres).
struct Box {
  glm::vec3 min{0.f}, max{0.f};
  // Half-open: min <= p < max on every axis (a point on a shared face belongs to one box).
  bool contains(const glm::vec3& p) const { return glm::all(glm::greaterThanEqual(p, min)) && glm::all(glm::lessThan(p, max)); }
};

// The geometry one sector is baked from: everything within `halo_m` of the sector (xy).
// Local frame: origin at the sector's min corner (x = 64 ix, y = 64 iy) and z = 0, so local
// (x, y) is the sector-relative position of probe.h and z the world height.
struct SectorGeometry {
  SectorKey key;
  double halo_m = 0;
  std::vector<glm::vec3> vertices;          // 3 per triangle, local metres
  std::vector<uint16_t> material;           // per triangle: index into materials
  std::vector<glm::vec3> materials;         // albedo per material (linear RGB in [0,1])
  std::vector<uint8_t> material_two_sided;  // per material: 1 = double-sided (worlds::Mesh)
  std::vector<uint8_t> cls;                 // per triangle: worlds::InstanceClass
  std::vector<Box> vegetation_boxes;        // local AABB of each vegetation instance in the halo
  float z_min = 0.f, z_max = 0.f;           // height range of the gathered triangles (0,0 if none)

  size_t triangleCount() const { return material.size(); }
  // Per triangle: 1 where its material is double-sided; empty when none is (RayScene::build).
  std::vector<uint8_t> twoSided() const;
};

// Inclusive range of sector keys (formats/sector.h).
using SectorRange = drtv::SectorRange;

class WorldGeometry {
 public:
  // Validates and bins `world`. Errors (message prefixed by `where`, e.g. the world file):
  // no terrain/static/vegetation triangle at all ("nothing to bake"), an instance whose mesh index
  // is out of range, a mesh index past its positions, geometry wider than kMaxWorldExtentM
  // or beyond kMaxWorldOffsetM / kMaxWorldHeightM.
  // O(triangles of large meshes + instances). Not thread-safe to build; const methods are.
  // `only`: bin just the geometry that sectors in this range gather with a halo up to `halo_m`
  // (a bake of --sectors need not flatten a whole 8192-cell terrain); gather() is then valid for
  // those sectors and halos alone (a bug otherwise, checked). Bounds, sectors(), notes, counts and
  // the fingerprint are the whole world's either way. The memory the binning needs is estimated
  // first and refused beyond memoryLimit() (drtv/formats/memory_limit.h), naming the mesh.
  static Result<WorldGeometry> build(const worlds::World& world, const std::string& where,
                                     std::optional<SectorRange> only = std::nullopt, double halo_m = 0.0);

  // Sectors the contributing geometry touches (xy bounds of terrain, static, vegetation).
  SectorRange sectors() const { return sectors_; }
  // World-space bounds of the contributing geometry (metres).
  glm::dvec3 boundsMin() const { return bounds_min_; }
  glm::dvec3 boundsMax() const { return bounds_max_; }
  // Skips and repairs, one line each, for the bake report.
  const std::vector<std::string>& notes() const { return notes_; }
  // Contributing triangles after skips (instanced count).
  size_t triangleCount() const { return triangle_count_; }
  // A 64-bit fingerprint of everything that shapes the bake's output (geometry, albedo, classes):
  // a resumed bake refuses sector files baked from other geometry.
  uint64_t fingerprint() const { return fingerprint_; }

  // The triangles whose bounding box overlaps the sector's square grown by `halo_m` (xy), in the
  // sector's local frame, in a deterministic order (independent of threads and of other sectors).
  SectorGeometry gather(SectorKey key, double halo_m) const;

  // Bytes one sector's bake holds per triangle it gathers: the SectorGeometry (39 B), Embree's
  // vertex and index buffers and BVH and the scene's normals (~120 B). Measured: a bake of one
  // sector gathering 67.5 M vegetation triangles peaked 11 GB above the world it was given.
  static constexpr uint64_t kBakeBytesPerGatheredTriangle = 170;
  // Refuses (memory_limit.h) a bake of the sectors in `range` with `halo_m` when `concurrent`
  // sectors baked at once, each as large as the largest gather in the range, would not fit;
  // `where` names the file. The gather's size comes from per-bin triangle counts (instances
  // that straddle bins count in each: it errs high), without gathering anything.
  Result<void> checkBakeMemory(const SectorRange& range, double halo_m, int concurrent, const std::string& where) const;
  // The most triangles one sector of `range` gathers with `halo_m`, from the per-bin counts as
  // checkBakeMemory counts them (it errs high), and which sector that is (`at`, may be null).
  // What a farm sizes a shard's memory by (drtv/baker/farm.h). O(sectors * halo bins).
  uint64_t largestGather(const SectorRange& range, double halo_m, SectorKey* at = nullptr) const;
  // The triangles sector `key` gathers with `halo_m`, counted as largestGather counts them. A
  // sector's bake time follows it (the island: correlation 0.96 over its 256 sectors); what the
  // shards are balanced by (drtv/baker/shard.h). O(halo bins).
  uint64_t gatherEstimate(SectorKey key, double halo_m) const;

 private:
  struct SmallInstance {
    uint32_t mesh;
    glm::dmat4 transform;
    uint8_t cls;
    uint16_t material;
    glm::dvec3 min, max;  // world AABB
  };
  struct Bin {
    std::vector<uint32_t> large_tris;  // into large_vertices_ / 3
    std::vector<uint32_t> small;       // into small_
    uint64_t triangles = 0;            // large_tris plus the small instances' triangles
  };
  const Bin* bin(int32_t ix, int32_t iy) const;

  const worlds::World* world_ = nullptr;  // for small instances' meshes; must outlive this
  glm::dvec3 anchor_{0.0};                // world position of large_vertices_' origin
  std::vector<glm::vec3> large_vertices_; // 3 per triangle, world - anchor
  std::vector<uint16_t> large_material_;
  std::vector<uint8_t> large_cls_;
  std::vector<SmallInstance> small_;
  std::vector<std::vector<uint32_t>> valid_tris_;  // per mesh: triangles that pass validation
  std::vector<glm::vec3> materials_;
  std::vector<uint8_t> material_two_sided_;
  std::vector<std::pair<glm::dvec3, glm::dvec3>> large_vegetation_boxes_;  // world AABBs
  SectorRange sectors_;
  std::optional<SectorRange> only_;  // the sectors binned for (all when empty)
  double only_halo_m_ = 0.0;
  int32_t bin_x0_ = 0, bin_y0_ = 0, bin_nx_ = 0, bin_ny_ = 0;
  std::vector<Bin> bins_;
  glm::dvec3 bounds_min_{0.0}, bounds_max_{0.0};
  std::vector<std::string> notes_;
  size_t triangle_count_ = 0;
  uint64_t fingerprint_ = 0;
};

}  // namespace drtv::raytrace
