// WorldGeometry: validation, binning and the per-sector gather (see world_geometry.h).
#include "drtv/raytrace/world_geometry.h"

#include <xxhash.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "drtv/formats/memory_limit.h"

namespace drtv::raytrace {
namespace {

// The k-th corner of a triangle as it is stored after `transform`: a mirroring transform (negative
// determinant, e.g. glTF's scale -1) turns counter-clockwise into clockwise, so its triangles take
// their corners 0, 2, 1 and keep their front side outward (glTF 2.0, 3.7.2.1: "when a mesh
// primitive uses any triangle-based topology, the determinant of the node's global transform
// defines the winding order").
bool mirrors(const glm::dmat4& transform) { return glm::determinant(glm::dmat3(transform)) < 0.0; }
int windingOrder(bool mirrored, int k) { return mirrored && k > 0 ? 3 - k : k; }

// Triangles with less area than this (m^2) are degenerate: their normal is noise. 1 mm^2 is far
// below any modelled detail and far above float round-off at the coordinates a sector uses.
constexpr double kMinTriangleAreaM2 = 1e-6;

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

bool finite(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

glm::dvec3 apply(const glm::dmat4& m, const glm::vec3& p) { return glm::dvec3(m * glm::dvec4(glm::dvec3(p), 1.0)); }

int32_t floorDiv(double v, double s) { return int32_t(std::floor(v / s)); }

}  // namespace

Result<WorldGeometry> WorldGeometry::build(const worlds::World& world, const std::string& where, std::optional<SectorRange> only,
                                           double halo_m) {
  WorldGeometry g;
  g.world_ = &world;
  g.only_ = only;
  g.only_halo_m_ = halo_m;
  // The xy box whose geometry is binned (world metres): the sectors of `only` grown by the halo.
  glm::dvec2 keep_lo(-INFINITY), keep_hi(INFINITY);
  if (only) {
    keep_lo = glm::dvec2(only->x0 * kSectorSizeM - halo_m, only->y0 * kSectorSizeM - halo_m);
    keep_hi = glm::dvec2((only->x1 + 1) * kSectorSizeM + halo_m, (only->y1 + 1) * kSectorSizeM + halo_m);
  }
  auto kept = [&](const glm::dvec3& lo, const glm::dvec3& hi) {
    return !(hi.x < keep_lo.x || lo.x > keep_hi.x || hi.y < keep_lo.y || lo.y > keep_hi.y);
  };
  const size_t mesh_count = world.meshes.size();
  g.valid_tris_.resize(mesh_count);

  // Which meshes contribute (used by a non-dynamic instance); only those are validated.
  std::vector<uint8_t> used(mesh_count, 0);
  if (auto ok = world.validate(); !ok) return std::unexpected(ok.error().context(where));
  for (const worlds::Instance& inst : world.instances)
    if (inst.cls != worlds::InstanceClass::kDynamic) used[inst.mesh] = 1;

  // Memory as an input limit (memory_limit.h): what the passes below allocate, estimated before
  // they allocate it. Here the validation's index per triangle of a used mesh (4 B) and each
  // instance's bounds (Placed, 64 B); the flattening after pass 1.
  {
    uint64_t estimate = 64 * uint64_t(world.instances.size());
    for (size_t m = 0; m < mesh_count; ++m)
      if (used[m]) estimate += 4 * uint64_t(world.meshes[m].triangleCount());
    if (auto ok = checkMemory(estimate, where, "validating the bake's geometry (" + std::to_string(world.instances.size()) +
                                                   " instances of " + std::to_string(mesh_count) + " meshes)");
        !ok)
      return std::unexpected(ok.error());
  }

  // Materials: one per distinct albedo, so that a forest of one mesh shares one entry.
  std::map<std::tuple<float, float, float, bool>, uint16_t> material_index;
  std::vector<uint16_t> mesh_material(mesh_count, 0);
  for (size_t m = 0; m < mesh_count; ++m) {
    if (!used[m]) continue;
    const worlds::Mesh& mesh = world.meshes[m];
    if (mesh.indices.size() % 3 != 0)
      return fail(where + ": mesh '" + mesh.name + "': " + std::to_string(mesh.indices.size()) + " indices, not a multiple of 3");
    size_t non_finite = 0, degenerate = 0;
    auto& valid = g.valid_tris_[m];
    valid.reserve(mesh.triangleCount());
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
      uint32_t idx[3];
      for (int k = 0; k < 3; ++k) {
        idx[k] = mesh.indices[3 * t + k];
        if (idx[k] >= mesh.positions.size())
          return fail(where + ": mesh '" + mesh.name + "': triangle " + std::to_string(t) + ": index " +
                      std::to_string(idx[k]) + " past its " + std::to_string(mesh.positions.size()) + " positions");
      }
      const glm::vec3 a = mesh.positions[idx[0]], b = mesh.positions[idx[1]], c = mesh.positions[idx[2]];
      if (!finite(a) || !finite(b) || !finite(c)) {
        ++non_finite;
        continue;
      }
      if (0.5 * glm::length(glm::cross(glm::dvec3(b - a), glm::dvec3(c - a))) < kMinTriangleAreaM2) {
        ++degenerate;
        continue;
      }
      valid.push_back(uint32_t(t));
    }
    if (non_finite) g.notes_.push_back("skipped: mesh '" + mesh.name + "': " + std::to_string(non_finite) + " triangles with non-finite vertices");
    if (degenerate) g.notes_.push_back("skipped: mesh '" + mesh.name + "': " + std::to_string(degenerate) + " degenerate (zero-area) triangles");
    glm::vec3 albedo = mesh.albedo;
    if (!finite(albedo) || glm::any(glm::lessThan(albedo, glm::vec3(0.f))) || glm::any(glm::greaterThan(albedo, glm::vec3(1.f)))) {
      g.notes_.push_back("repaired: mesh '" + mesh.name + "': albedo outside [0,1] clamped");
      for (int c = 0; c < 3; ++c) albedo[c] = std::isfinite(albedo[c]) ? std::clamp(albedo[c], 0.f, 1.f) : 0.5f;
    }
    auto [it, inserted] = material_index.try_emplace({albedo.x, albedo.y, albedo.z, mesh.double_sided}, uint16_t(g.materials_.size()));
    if (inserted) {
      if (g.materials_.size() >= 65535) return fail(where + ": more than 65535 distinct albedos");
      g.materials_.push_back(albedo);
      g.material_two_sided_.push_back(mesh.double_sided);
    }
    mesh_material[m] = it->second;
  }

  // Pass 1: per-instance world bounds, skipping instances that cannot be placed.
  struct Placed {
    size_t instance;
    glm::dvec3 min, max;
  };
  std::vector<Placed> placed;
  placed.reserve(world.instances.size());
  glm::dvec3 bmin(1e300), bmax(-1e300);
  for (size_t i = 0; i < world.instances.size(); ++i) {
    const worlds::Instance& inst = world.instances[i];
    if (inst.cls == worlds::InstanceClass::kDynamic || g.valid_tris_[inst.mesh].empty()) continue;
    if (!finite(inst.transform) || !(std::abs(glm::determinant(glm::dmat3(inst.transform))) > 1e-18)) {
      g.notes_.push_back("skipped: instance '" + inst.name + "': transform not finite or singular");
      continue;
    }
    const worlds::Mesh& mesh = world.meshes[inst.mesh];
    glm::dvec3 lo(1e300), hi(-1e300);
    for (uint32_t t : g.valid_tris_[inst.mesh])
      for (int k = 0; k < 3; ++k) {
        const glm::dvec3 p = apply(inst.transform, mesh.positions[mesh.indices[3 * t + k]]);
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
      }
    if (!finite(lo) || !finite(hi)) {
      g.notes_.push_back("skipped: instance '" + inst.name + "': transformed vertices not finite");
      continue;
    }
    placed.push_back({i, lo, hi});
    bmin = glm::min(bmin, lo);
    bmax = glm::max(bmax, hi);
  }
  if (placed.empty()) return fail(where + ": nothing to bake: no terrain, static or vegetation triangles");
  const glm::dvec3 extent = bmax - bmin;
  if (extent.x > kMaxWorldExtentM || extent.y > kMaxWorldExtentM || extent.z > kMaxWorldExtentM)
    return fail(where + ": geometry spans " + std::to_string(extent.x) + " x " + std::to_string(extent.y) + " x " +
                std::to_string(extent.z) + " m, more than the " + std::to_string(kMaxWorldExtentM) + " m the baker accepts");
  // Where it sits matters too: sector keys are int32 and a probe's height must pass validateProbe
  // (|z| < 1e6 m), so the world must lie within kMaxWorldOffsetM horizontally and 1e5 m vertically.
  if (glm::any(glm::greaterThan(glm::abs(glm::dvec2(bmin)), glm::dvec2(kMaxWorldOffsetM))) ||
      glm::any(glm::greaterThan(glm::abs(glm::dvec2(bmax)), glm::dvec2(kMaxWorldOffsetM))) || std::fabs(bmin.z) > kMaxWorldHeightM ||
      std::fabs(bmax.z) > kMaxWorldHeightM)
    return fail(where + ": geometry lies at [" + std::to_string(bmin.x) + ", " + std::to_string(bmin.y) + ", " + std::to_string(bmin.z) +
                "] .. [" + std::to_string(bmax.x) + ", " + std::to_string(bmax.y) + ", " + std::to_string(bmax.z) +
                "] m: the baker accepts +-" + std::to_string(int64_t(kMaxWorldOffsetM)) + " m horizontally and +-" +
                std::to_string(int64_t(kMaxWorldHeightM)) + " m vertically");
  g.bounds_min_ = bmin;
  g.bounds_max_ = bmax;
  g.sectors_.x0 = floorDiv(bmin.x, kSectorSizeM);
  g.sectors_.y0 = floorDiv(bmin.y, kSectorSizeM);
  // A bound exactly on a sector edge does not pull in the sector beyond it.
  g.sectors_.x1 = std::max(g.sectors_.x0, int32_t(std::ceil(bmax.x / kSectorSizeM)) - 1);
  g.sectors_.y1 = std::max(g.sectors_.y0, int32_t(std::ceil(bmax.y / kSectorSizeM)) - 1);
  g.bin_x0_ = g.sectors_.x0;
  g.bin_y0_ = g.sectors_.y0;
  g.bin_nx_ = g.sectors_.x1 - g.sectors_.x0 + 1;
  g.bin_ny_ = g.sectors_.y1 - g.sectors_.y0 + 1;
  g.bins_.resize(size_t(g.bin_nx_) * size_t(g.bin_ny_));
  g.anchor_ = glm::dvec3(std::floor(0.5 * (bmin.x + bmax.x) / kSectorSizeM) * kSectorSizeM,
                         std::floor(0.5 * (bmin.y + bmax.y) / kSectorSizeM) * kSectorSizeM, 0.0);

  auto binRange = [&](const glm::dvec3& lo, const glm::dvec3& hi, auto&& fn) {
    const int32_t x0 = std::clamp(floorDiv(lo.x, kSectorSizeM), g.bin_x0_, g.bin_x0_ + g.bin_nx_ - 1);
    const int32_t x1 = std::clamp(floorDiv(hi.x, kSectorSizeM), g.bin_x0_, g.bin_x0_ + g.bin_nx_ - 1);
    const int32_t y0 = std::clamp(floorDiv(lo.y, kSectorSizeM), g.bin_y0_, g.bin_y0_ + g.bin_ny_ - 1);
    const int32_t y1 = std::clamp(floorDiv(hi.y, kSectorSizeM), g.bin_y0_, g.bin_y0_ + g.bin_ny_ - 1);
    for (int32_t y = y0; y <= y1; ++y)
      for (int32_t x = x0; x <= x1; ++x) fn(g.bins_[size_t(y - g.bin_y0_) * g.bin_nx_ + (x - g.bin_x0_)]);
  };

  // Pass 2: flatten large meshes triangle by triangle; bin small instances whole. Its memory
  // first: per flattened triangle its vertices (36 B), material and class (3 B) and bin entry
  // (4 B, twice for a vector's growth); per small instance its SmallInstance and bin entries. A
  // large mesh only partly inside `only` counts the share of its xy bounds inside (terrain is
  // spread evenly; the estimate's margin covers the rest).
  {
    double large = 0;
    size_t small = 0, biggest = SIZE_MAX;
    for (const Placed& p : placed) {
      const uint32_t mesh = world.instances[p.instance].mesh;
      const size_t n = g.valid_tris_[mesh].size();
      if (!kept(p.min, p.max)) continue;
      if (n <= kLargeMeshTriangles) {
        ++small;
        continue;
      }
      double share = 1.0;
      if (only) {
        const glm::dvec2 lo = glm::max(glm::dvec2(p.min), keep_lo), hi = glm::min(glm::dvec2(p.max), keep_hi);
        const glm::dvec2 size = glm::dvec2(p.max - p.min);
        if (size.x > 0 && size.y > 0) share = std::clamp((hi.x - lo.x) * (hi.y - lo.y) / (size.x * size.y), 0.0, 1.0);
      }
      large += share * double(n);
      if (biggest == SIZE_MAX || n > g.valid_tris_[biggest].size()) biggest = mesh;
    }
    const auto large_tris = uint64_t(std::ceil(large));
    const uint64_t estimate = large_tris * (36 + 3 + 8) + small * (sizeof(SmallInstance) + 16);
    std::string what = "binning the bake's geometry (";
    if (large_tris) what += std::to_string(large_tris) + " triangles of large meshes, the largest '" + world.meshes[biggest].name + "'";
    if (large_tris && small) what += "; ";
    if (small) what += std::to_string(small) + " instances of small meshes";
    what += ")";
    if (auto ok = checkMemory(estimate, where, what); !ok) return std::unexpected(ok.error());
    // Reserved exactly where the count is exact, so the vectors do not double past the estimate.
    if (!only) {
      g.large_vertices_.reserve(3 * large_tris);
      g.large_material_.reserve(large_tris);
      g.large_cls_.reserve(large_tris);
    }
    g.small_.reserve(small);
  }
  size_t large_degenerate = 0;
  for (const Placed& p : placed) {
    const worlds::Instance& inst = world.instances[p.instance];
    const worlds::Mesh& mesh = world.meshes[inst.mesh];
    const auto& valid = g.valid_tris_[inst.mesh];
    if (valid.size() > kLargeMeshTriangles) {
      const bool mirrored = mirrors(inst.transform);
      for (uint32_t t : valid) {
        glm::dvec3 w[3];
        for (int k = 0; k < 3; ++k) w[k] = apply(inst.transform, mesh.positions[mesh.indices[3 * t + windingOrder(mirrored, k)]]);
        if (0.5 * glm::length(glm::cross(w[1] - w[0], w[2] - w[0])) < kMinTriangleAreaM2) {
          ++large_degenerate;
          continue;
        }
        if (only && !kept(glm::min(w[0], glm::min(w[1], w[2])), glm::max(w[0], glm::max(w[1], w[2])))) continue;
        const uint32_t index = uint32_t(g.large_material_.size());
        for (int k = 0; k < 3; ++k) g.large_vertices_.push_back(glm::vec3(w[k] - g.anchor_));
        g.large_material_.push_back(mesh_material[inst.mesh]);
        g.large_cls_.push_back(uint8_t(inst.cls));
        binRange(glm::min(w[0], glm::min(w[1], w[2])), glm::max(w[0], glm::max(w[1], w[2])),
                 [&](Bin& b) {
                   b.large_tris.push_back(index);
                   ++b.triangles;
                 });
      }
      g.triangle_count_ += valid.size();
      if (inst.cls == worlds::InstanceClass::kVegetation) g.large_vegetation_boxes_.emplace_back(p.min, p.max);
    } else {
      g.triangle_count_ += valid.size();
      if (!kept(p.min, p.max)) continue;
      const uint32_t index = uint32_t(g.small_.size());
      g.small_.push_back({inst.mesh, inst.transform, uint8_t(inst.cls), mesh_material[inst.mesh], p.min, p.max});
      binRange(p.min, p.max, [&](Bin& b) {
        b.small.push_back(index);
        b.triangles += valid.size();
      });
    }
  }
  if (large_degenerate) g.notes_.push_back("skipped: " + std::to_string(large_degenerate) + " triangles degenerate after their instance transform");
  g.triangle_count_ -= large_degenerate;

  // Fingerprint: every input that shapes the baked bytes.
  XXH3_state_t* state = XXH3_createState();
  XXH3_64bits_reset(state);
  for (size_t m = 0; m < mesh_count; ++m) {
    if (!used[m]) continue;
    const worlds::Mesh& mesh = world.meshes[m];
    XXH3_64bits_update(state, mesh.positions.data(), mesh.positions.size() * sizeof(glm::vec3));
    XXH3_64bits_update(state, mesh.indices.data(), mesh.indices.size() * sizeof(uint32_t));
    XXH3_64bits_update(state, &g.materials_[mesh_material[m]], sizeof(glm::vec3));
    // Only when set, so that worlds without double-sided materials keep their fingerprints.
    if (mesh.double_sided) XXH3_64bits_update(state, "double-sided", 12);
  }
  for (const Placed& p : placed) {
    const worlds::Instance& inst = world.instances[p.instance];
    XXH3_64bits_update(state, &inst.mesh, sizeof(inst.mesh));
    XXH3_64bits_update(state, &inst.transform, sizeof(inst.transform));
    XXH3_64bits_update(state, &inst.cls, sizeof(inst.cls));
  }
  g.fingerprint_ = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  return g;
}

const WorldGeometry::Bin* WorldGeometry::bin(int32_t ix, int32_t iy) const {
  if (ix < bin_x0_ || iy < bin_y0_ || ix >= bin_x0_ + bin_nx_ || iy >= bin_y0_ + bin_ny_) return nullptr;
  return &bins_[size_t(iy - bin_y0_) * bin_nx_ + (ix - bin_x0_)];
}

uint64_t WorldGeometry::gatherEstimate(SectorKey key, double halo_m) const {
  const int64_t reach = int64_t(std::ceil(halo_m / kSectorSizeM));
  const int64_t x0 = std::max<int64_t>(int64_t(key.ix) - reach, bin_x0_), x1 = std::min<int64_t>(int64_t(key.ix) + reach, int64_t(bin_x0_) + bin_nx_ - 1);
  const int64_t y0 = std::max<int64_t>(int64_t(key.iy) - reach, bin_y0_), y1 = std::min<int64_t>(int64_t(key.iy) + reach, int64_t(bin_y0_) + bin_ny_ - 1);
  uint64_t tris = 0;
  for (int64_t y = y0; y <= y1; ++y)
    for (int64_t x = x0; x <= x1; ++x) tris += bin(int32_t(x), int32_t(y))->triangles;
  return tris;
}

uint64_t WorldGeometry::largestGather(const SectorRange& range, double halo_m, SectorKey* at) const {
  uint64_t largest = 0;
  SectorKey where{};
  const int32_t reach = int32_t(std::ceil(halo_m / kSectorSizeM));
  // Bins outside the world's are empty: clamp the range to them first (a --sectors range may be
  // wider than the world, and a 1024 x 1024 world costs 1 M sums of (2 reach + 1)^2 bins).
  const int32_t x0 = std::max(range.x0, bin_x0_), x1 = std::min(range.x1, bin_x0_ + bin_nx_ - 1);
  const int32_t y0 = std::max(range.y0, bin_y0_), y1 = std::min(range.y1, bin_y0_ + bin_ny_ - 1);
  for (int32_t y = y0; y <= y1; ++y)
    for (int32_t x = x0; x <= x1; ++x) {
      uint64_t tris = 0;
      for (int32_t by = y - reach; by <= y + reach; ++by)
        for (int32_t bx = x - reach; bx <= x + reach; ++bx)
          if (const Bin* b = bin(bx, by)) tris += b->triangles;
      if (tris > largest) largest = tris, where = SectorKey{x, y};
    }
  if (at) *at = where;
  return largest;
}

Result<void> WorldGeometry::checkBakeMemory(const SectorRange& range, double halo_m, int concurrent, const std::string& where) const {
  SectorKey at{};
  const uint64_t largest = largestGather(range, halo_m, &at);
  const uint64_t sectors = range.count();
  const uint64_t at_once = std::max<uint64_t>(1, std::min<uint64_t>(uint64_t(std::max(concurrent, 1)), sectors));
  return checkMemory(at_once * largest * kBakeBytesPerGatheredTriangle, where,
                     "baking " + std::to_string(at_once) + " sector(s) at once, each gathering up to " + std::to_string(largest) +
                         " triangles (sector " + toString(at) + " with its " + std::to_string(int(halo_m)) + " m halo)");
}

std::vector<uint8_t> SectorGeometry::twoSided() const {
  if (std::find(material_two_sided.begin(), material_two_sided.end(), uint8_t(1)) == material_two_sided.end()) return {};
  std::vector<uint8_t> out(material.size());
  for (size_t t = 0; t < material.size(); ++t) out[t] = material_two_sided[material[t]];
  return out;
}

SectorGeometry WorldGeometry::gather(SectorKey key, double halo_m) const {
  // Built for some sectors only: anything else would silently miss geometry.
  if (only_) {
    DRTV_CHECK(only_->contains(key));
    DRTV_CHECK_LE(halo_m, only_halo_m_);
  }
  SectorGeometry s;
  s.key = key;
  s.halo_m = halo_m;
  s.materials = materials_;
  s.material_two_sided = material_two_sided_;
  const glm::dvec3 origin(key.ix * kSectorSizeM, key.iy * kSectorSizeM, 0.0);
  const glm::dvec2 lo(origin.x - halo_m, origin.y - halo_m), hi(origin.x + kSectorSizeM + halo_m, origin.y + kSectorSizeM + halo_m);
  std::vector<uint32_t> large, small;
  for (int32_t iy = floorDiv(lo.y, kSectorSizeM); iy <= floorDiv(hi.y, kSectorSizeM); ++iy)
    for (int32_t ix = floorDiv(lo.x, kSectorSizeM); ix <= floorDiv(hi.x, kSectorSizeM); ++ix)
      if (const Bin* b = bin(ix, iy)) {
        large.insert(large.end(), b->large_tris.begin(), b->large_tris.end());
        small.insert(small.end(), b->small.begin(), b->small.end());
      }
  std::sort(large.begin(), large.end());
  large.erase(std::unique(large.begin(), large.end()), large.end());
  std::sort(small.begin(), small.end());
  small.erase(std::unique(small.begin(), small.end()), small.end());

  auto overlaps = [&](const glm::dvec3& a, const glm::dvec3& b) {
    return !(b.x < lo.x || a.x > hi.x || b.y < lo.y || a.y > hi.y);
  };
  const glm::dvec3 shift = anchor_ - origin;
  for (uint32_t t : large) {
    const glm::dvec3 a(large_vertices_[3 * t]), b(large_vertices_[3 * t + 1]), c(large_vertices_[3 * t + 2]);
    if (!overlaps(glm::min(a, glm::min(b, c)) + anchor_, glm::max(a, glm::max(b, c)) + anchor_)) continue;
    s.vertices.push_back(glm::vec3(a + shift));
    s.vertices.push_back(glm::vec3(b + shift));
    s.vertices.push_back(glm::vec3(c + shift));
    s.material.push_back(large_material_[t]);
    s.cls.push_back(large_cls_[t]);
  }
  for (uint32_t i : small) {
    const SmallInstance& inst = small_[i];
    if (!overlaps(inst.min, inst.max)) continue;
    const worlds::Mesh& mesh = world_->meshes[inst.mesh];
    const bool mirrored = mirrors(inst.transform);
    for (uint32_t t : valid_tris_[inst.mesh]) {
      for (int k = 0; k < 3; ++k)
        s.vertices.push_back(glm::vec3(apply(inst.transform, mesh.positions[mesh.indices[3 * t + windingOrder(mirrored, k)]]) - origin));
      s.material.push_back(inst.material);
      s.cls.push_back(inst.cls);
    }
    if (inst.cls == uint8_t(worlds::InstanceClass::kVegetation))
      s.vegetation_boxes.push_back({glm::vec3(inst.min - origin), glm::vec3(inst.max - origin)});
  }
  for (const auto& [bmin, bmax] : large_vegetation_boxes_)
    if (overlaps(bmin, bmax)) s.vegetation_boxes.push_back({glm::vec3(bmin - origin), glm::vec3(bmax - origin)});
  if (!s.vertices.empty()) {
    s.z_min = s.z_max = s.vertices[0].z;
    for (const glm::vec3& v : s.vertices) {
      s.z_min = std::min(s.z_min, v.z);
      s.z_max = std::max(s.z_max, v.z);
    }
  }
  return s;
}

}  // namespace drtv::raytrace
