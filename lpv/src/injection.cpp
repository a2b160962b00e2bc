// Cascaded light propagation volumes (lpv.h; references there): injection: the light of the
// VPLs, the surfels' blocking potential, and the sky's visibility through it.
#include "drtv/lpv/lpv.h"

#include <algorithm>
#include <cmath>

#include "cascade.h"
#include "workers.h"

namespace drtv::lpv {

using namespace detail;

void CascadedLpv::injectLight(int c, std::span<const Surfel> surfels) {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  const int jobs = int(scratch_.size());
  if (jobs == 1) injectJob(c, surfels, 0, 1);
  else workers_->run(jobs, [&](int job, int) { injectJob(c, surfels, job, jobs); });
}

void CascadedLpv::injectJob(int c, std::span<const Surfel> surfels, int job, int jobs) {
  Cascade& g = cascades_[size_t(c)];
  const double s = g.box.cell_m, inv_s = 1.0 / s;
  const float scale = float(1.0 / (double(sh::kPi) * s * s));
  const int n = g.n;
  const glm::dvec3 box_min = g.box.min;
  const size_t P = g.padded(), np = size_t(n) + 2;
  float* const planes = g.injected.data();
  uint8_t* const lit = g.inj_lit.data();
  // With `jobs` > 1, this job takes the surfels landing in its blocks of 4 rows of y, in the
  // given order, so every cell's sum is made in the same order whatever the count.
  // The cell of a run of surfels (an RSM's neighbouring texels share cells) is held in
  // registers: the same additions in the same order as adding to memory, without waiting on
  // each store before the next load of the same address.
  size_t run = SIZE_MAX, run_row = 0;
  float acc[kPlanes];
  uint8_t run_lit = 0;
  auto flush = [&] {
    if (run == SIZE_MAX) return;
    for (int p = 0; p < kPlanes; ++p) planes[size_t(p) * P + run] = acc[p];
    for (int ch = 0; ch < 3; ++ch) lit[run_row + size_t(ch) * np] |= uint8_t((run_lit >> ch) & 1);
  };
  for (const Surfel& v : surfels) {
    // Half a cell along the normal [1] sec. 4.1: the VPL lights the space in front of it. The
    // row first: with threads, a job skips the other jobs' surfels before the rest of the work.
    const double py = (v.position.y - box_min.y) * inv_s + 0.5 * double(v.normal.y);
    if (!(py >= 0 && py < n)) continue;
    const int j = int(py);
    if (jobs > 1 && (j / 4) % jobs != job) continue;
    const double px = (v.position.x - box_min.x) * inv_s + 0.5 * double(v.normal.x);
    const double pz = (v.position.z - box_min.z) * inv_s + 0.5 * double(v.normal.z);
    if (!(px >= 0 && pz >= 0 && px < n && pz < n)) continue;
    const int i = int(px), k = int(pz);
    const size_t idx = size_t(i + 1) + np * (size_t(j + 1) + np * size_t(k + 1));
    if (idx != run) {
      flush();
      run = idx;
      run_row = size_t(k + 1) * 3 * np + size_t(j + 1);
      run_lit = 0;
      for (int q = 0; q < kPlanes; ++q) acc[q] = planes[size_t(q) * P + idx];
    }
    const sh::Sh4 lobe = sh::cosineLobe(v.normal) * scale;
    for (int ch = 0; ch < 3; ++ch) {
      const float f = v.flux[ch];
      acc[ch * 4] += f * lobe.x;
      acc[ch * 4 + 1] += f * lobe.y;
      acc[ch * 4 + 2] += f * lobe.z;
      acc[ch * 4 + 3] += f * lobe.w;
      run_lit |= uint8_t(f != 0.f) << ch;
    }
  }
  flush();
}

void CascadedLpv::clearGeometry(int c) {
  Cascade& g = cascades_[size_t(c)];
  std::fill(g.geometry.begin(), g.geometry.end(), 0.f);
}

void CascadedLpv::injectGeometry(int c, std::span<const Surfel> surfels) {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  Cascade& g = cascades_[size_t(c)];
  const double s = g.box.cell_m;
  const size_t corners = g.geometry.size() / 4;
  const float inv_area = float(1.0 / (s * s));
  for (const Surfel& v : surfels) {
    // The geometry volume's cells are centred on the LPV's corners: the nearest corner.
    const glm::dvec3 p = glm::floor((v.position - g.box.min) / s + 0.5);
    if (!(p.x >= 0 && p.y >= 0 && p.z >= 0 && p.x <= g.n && p.y <= g.n && p.z <= g.n)) continue;
    const size_t idx = g.corner(int(p.x), int(p.y), int(p.z));
    const sh::Sh4 lobe = sh::cosineLobe(v.normal) * (v.area_m2 * inv_area);
    for (int k = 0; k < 4; ++k) g.geometry[size_t(k) * corners + idx] += lobe[k];
  }
}

glm::vec3 CascadedLpv::skyDirection(int k) {
  // Spherical Fibonacci: z uniform in (-1, 1), golden-angle azimuths.
  const double z = 1.0 - (2.0 * k + 1.0) / kSkyDirections;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2.39996322972865332 * k;
  return glm::vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
}

void CascadedLpv::computeOcclusion(int c) {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  Cascade& g = cascades_[size_t(c)];
  const int n = g.n;
  const size_t corners = g.geometry.size() / 4;
  auto blocking = [&](size_t corner_idx, const sh::Sh4& y) {
    float b = 0;
    for (int k = 0; k < 4; ++k) b += g.geometry[size_t(k) * corners + corner_idx] * y[k];
    return b;
  };
  // Faces: light travelling t = dirVector(d) enters cell (i,j,k) through the face on its -t side.
  for (int d = 0; d < kDirs; ++d) {
    const glm::ivec3 t = dirVector(d);
    const int axis = d / 2;
    const sh::Sh4 y = sh::evaluate(-glm::vec3(t));
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          glm::ivec3 base(i, j, k);
          if (t[axis] < 0) base[axis] += 1;  // the face on the cell's max side
          float b = 0;
          for (int u = 0; u < 2; ++u)
            for (int v = 0; v < 2; ++v) {
              glm::ivec3 q = base;
              q[(axis + 1) % 3] += u;
              q[(axis + 2) % 3] += v;
              b += blocking(g.corner(q.x, q.y, q.z), y);
            }
          g.face_t[size_t(d) * g.cells + g.index(i, j, k)] = 1.f - std::clamp(0.25f * b, 0.f, 1.f);
        }
  }
  // Sky transmittance: march from each cell centre towards the sky, one cell per step. The
  // corner nearest to centre + m w is the cell's index plus floor(1 + m w), the same offset for
  // every cell, and each corner's blocking for a direction is read once.
  const int m1 = n + 1;
  std::vector<float> pass(size_t(m1) * size_t(m1) * size_t(m1));
  std::vector<glm::ivec3> offsets;
  for (int dir = 0; dir < kSkyDirections; ++dir) {
    const glm::vec3 w = skyDirection(dir);
    // The view ray from the cell towards w is blocked by surfaces it meets on their front side
    // (n.w < 0), as the path tracer's ray is: the blocking potential read for travel along w.
    const sh::Sh4 y = sh::evaluate(-w);
    for (size_t q = 0; q < pass.size(); ++q) pass[q] = 1.f - std::clamp(blocking(q, y), 0.f, 1.f);
    offsets.clear();
    for (int m = 1; m <= options_.sky_steps; ++m) offsets.push_back(glm::ivec3(glm::floor(1.f + float(m) * w)));
    // Offsets are monotone per axis, so a march leaves the corners at the first step that leaves
    // them along any axis: steps[axis][coordinate] counts the steps inside.
    const int S = int(offsets.size());
    std::array<std::vector<int>, 3> steps;
    for (int a = 0; a < 3; ++a) {
      steps[size_t(a)].assign(size_t(n), S);
      for (int i = 0; i < n; ++i)
        for (int m = 0; m < S; ++m)
          if (i + offsets[size_t(m)][a] < 0 || i + offsets[size_t(m)][a] > n) {
            steps[size_t(a)][size_t(i)] = m;
            break;
          }
    }
    std::vector<ptrdiff_t> delta(static_cast<size_t>(S));
    for (int m = 0; m < S; ++m) {
      const glm::ivec3 o = offsets[size_t(m)];
      delta[size_t(m)] = ptrdiff_t(o.x) + ptrdiff_t(m1) * (ptrdiff_t(o.y) + ptrdiff_t(m1) * ptrdiff_t(o.z));
    }
    uint8_t* out = g.sky_t.data() + size_t(dir) * g.cells;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j) {
        const int jk = std::min(steps[1][size_t(j)], steps[2][size_t(k)]);
        for (int i = 0; i < n; ++i) {
          const int count = std::min(jk, steps[0][size_t(i)]);
          const float* base = pass.data() + g.corner(i, j, k);
          float T = 1.f;
          for (int m = 0; m < count; ++m) T *= base[delta[size_t(m)]];
          out[g.index(i, j, k)] = uint8_t(T * 255.f + 0.5f);
        }
      }
  }
}

void CascadedLpv::setSkyRadiance(int c, const std::array<glm::vec3, kSkyDirections>& L) {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  Cascade& g = cascades_[size_t(c)];
  std::fill(g.sky.begin(), g.sky.end(), 0.f);
  const float w = float(4.0 * sh::kPi / kSkyDirections / 255.0);
  for (int dir = 0; dir < kSkyDirections; ++dir) {
    const sh::Sh4 y = sh::evaluate(skyDirection(dir));
    for (int ch = 0; ch < 3; ++ch)
      for (int k = 0; k < 4; ++k) {
        const float f = L[size_t(dir)][ch] * y[k] * w;
        float* out = g.sky.data() + size_t(ch * 4 + k) * g.cells;
        const uint8_t* t = g.sky_t.data() + size_t(dir) * g.cells;
        for (size_t i = 0; i < g.cells; ++i) out[i] += f * float(t[i]);
      }
  }
}

}  // namespace drtv::lpv
