// fine_shader.cpp — the fine level packed for the shaders (fine_shader.h).
#include "drtv/runtime/fine_shader.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "drtv/formats/error.h"
#include "drtv/formats/visibility.h"

namespace drtv::runtime {

namespace {
double cellOf(const FineShaderOptions& o) { return o.cell_m > 0.0 ? o.cell_m : 4.0; }
glm::dvec3 halfOf(const FineShaderOptions& o) { return glm::max(o.half_extent_m, glm::dvec3(cellOf(o))); }
}  // namespace

glm::dvec3 fineBoxCorner(const glm::dvec3& camera, const FineShaderOptions& o) {
  const bool finite = std::isfinite(camera.x) && std::isfinite(camera.y) && std::isfinite(camera.z);
  if (!finite) return glm::dvec3(NAN);
  const double cell = cellOf(o);
  return glm::floor((camera - halfOf(o)) / cell) * cell;
}

FineShaderData packFineLevel(const ProbeCache& cache, const glm::dvec3& camera, const FineShaderOptions& o) {
  FineShaderData out;
  FineShaderConstants& k = out.constants;
  const double cell = cellOf(o);
  const double R = o.lookup.radius_m;
  const bool finite = std::isfinite(camera.x) && std::isfinite(camera.y) && std::isfinite(camera.z);
  const glm::dvec3 half = halfOf(o);
  // Options are the engine's, not a file's: a box of more cells than a GPU buffer indexes is a bug.
  DRTV_CHECK(cell > 0.0 && glm::all(glm::lessThanEqual(2.0 * half / cell, glm::dvec3(1024.0))));
  const glm::ivec3 n = glm::ivec3(glm::ceil(2.0 * half / cell));
  const glm::dvec3 lo = finite ? fineBoxCorner(camera, o) : glm::dvec3(0.0);
  const glm::dvec3 hi = lo + glm::dvec3(n) * cell;
  for (int a = 0; a < 3; ++a) k.box_min[a] = float(lo[a]), k.box_max[a] = float(hi[a]), k.cells[a] = n[a];
  k.cell_m = float(cell);
  k.radius_m = o.lookup.radius_m;
  k.normal_bias_m = o.lookup.normal_bias_m;
  k.min_visibility = o.lookup.min_visibility;
  k.full_weight = o.lookup.full_weight;
  k.fade_m = float(cell);
  const size_t cell_count = size_t(n.x) * size_t(n.y) * size_t(n.z);
  if (!o.lookup.enabled || !(R > 0.0) || !finite) {
    // An empty level: every cell lists nothing.
    out.cells.assign(2 * cell_count, 0u);
    k.probes = 0;
    return out;
  }
  std::vector<std::vector<uint32_t>> lists(cell_count);
  cache.visitCoveredProbes(lo - R, hi + R, [&](const ProbeCache::CoveredProbe& p) {
    const uint32_t index = uint32_t(out.probes.size());
    FineShaderProbe fp{};
    for (int a = 0; a < 3; ++a) fp.position[a] = float(p.position[a]);
    for (int b = 0; b < 4; ++b)
      for (int a = 0; a < 3; ++a) fp.colours[b][a] = p.colours[size_t(b)][a];
    out.probes.push_back(fp);
    const size_t at = out.visibility.size();
    out.visibility.resize(at + kVisValuesPerProbe / 4);
    std::memcpy(out.visibility.data() + at, p.visibility.data(), kVisValuesPerProbe);  // little-endian bytes, as the shaders read them
    // Every cell some point of which lies within R of the probe.
    const glm::ivec3 c0 = glm::clamp(glm::ivec3(glm::floor((p.position - R - lo) / cell)), glm::ivec3(0), n - 1);
    const glm::ivec3 c1 = glm::clamp(glm::ivec3(glm::floor((p.position + R - lo) / cell)), glm::ivec3(0), n - 1);
    for (int z = c0.z; z <= c1.z; ++z)
      for (int y = c0.y; y <= c1.y; ++y)
        for (int x = c0.x; x <= c1.x; ++x) {
          const glm::dvec3 box_lo = lo + glm::dvec3(x, y, z) * cell, box_hi = box_lo + cell;
          const glm::dvec3 d = glm::max(glm::max(box_lo - p.position, p.position - box_hi), glm::dvec3(0.0));
          if (glm::dot(d, d) < R * R) lists[size_t(x) + size_t(n.x) * (size_t(y) + size_t(n.y) * size_t(z))].push_back(index);
        }
  });
  static_assert(std::endian::native == std::endian::little, "the visibility bytes are copied as little-endian uints");
  k.probes = uint32_t(out.probes.size());
  size_t listed = 0;
  for (const auto& l : lists) listed += l.size();
  out.cells.reserve(2 * cell_count + listed);
  out.cells.resize(2 * cell_count);
  for (size_t c = 0; c < cell_count; ++c) {
    out.cells[2 * c] = uint32_t(out.cells.size());
    out.cells[2 * c + 1] = uint32_t(lists[c].size());
    out.cells.insert(out.cells.end(), lists[c].begin(), lists[c].end());
  }
  return out;
}

float fineShaderFade(const FineShaderConstants& k, const glm::dvec3& at) {
  double edge = INFINITY;
  for (int a = 0; a < 3; ++a) edge = std::min({edge, at[a] - double(k.box_min[a]), double(k.box_max[a]) - at[a]});
  if (!(k.fade_m > 0.f)) return edge > 0.0 ? 1.f : 0.f;
  return float(std::clamp(edge / double(k.fade_m), 0.0, 1.0));
}

}  // namespace drtv::runtime
