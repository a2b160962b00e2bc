#include "model_material.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>

#include <glm/gtc/matrix_transform.hpp>

#include "drtv/raytrace/world_geometry.h"

namespace drtv::eval {
namespace {

using worlds::InstanceClass;

// The resampling lattice's spacing in a 1 m cell (4 points per edge), metres: a surface model's
// shell is at least half of it thick at every scale, so no line of points steps over it.
constexpr double kLatticeSpacingM = 0.25;
// Voxel centres half a voxel off the model's own lattice (index space = x / voxel + kShift): a
// face on a whole number of voxels from the model's origin then lies between voxels, not through
// their centres. Without it the test box's walls (faces on the cells' boundaries, voxels of the
// lattice's spacing) had lattice points on the boundary between the face's voxel (distance 0:
// blocking) and the next, and blocked a third of the cells beside them: walls 39.9 % -> 54.9 %.
constexpr double kShift = 0.5;

bool solidModel(const worlds::Mesh& mesh, InstanceClass cls) { return cls == InstanceClass::kStatic && !mesh.double_sided; }

// The scale a transform gives each of the model's axes: its linear part's column lengths.
glm::dvec3 axisScales(const glm::dmat4& t) {
  return {glm::length(glm::dvec3(t[0])), glm::length(glm::dvec3(t[1])), glm::length(glm::dvec3(t[2]))};
}

}  // namespace

bool placedAsModel(const worlds::World& world, const worlds::Instance& inst) {
  if (inst.cls != InstanceClass::kStatic && inst.cls != InstanceClass::kVegetation) return false;
  if (inst.mesh >= world.meshes.size() || world.meshes[inst.mesh].triangleCount() > raytrace::kLargeMeshTriangles) return false;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(inst.transform[c][r])) return false;
  return std::abs(glm::determinant(glm::dmat3(inst.transform))) > 1e-18;
}

Result<ModelMaterial> ModelMaterial::build(const worlds::World& world, const ModelVoxelOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  static std::once_flag init;
  std::call_once(init, [] { openvdb::initialize(); });
  ModelMaterial out;
  // The models: one per (mesh, solid), with the largest and smallest scale of their placements.
  struct Use {
    glm::dvec3 max_scale{0.0}, min_scale{1e300};  // per model axis
    uint32_t model = 0;
  };
  std::map<std::pair<uint32_t, bool>, Use> uses;
  for (const worlds::Instance& inst : world.instances) {
    if (!placedAsModel(world, inst)) continue;
    const worlds::Mesh& mesh = world.meshes[inst.mesh];
    if (mesh.triangleCount() == 0) continue;
    Use& u = uses[{inst.mesh, solidModel(mesh, inst.cls)}];
    const glm::dvec3 s = axisScales(inst.transform);
    u.max_scale = glm::max(u.max_scale, s);
    u.min_scale = glm::min(u.min_scale, s);
  }
  for (auto& [key, use] : uses) {
    const worlds::Mesh& mesh = world.meshes[key.first];
    const bool solid = key.second;
    glm::dvec3 lo(1e300), hi(-1e300);
    for (const glm::vec3& p : mesh.positions) {
      lo = glm::min(lo, glm::dvec3(p));
      hi = glm::max(hi, glm::dvec3(p));
    }
    Model m;
    m.reflectance = glm::clamp(mesh.albedo, 0.f, 1.f);
    m.solid = solid;
    // Per model axis, so that a unit box stretched 30 m one way and 0.4 m another is not
    // voxelised at 120 voxels a metre on every axis.
    m.voxel = glm::dvec3(o.voxel_m) / use.max_scale;
    // In voxel index units (OpenVDB's index space, voxel centres on the integers): the shell's
    // half-width, at least half a lattice spacing in the world at the smallest scale on every axis.
    auto shell = [&] {
      const glm::dvec3 half = 0.5 * kLatticeSpacingM / (use.min_scale * m.voxel);
      return std::max({0.87, half.x, half.y, half.z});
    };
    glm::ivec3 c0(0);
    auto dims = [&] {
      const double margin = (solid ? 1.0 : shell()) + 2.0;
      c0 = glm::ivec3(glm::floor(lo / m.voxel + kShift - margin));
      const glm::ivec3 c1(glm::ceil(hi / m.voxel + kShift + margin));
      m.size = c1 - c0 + 1;
      m.origin = (glm::dvec3(c0) - 0.5 - kShift) * m.voxel;
      return size_t(m.size.x) * size_t(m.size.y) * size_t(m.size.z);
    };
    for (size_t n = dims(); n > o.max_voxels; n = dims()) m.voxel *= std::cbrt(double(n) / double(o.max_voxels)) * 1.01;
    // The mesh in index space (x / voxel + kShift per axis) under a unit transform: OpenVDB's
    // distances are then in voxels (anisotropic in the model's units; the inside test is exact
    // either way).
    std::vector<openvdb::Vec3s> points;
    points.reserve(mesh.positions.size());
    for (const glm::vec3& p : mesh.positions) {
      const glm::dvec3 q = glm::dvec3(p) / m.voxel + kShift;
      points.emplace_back(float(q.x), float(q.y), float(q.z));
    }
    std::vector<openvdb::Vec3I> tris;
    for (size_t t = 0; t < mesh.triangleCount(); ++t)
      tris.emplace_back(mesh.indices[3 * t], mesh.indices[3 * t + 1], mesh.indices[3 * t + 2]);
    try {
      const auto xform = openvdb::math::Transform::createLinearTransform(1.0);
      const float shell_voxels = float(shell());
      openvdb::FloatGrid::Ptr grid =
          solid ? openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*xform, points, tris, 3.0f)
                : openvdb::tools::meshToUnsignedDistanceField<openvdb::FloatGrid>(*xform, points, tris, {}, shell_voxels + 1.f);
      auto acc = grid->getConstAccessor();
      m.blocks.assign(size_t(m.size.x) * size_t(m.size.y) * size_t(m.size.z), 0);
      size_t v = 0;
      for (int k = 0; k < m.size.z; ++k)
        for (int j = 0; j < m.size.y; ++j)
          for (int i = 0; i < m.size.x; ++i, ++v) {
            const float d = acc.getValue(openvdb::Coord(c0.x + i, c0.y + j, c0.z + k));
            m.blocks[v] = solid ? d <= 0.f : d <= shell_voxels;
          }
    } catch (const openvdb::Exception& e) {
      return fail("sweep: model '" + mesh.name + "': OpenVDB: " + e.what());
    }
    // Where blocking voxels can be: a voxel blocks when its centre is inside the mesh (solid) or
    // within the shell of it (surface), and reaches half a voxel further; one voxel more for the
    // distances' rounding. The placements' boxes are this, not the dense grid with its margin:
    // with 0.5 m voxels the margin had made the resampled regions twice as large.
    const double reach = (solid ? 0.0 : double(shell())) + 1.5;
    m.reach_min = lo - reach * m.voxel;
    m.reach_max = hi + reach * m.voxel;
    use.model = uint32_t(out.models_.size());
    out.stats_.voxels += m.blocks.size();
    out.models_.push_back(std::move(m));
  }
  // The placements: world -> the model's dense voxel coordinates (floor gives the nearest voxel).
  for (const worlds::Instance& inst : world.instances) {
    if (!placedAsModel(world, inst)) continue;
    const worlds::Mesh& mesh = world.meshes[inst.mesh];
    if (mesh.triangleCount() == 0) continue;
    Placement p;
    p.model = uses.at({inst.mesh, solidModel(mesh, inst.cls)}).model;
    const Model& m = out.models_[p.model];
    const glm::dmat4 to_voxels = glm::scale(glm::dmat4(1.0), glm::dvec3(1.0 / m.voxel)) * glm::translate(glm::dmat4(1.0), -m.origin);
    p.to_model = to_voxels * glm::inverse(inst.transform);
    p.min = glm::dvec3(1e300);
    p.max = glm::dvec3(-1e300);
    for (int c = 0; c < 8; ++c) {
      const glm::dvec3 corner((c & 1) ? m.reach_max.x : m.reach_min.x, (c & 2) ? m.reach_max.y : m.reach_min.y,
                              (c & 4) ? m.reach_max.z : m.reach_min.z);
      const glm::dvec3 w(inst.transform * glm::dvec4(corner, 1.0));
      p.min = glm::min(p.min, w);
      p.max = glm::max(p.max, w);
    }
    out.placements_.push_back(p);
  }
  out.stats_.models = out.models_.size();
  out.stats_.placements = out.placements_.size();
  out.stats_.build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

ObjectLayer ModelMaterial::resample(const sweep::GridShape& s) const {
  const size_t cells = s.cellCount();
  std::vector<float> pass(cells, 1.f);
  std::vector<glm::vec3> refl(cells, glm::vec3(0.f));
  std::vector<float> weight(cells, 0.f);
  const glm::dvec3 top = s.max();
  constexpr int kLattice = 4;  // points per cell edge
  const double step = s.cell_m / kLattice;
  std::vector<uint8_t> occ;
  std::vector<std::array<uint16_t, 3>> lines;  // per cell of the region: its blocked lines per axis
  for (const Placement& p : placements_) {
    if (p.max.x <= s.origin.x || p.max.y <= s.origin.y || p.max.z <= s.origin.z || p.min.x >= top.x || p.min.y >= top.y ||
        p.min.z >= top.z)
      continue;
    const Model& m = models_[p.model];
    // The region: every cell of the lattice the placement's box overlaps, inside the grid or not,
    // so that its lines' runs are whole.
    const glm::ivec3 lo(glm::floor((p.min - s.origin) / s.cell_m)), hi(glm::floor((p.max - s.origin) / s.cell_m));
    const glm::ivec3 rc = hi - lo + 1, d = rc * kLattice;
    occ.assign(size_t(d.x) * size_t(d.y) * size_t(d.z), 0);
    const glm::dmat3 a(p.to_model);
    const glm::vec3 da(a[0] * step);
    const glm::dvec3 t(p.to_model[3]);
    const glm::ivec3 n = m.size;
    for (int z = 0; z < d.z; ++z)
      for (int y = 0; y < d.y; ++y) {
        const glm::dvec3 first = s.origin + glm::dvec3(lo) * s.cell_m + (glm::dvec3(0, y, z) + 0.5) * step;
        const glm::vec3 q0(a * first + t);
        uint8_t* row = &occ[size_t(d.x) * (size_t(y) + size_t(d.y) * size_t(z))];
        for (int x = 0; x < d.x; ++x) {
          const glm::vec3 q = q0 + float(x) * da;
          // Truncation is floor from 0 up (std::floor is a call in baseline x86-64 code).
          if (!(q.x >= 0.f && q.y >= 0.f && q.z >= 0.f)) continue;
          const int i = int(q.x), j = int(q.y), k = int(q.z);
          if (i >= n.x || j >= n.y || k >= n.z) continue;
          row[x] = m.blocks[size_t(i) + size_t(n.x) * (size_t(j) + size_t(n.y) * size_t(k))];
        }
      }
    // Each line's runs of blocking points, as the ray caster's rays: a solid's run blocks every
    // cell it passes (the inside between a front and a back face), a surface's only the cell of
    // its middle (the cell of the hit: the shell is thicker than the surface).
    lines.assign(size_t(rc.x) * size_t(rc.y) * size_t(rc.z), {0, 0, 0});
    const size_t stride[3] = {1, size_t(d.x), size_t(d.x) * size_t(d.y)};
    const size_t cell_stride[3] = {1, size_t(rc.x), size_t(rc.x) * size_t(rc.y)};
    for (int axis = 0; axis < 3; ++axis) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const size_t sa = stride[axis], ca = cell_stride[axis];
      const int len = d[axis];
      for (int pv = 0; pv < d[v]; ++pv)
        for (int pu = 0; pu < d[u]; ++pu) {
          // The line's bit within a cell, by its position on the two other axes.
          const uint16_t bit = uint16_t(1u << ((pu % kLattice) + kLattice * (pv % kLattice)));
          const uint8_t* o = occ.data() + size_t(pu) * stride[u] + size_t(pv) * stride[v];
          std::array<uint16_t, 3>* cells_of_line = lines.data() + size_t(pu / kLattice) * cell_stride[u] + size_t(pv / kLattice) * cell_stride[v];
          int w = 0;
          while (w < len) {
            while (w < len && !o[size_t(w) * sa]) ++w;
            if (w == len) break;
            const int run = w;
            while (w < len && o[size_t(w) * sa]) ++w;
            if (m.solid) {
              for (int c = run / kLattice; c <= (w - 1) / kLattice; ++c) cells_of_line[size_t(c) * ca][axis] |= bit;
            } else {
              cells_of_line[size_t((run + w - 1) / 2 / kLattice) * ca][axis] |= bit;
            }
          }
        }
    }
    for (int k = std::max(lo.z, 0); k <= std::min(hi.z, s.size.z - 1); ++k)
      for (int j = std::max(lo.y, 0); j <= std::min(hi.y, s.size.y - 1); ++j)
        for (int i = std::max(lo.x, 0); i <= std::min(hi.x, s.size.x - 1); ++i) {
          const auto& l = lines[size_t(i - lo.x) + size_t(rc.x) * (size_t(j - lo.y) + size_t(rc.y) * size_t(k - lo.z))];
          const int blocked = std::popcount(l[0]) + std::popcount(l[1]) + std::popcount(l[2]);
          if (!blocked) continue;
          const float share = float(blocked) / float(3 * kLattice * kLattice);
          const size_t ci = s.index(i, j, k);
          pass[ci] *= 1.f - share;
          refl[ci] += share * m.reflectance;
          weight[ci] += share;
        }
  }
  ObjectLayer out;
  out.share.resize(cells);
  out.reflectance.assign(cells, glm::vec3(0.f));
  for (size_t c = 0; c < cells; ++c) {
    out.share[c] = 1.f - pass[c];
    if (weight[c] > 0.f) out.reflectance[c] = glm::clamp(refl[c] / weight[c], 0.f, 1.f);
  }
  return out;
}

}  // namespace drtv::eval
