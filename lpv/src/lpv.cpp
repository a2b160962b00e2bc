// Cascaded light propagation volumes (lpv.h; references there): the cascades, their placement and
// what they hold; injection (injection.cpp), propagation (propagation.cpp) and lookup (lookup.cpp)
// are files of their own.
#include "drtv/lpv/lpv.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "cascade.h"
#include "propagation_matrices.h"
#include "workers.h"

namespace drtv::lpv {

using namespace detail;

Result<void> validate(const LpvOptions& o) {
  if (o.cascades < 1 || o.cascades > 8) return fail("cascades: expected an integer in [1, 8]");
  if (o.cells < 4 || o.cells > 128 || o.cells % 2) return fail("cells: expected an even integer in [4, 128]");
  if (!(o.cell_m > 0 && o.cell_m <= 1e4)) return fail("cell_m: expected metres in (0, 1e4]");
  if (!(o.ratio >= 1.5 && o.ratio <= 4)) return fail("ratio: expected a number in [1.5, 4]");
  if (o.iterations < 0 || o.iterations > 256) return fail("iterations: expected an integer in [0, 256]");
  if (o.sky_steps < 0 || o.sky_steps > o.cells) return fail("sky_steps: expected an integer in [0, cells]");
  if (!(o.lookup_offset_cells >= 0 && o.lookup_offset_cells <= 2)) return fail("lookup_offset_cells: expected cells in [0, 2]");
  if (!(o.blend_cells >= 0 && o.blend_cells <= float(o.cells) / 4)) return fail("blend_cells: expected cells in [0, cells / 4]");
  if (o.threads < 1 || o.threads > 64) return fail("threads: expected an integer in [1, 64]");
  return {};
}

CascadedLpv::CascadedLpv(const LpvOptions& o) : options_(o) {
  const int n = o.cells;
  const size_t cells = size_t(n) * size_t(n) * size_t(n);
  const size_t corners = size_t(n + 1) * size_t(n + 1) * size_t(n + 1);
  const size_t np = size_t(n) + 2;
  cascades_.resize(size_t(o.cascades));
  double s = o.cell_m;
  for (Cascade& c : cascades_) {
    c.n = n;
    c.cells = cells;
    c.box.cell_m = s;
    c.box.cells = n;
    c.injected.assign(kPlanes * c.padded(), 0.f);
    c.inj_lit.assign(np * 3 * np, 0);
    c.light.assign(kPlanes * cells, 0.f);
    c.light_lit.assign(size_t(n) * 3 * size_t(n), 0);
    c.last_step.assign(3 * cells, 0.f);
    c.last_lit.assign(size_t(n) * 3 * size_t(n), 0);
    c.geometry.assign(4 * corners, 0.f);
    c.face_t.assign(kDirs * cells, 1.f);
    c.sky_t.assign(kSkyDirections * cells, 255);
    c.sky.assign(kPlanes * cells, 0.f);
    s *= o.ratio;
  }
  // A propagation has 3 jobs (its channels); an injection one per thread.
  const int threads = std::min(o.threads, 3);
  scratch_.resize(size_t(threads));
  for (Scratch& w : scratch_) {
    w.ring.assign(size_t(kWaveDepth) * 3 * 4 * np * np, 0.f);
    w.ring_lit.assign(size_t(kWaveDepth) * 3 * np, 0);
  }
  if (threads > 1) workers_ = std::make_unique<Workers>(threads - 1);
  if (threads == 2) pipeline_ = std::make_unique<Pipeline>();
}

CascadedLpv::CascadedLpv(CascadedLpv&&) noexcept = default;
CascadedLpv& CascadedLpv::operator=(CascadedLpv&&) noexcept = default;
CascadedLpv::~CascadedLpv() = default;

Result<CascadedLpv> CascadedLpv::create(const LpvOptions& options) {
  if (auto e = validate(options); !e) return std::unexpected(e.error().context("lpv options"));
  (void)matrices();
  return CascadedLpv(options);
}

int CascadedLpv::cascadeCount() const { return int(cascades_.size()); }

const CascadeBox& CascadedLpv::box(int c) const {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  return cascades_[size_t(c)].box;
}

uint32_t CascadedLpv::setCamera(const glm::dvec3& camera) {
  DRTV_CHECK(std::isfinite(camera.x) && std::isfinite(camera.y) && std::isfinite(camera.z));
  uint32_t moved = 0;
  for (size_t ci = 0; ci < cascades_.size(); ++ci) {
    Cascade& c = cascades_[ci];
    const double s = c.box.cell_m;
    const glm::dvec3 min = (glm::floor(camera / s) - glm::dvec3(c.n / 2)) * s;
    if (placed_ && min == c.box.min) continue;
    c.box.min = min;
    moved |= 1u << ci;
    clearLight(int(ci));
    clearGeometry(int(ci));
    std::fill(c.face_t.begin(), c.face_t.end(), 1.f);
    std::fill(c.sky_t.begin(), c.sky_t.end(), uint8_t(255));
    std::fill(c.sky.begin(), c.sky.end(), 0.f);
  }
  placed_ = true;
  return moved;
}

void CascadedLpv::clearLight(int c) {
  clearInjected(c);
  Cascade& g = cascades_[size_t(c)];
  const int n = g.n;
  // Only the rows a propagation flagged can hold anything but zeros.
  for (int k = 0; k < n; ++k)
    for (int ch = 0; ch < 3; ++ch)
      for (int j = 0; j < n; ++j) {
        uint8_t& lit = g.light_lit[(size_t(k) * 3 + size_t(ch)) * size_t(n) + size_t(j)];
        if (lit) {  // until the next propagate
          for (int q = 0; q < 4; ++q) std::fill_n(g.light.data() + size_t(ch * 4 + q) * g.cells + g.index(0, j, k), n, 0.f);
          lit = 0;
        }
      }
}

void CascadedLpv::clearInjected(int c) {
  Cascade& g = cascades_[size_t(c)];
  const int n = g.n;
  const size_t np = size_t(n) + 2, P = g.padded();
  // Only the rows an injection flagged can hold anything but zeros.
  for (int k = 0; k < n; ++k)
    for (int ch = 0; ch < 3; ++ch)
      for (int j = 0; j < n; ++j) {
        uint8_t& inj = g.inj_lit[(size_t(k + 1) * 3 + size_t(ch)) * np + size_t(j + 1)];
        if (!inj) continue;
        for (int q = 0; q < 4; ++q) std::fill_n(g.injected.data() + size_t(ch * 4 + q) * P + g.paddedIndex(0, j, k), n, 0.f);
        inj = 0;
      }
}

sh::Sh4Rgb CascadedLpv::cellLight(int c, int i, int j, int k) const {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  const Cascade& g = cascades_[size_t(c)];
  DRTV_CHECK(i >= 0 && j >= 0 && k >= 0 && i < g.n && j < g.n && k < g.n);
  const size_t idx = g.index(i, j, k);
  sh::Sh4Rgb out{};
  for (int ch = 0; ch < 3; ++ch)
    for (int q = 0; q < 4; ++q) out[size_t(ch)][q] = g.light[size_t(ch * 4 + q) * g.cells + idx];
  return out;
}

glm::dvec3 CascadedLpv::totalLight(int c) const {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  const Cascade& g = cascades_[size_t(c)];
  glm::dvec3 out(0.0);
  for (int ch = 0; ch < 3; ++ch)
    for (size_t i = 0; i < g.cells; ++i) out[ch] += g.light[size_t(ch * 4) * g.cells + i];
  return out;
}

glm::dvec3 CascadedLpv::lastStepLight(int c) const {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  const Cascade& g = cascades_[size_t(c)];
  glm::dvec3 out(0.0);
  for (int ch = 0; ch < 3; ++ch)
    for (size_t i = 0; i < g.cells; ++i) out[ch] += g.last_step[size_t(ch) * g.cells + i];
  return out;
}

size_t CascadedLpv::bytes() const {
  size_t b = 0;
  for (const Scratch& w : scratch_)
    b += w.ring.size() * sizeof(float) + w.ring_lit.size() + w.grids[0].bytes() + w.grids[1].bytes();
  if (pipeline_)
    for (const StepGrid& grid : pipeline_->grids) b += grid.bytes();
  for (const Cascade& c : cascades_)
    b += (c.injected.size() + c.light.size() + c.last_step.size() + c.geometry.size() + c.face_t.size() + c.sky.size()) *
             sizeof(float) +
         c.sky_t.size() + c.inj_lit.size() + c.light_lit.size() + c.last_lit.size();
  return b;
}

}  // namespace drtv::lpv
