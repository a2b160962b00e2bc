#include "sweep_material.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "drtv/formats/sector.h"
#include "drtv/raytrace/ray_scene.h"

namespace drtv::eval {
namespace {

using worlds::InstanceClass;

struct Accum {
  std::vector<uint16_t> blocked[3];  // rays blocked in the cell, per axis
  std::vector<float> ground;         // sum over downward rays of the share below the ground
  std::vector<glm::vec3> ground_albedo, object_albedo;
  std::vector<uint32_t> ground_hits, object_hits;
  std::vector<float> ground_top;     // per column: the highest terrain hit
  std::vector<double> ground_sum;    // per column: the sum of the downward rays' terrain hits
  std::vector<uint32_t> ground_rays; // ... and how many there were
};

// One ray along `axis` through the grid: marks the cells it is blocked in.
struct Tracer {
  const raytrace::RayScene& scene;
  const raytrace::SectorGeometry& sg;
  const sweep::GridShape& s;
  glm::dvec3 local;  // world position of sg's local frame origin
  Accum& acc;
  double bias_m;

  // Cells along the ray: index along the axis from the position.
  int cellAlong(int axis, double world) const { return int(std::floor((world - s.origin[axis]) / s.cell_m)); }

  // `fixed`: the ray's cell indices on the two other axes; the ray runs from a0 to a1 (world) on
  // `axis`, downward for z.
  void trace(int axis, glm::dvec3 start, double length, glm::ivec3 fixed) {
    glm::vec3 dir(0.f);
    dir[axis] = axis == 2 ? -1.f : 1.f;
    raytrace::Ray ray;
    ray.origin = glm::vec3(start - local);
    ray.dir = dir;
    ray.t_far = float(length);
    int depth = 0, last_marked = -1 << 30;
    double t_prev = 0;
    auto cellAt = [&](double t) {
      const double w = start[axis] + double(dir[axis]) * t;
      return cellAlong(axis, w);
    };
    auto mark = [&](int c) {
      if (c == last_marked || c < 0 || c >= s.size[axis]) return;
      last_marked = c;
      glm::ivec3 idx = fixed;
      idx[axis] = c;
      ++acc.blocked[axis][s.index(idx.x, idx.y, idx.z)];
    };
    auto markRange = [&](double t0, double t1) {
      int c0 = cellAt(t0), c1 = cellAt(t1);
      if (c0 > c1) std::swap(c0, c1);
      // Downward (z) rays meet cells in decreasing order; mark's repeat check wants monotone calls.
      if (axis == 2)
        for (int c = c1; c >= c0; --c) mark(c);
      else
        for (int c = c0; c <= c1; ++c) mark(c);
    };
    for (int guard = 0; guard < 100000; ++guard) {
      const raytrace::Hit h = scene.intersect(ray);
      if (!h.hit()) break;
      const double t = h.t;
      const auto cls = InstanceClass(sg.cls[h.prim]);
      const glm::vec3 albedo = sg.materials[sg.material[h.prim]];
      if (depth > 0) markRange(t_prev, t);
      if (cls == InstanceClass::kTerrain) {
        if (axis == 2) {
          const size_t col = size_t(fixed.x) + size_t(s.size.x) * size_t(fixed.y);
          acc.ground_top[col] = std::max(acc.ground_top[col], float(start.z - t));
          acc.ground_sum[col] += start.z - t;
          ++acc.ground_rays[col];
          const double zg = start.z - t - bias_m;
          glm::ivec3 idx = fixed;
          for (int k = 0; k < s.size.z; ++k) {
            idx.z = k;
            const double below = std::clamp((zg - (s.origin.z + k * s.cell_m)) / s.cell_m, 0.0, 1.0);
            if (below <= 0) break;
            const size_t ci = s.index(idx.x, idx.y, idx.z);
            acc.ground[ci] += float(below);
            acc.ground_albedo[ci] += albedo;
            ++acc.ground_hits[ci];
          }
          break;  // below the ground is all ground
        }
      } else {
        const int c = cellAt(t);
        mark(c);
        if (c >= 0 && c < s.size[axis]) {
          glm::ivec3 idx = fixed;
          idx[axis] = c;
          const size_t ci = s.index(idx.x, idx.y, idx.z);
          acc.object_albedo[ci] += albedo;
          ++acc.object_hits[ci];
        }
        // A double-sided triangle is a surface from both sides (docs/world-format.md), never the
        // skin of a solid: it opens and closes nothing.
        if (cls == InstanceClass::kStatic && !scene.twoSided(h.prim))
          depth = scene.frontFace(ray, h.prim) ? depth + 1 : std::max(0, depth - 1);
      }
      t_prev = t;
      ray.t_near = float(t) + 1e-4f + 1e-6f * float(t);
    }
  }
};

}  // namespace

Result<sweep::MaterialGrid> voxelise(const raytrace::WorldGeometry& geometry, const sweep::GridShape& s, const VoxelOptions& o,
                                     std::vector<float>* ground_mean_z) {
  return voxelise(&geometry, s, o, ground_mean_z, nullptr);
}

Result<sweep::MaterialGrid> voxelise(const raytrace::WorldGeometry* geometry, const sweep::GridShape& s, const VoxelOptions& o,
                                     std::vector<float>* ground_mean_z, const ObjectLayer* objects) {
  const double per_sector = kSectorSizeM / s.cell_m;
  if (std::abs(per_sector - std::round(per_sector)) > 1e-9 || per_sector < 1)
    return fail("sweep: cell size " + std::to_string(s.cell_m) + " m does not divide a 64 m sector");
  const int n = std::clamp(int(std::ceil(s.cell_m / o.ray_spacing_m - 1e-9)), 1, kMaxRaysPerEdge);
  Accum acc;
  const size_t cells = s.cellCount();
  for (auto& b : acc.blocked) b.assign(cells, 0);
  acc.ground.assign(cells, 0.f);
  acc.ground_albedo.assign(cells, glm::vec3(0.f));
  acc.object_albedo.assign(cells, glm::vec3(0.f));
  acc.ground_hits.assign(cells, 0);
  acc.object_hits.assign(cells, 0);
  acc.ground_top.assign(size_t(s.size.x) * size_t(s.size.y), -std::numeric_limits<float>::infinity());
  acc.ground_sum.assign(acc.ground_top.size(), 0.0);
  acc.ground_rays.assign(acc.ground_top.size(), 0);
  const glm::dvec3 hi = s.max();
  const SectorKey k0 = sectorAt(s.origin.x, s.origin.y), k1 = sectorAt(hi.x - 1e-6, hi.y - 1e-6);
  const int cps = int(std::round(per_sector));
  for (int32_t sy = k0.iy; sy <= k1.iy && geometry; ++sy)
    for (int32_t sx = k0.ix; sx <= k1.ix; ++sx) {
      const SectorKey key{sx, sy};
      const raytrace::SectorGeometry sg = geometry->gather(key, o.halo_m);
      if (sg.triangleCount() == 0) continue;
      auto scene = raytrace::RayScene::build(sg.vertices, sg.twoSided());
      if (!scene) return std::unexpected(scene.error().context("sweep: sector " + toString(key)));
      const glm::dvec3 local(kSectorSizeM * sx, kSectorSizeM * sy, 0.0);
      // This sector's cells.
      const int i0 = std::max(0, int(std::lround((local.x - s.origin.x) / s.cell_m))), i1 = std::min(s.size.x, i0 + cps);
      const int j0 = std::max(0, int(std::lround((local.y - s.origin.y) / s.cell_m))), j1 = std::min(s.size.y, j0 + cps);
      Tracer tr{*scene, sg, s, local, acc, o.ground_bias_cells * s.cell_m};
      const double height = s.cell_m * s.size.z;
      for (int j = j0; j < j1; ++j)
        for (int i = i0; i < i1; ++i)
          for (int b = 0; b < n; ++b)
            for (int a = 0; a < n; ++a)
              tr.trace(2, {s.origin.x + (i + (a + 0.5) / n) * s.cell_m, s.origin.y + (j + (b + 0.5) / n) * s.cell_m, hi.z}, height,
                       {i, j, 0});
      for (int k = 0; k < s.size.z; ++k)
        for (int b = 0; b < n; ++b)
          for (int a = 0; a < n; ++a) {
            const double z = s.origin.z + (k + (b + 0.5) / n) * s.cell_m;
            for (int j = j0; j < j1; ++j)
              tr.trace(0, {s.origin.x + i0 * s.cell_m, s.origin.y + (j + (a + 0.5) / n) * s.cell_m, z}, (i1 - i0) * s.cell_m, {0, j, k});
            for (int i = i0; i < i1; ++i)
              tr.trace(1, {s.origin.x + (i + (a + 0.5) / n) * s.cell_m, s.origin.y + j0 * s.cell_m, z}, (j1 - j0) * s.cell_m, {i, 0, k});
          }
    }
  sweep::MaterialGrid m = sweep::MaterialGrid::clear(s);
  m.ground_z = acc.ground_top;
  if (ground_mean_z) {
    ground_mean_z->assign(acc.ground_top.size(), std::numeric_limits<float>::quiet_NaN());
    for (size_t c = 0; c < acc.ground_top.size(); ++c)
      if (acc.ground_rays[c]) (*ground_mean_z)[c] = float(acc.ground_sum[c] / double(acc.ground_rays[c]));
  }
  const float rays = float(n * n);
  for (size_t c = 0; c < cells; ++c) {
    float obj = std::min(1.f, float(acc.blocked[0][c] + acc.blocked[1][c] + acc.blocked[2][c]) / (3.f * rays));
    const bool modelled = objects && objects->share[c] > 0.f;
    glm::vec3 object_albedo(0.f);
    if (modelled) {
      const float om = objects->share[c];
      const glm::vec3 rays_albedo = acc.object_hits[c] ? acc.object_albedo[c] / float(acc.object_hits[c]) : glm::vec3(0.f);
      object_albedo = (obj * rays_albedo + om * objects->reflectance[c]) / (obj + om);
      obj = 1.f - (1.f - obj) * (1.f - om);
    }
    const bool has_objects = modelled || acc.object_hits[c] != 0;
    const float g = std::min(1.f, acc.ground[c] / rays);
    m.density[c] = 1.f - (1.f - g) * (1.f - obj);
    const float wg = g, wo = (1.f - g) * obj;
    glm::vec3 r(0.f);
    if (acc.ground_hits[c]) r += wg * acc.ground_albedo[c] / float(acc.ground_hits[c]);
    if (modelled)
      r += wo * object_albedo;
    else if (acc.object_hits[c])
      r += wo * acc.object_albedo[c] / float(acc.object_hits[c]);
    const float w = (acc.ground_hits[c] ? wg : 0.f) + (has_objects ? wo : 0.f);
    m.reflectance[c] = w > 0 ? glm::clamp(r / w, 0.f, 1.f) : glm::vec3(0.f);
  }
  return m;
}

}  // namespace drtv::eval
