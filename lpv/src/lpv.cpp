// Cascaded light propagation volumes (lpv.h; references there).
#include "drtv/lpv/lpv.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <thread>

namespace drtv::lpv {
namespace {

// The propagation's loops compiled for the baseline and for AVX2 (no FMA: the same operations in
// the same order, so the same bits), chosen at load time; not under the sanitizers, whose
// run-time is not up when the ifunc resolvers run, nor off x86-64.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(__SANITIZE_ADDRESS__)
#define DRTV_LPV_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define DRTV_LPV_CLONES
#endif

constexpr int kPlanes = 12;  // 3 channels x 4 SH coefficients, plane p = channel * 4 + coefficient

// The 6 propagation directions: the direction light travels from the source neighbour into the
// receiving cell. d = 2 * axis + (0: +, 1: -).
constexpr int kDirs = 6;
glm::ivec3 dirVector(int d) {
  glm::ivec3 v(0);
  v[d / 2] = (d % 2) ? -1 : 1;
  return v;
}
// sh.h's coefficient of each axis: x -> 3 (Y11), y -> 1 (Y1-1), z -> 2 (Y10).
constexpr int kAxisCoeff[3] = {3, 1, 2};

// The sparse propagation matrix of one direction (lpv.h, "Propagation"): with a the axis's
// coefficient and o1, o2 the other two band-1 ones,
//   dst0 += m00 s0 + m0a sa;  dsta += ma0 s0 + maa sa;  dst_o += moo s_o.
// By the symmetry of the 5 faces about the axis every other entry is 0 (checked at build).
struct DirMatrix {
  int a = 0, o1 = 0, o2 = 0;
  float m00 = 0, m0a = 0, ma0 = 0, maa = 0, moo = 0;
};

std::array<DirMatrix, kDirs> buildMatrices() {
  std::array<DirMatrix, kDirs> out{};
  for (int d = 0; d < kDirs; ++d) {
    const glm::vec3 t = glm::vec3(dirVector(d));
    const int axis = d / 2;
    // The far face: towards t, re-emitted about t. The 4 side faces: centres at t +- 0.5 e_side.
    glm::dmat4 M(0.0);  // M[col][row]: dst[row] += M[col][row] * src[col]
    auto addFace = [&](const glm::vec3& towards, const glm::vec3& face_normal, double solid_angle) {
      const sh::Sh4 lobe = sh::cosineLobe(face_normal);
      const sh::Sh4 eval = sh::evaluate(glm::normalize(towards));
      for (int col = 0; col < 4; ++col)
        for (int row = 0; row < 4; ++row) M[col][row] += solid_angle / sh::kPi * double(lobe[row]) * double(eval[col]);
    };
    addFace(t, t, kFarFaceSolidAngle);
    for (int side = 0; side < 3; ++side) {
      if (side == axis) continue;
      for (int s = -1; s <= 1; s += 2) {
        glm::vec3 e(0.f);
        e[side] = float(s);
        addFace(t + 0.5f * e, e, kSideFaceSolidAngle);
      }
    }
    DirMatrix m;
    m.a = kAxisCoeff[axis];
    m.o1 = kAxisCoeff[(axis + 1) % 3];
    m.o2 = kAxisCoeff[(axis + 2) % 3];
    m.m00 = float(M[0][0]), m.m0a = float(M[m.a][0]), m.ma0 = float(M[0][m.a]), m.maa = float(M[m.a][m.a]);
    m.moo = float(M[m.o1][m.o1]);
    DRTV_CHECK(std::abs(M[m.o1][m.o1] - M[m.o2][m.o2]) < 1e-6);
    for (int col = 0; col < 4; ++col)
      for (int row = 0; row < 4; ++row) {
        const bool kept = (row == 0 && (col == 0 || col == m.a)) || (row == m.a && (col == 0 || col == m.a)) ||
                          (row == col && (row == m.o1 || row == m.o2));
        if (!kept) DRTV_CHECK(std::abs(M[col][row]) < 1e-6);
      }
    out[size_t(d)] = m;
  }
  return out;
}

const std::array<DirMatrix, kDirs>& matrices() {
  static const std::array<DirMatrix, kDirs> m = buildMatrices();
  return m;
}

}  // namespace

struct CascadedLpv::Cascade {
  CascadeBox box;
  int n = 0;
  size_t cells = 0;
  std::vector<float> injected;   // kPlanes x cells
  std::vector<float> light;      // kPlanes x cells: injected + every step
  std::vector<float> last_step;  // band-0 of the last step, per channel (3 x cells): tests
  std::vector<float> geometry;   // 4 x (n+1)^3 blocking potential SH on the corners
  std::vector<float> face_t;     // kDirs x cells: transmittance of light entering through that face
  std::vector<uint8_t> sky_t;    // kSkyDirections x cells, T in 1/255
  std::vector<float> sky;        // kPlanes x cells: visible sky radiance SH
  size_t index(int i, int j, int k) const { return size_t(i) + size_t(n) * (size_t(j) + size_t(n) * size_t(k)); }
  size_t corner(int i, int j, int k) const {
    const size_t m = size_t(n) + 1;
    return size_t(i) + m * (size_t(j) + m * size_t(k));
  }
};

std::string validate(const LpvOptions& o) {
  if (o.cascades < 1 || o.cascades > 8) return "cascades: expected an integer in [1, 8]";
  if (o.cells < 4 || o.cells > 128 || o.cells % 2) return "cells: expected an even integer in [4, 128]";
  if (!(o.cell_m > 0 && o.cell_m <= 1e4)) return "cell_m: expected metres in (0, 1e4]";
  if (!(o.ratio >= 1.5 && o.ratio <= 4)) return "ratio: expected a number in [1.5, 4]";
  if (o.iterations < 0 || o.iterations > 256) return "iterations: expected an integer in [0, 256]";
  if (o.sky_steps < 0 || o.sky_steps > o.cells) return "sky_steps: expected an integer in [0, cells]";
  if (!(o.lookup_offset_cells >= 0 && o.lookup_offset_cells <= 2)) return "lookup_offset_cells: expected cells in [0, 2]";
  if (!(o.blend_cells >= 0 && o.blend_cells <= float(o.cells) / 4)) return "blend_cells: expected cells in [0, cells / 4]";
  if (o.threads < 1 || o.threads > 64) return "threads: expected an integer in [1, 64]";
  return "";
}

CascadedLpv::CascadedLpv(const LpvOptions& o) : options_(o) {
  const int n = o.cells;
  const size_t cells = size_t(n) * size_t(n) * size_t(n);
  const size_t corners = size_t(n + 1) * size_t(n + 1) * size_t(n + 1);
  cascades_.resize(size_t(o.cascades));
  double s = o.cell_m;
  for (Cascade& c : cascades_) {
    c.n = n;
    c.cells = cells;
    c.box.cell_m = s;
    c.box.cells = n;
    c.injected.assign(kPlanes * cells, 0.f);
    c.light.assign(kPlanes * cells, 0.f);
    c.last_step.assign(3 * cells, 0.f);
    c.geometry.assign(4 * corners, 0.f);
    c.face_t.assign(kDirs * cells, 1.f);
    c.sky_t.assign(kSkyDirections * cells, 255);
    c.sky.assign(kPlanes * cells, 0.f);
    s *= o.ratio;
  }
  const size_t padded = size_t(n + 2) * size_t(n + 2) * size_t(n + 2);
  step_a_.assign(kPlanes * padded, 0.f);
  step_b_.assign(kPlanes * padded, 0.f);
  lit_a_.assign(3 * size_t(n + 2) * size_t(n + 2), 0);
  lit_b_.assign(3 * size_t(n + 2) * size_t(n + 2), 0);
}

CascadedLpv::CascadedLpv(CascadedLpv&&) noexcept = default;
CascadedLpv& CascadedLpv::operator=(CascadedLpv&&) noexcept = default;
CascadedLpv::~CascadedLpv() = default;

Result<CascadedLpv> CascadedLpv::create(const LpvOptions& options) {
  if (std::string e = validate(options); !e.empty()) return fail("lpv options: " + e);
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
  Cascade& g = cascades_[size_t(c)];
  std::fill(g.injected.begin(), g.injected.end(), 0.f);
  std::fill(g.light.begin(), g.light.end(), 0.f);  // until the next propagate
}

void CascadedLpv::injectLight(int c, std::span<const Surfel> surfels) {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  Cascade& g = cascades_[size_t(c)];
  const double s = g.box.cell_m, inv_s = 1.0 / s;
  const float scale = float(1.0 / (double(sh::kPi) * s * s));
  float* planes = g.injected.data();
  for (const Surfel& v : surfels) {
    // Half a cell along the normal [1] sec. 4.1: the VPL lights the space in front of it.
    const glm::dvec3 p = (v.position - g.box.min) * inv_s + 0.5 * glm::dvec3(v.normal);
    if (!(p.x >= 0 && p.y >= 0 && p.z >= 0 && p.x < g.n && p.y < g.n && p.z < g.n)) continue;
    const size_t idx = g.index(int(p.x), int(p.y), int(p.z));
    const sh::Sh4 lobe = sh::cosineLobe(v.normal) * scale;
    for (int ch = 0; ch < 3; ++ch) {
      float* q = planes + size_t(ch * 4) * g.cells + idx;
      const float f = v.flux[ch];
      q[0] += f * lobe.x;
      q[g.cells] += f * lobe.y;
      q[2 * g.cells] += f * lobe.z;
      q[3 * g.cells] += f * lobe.w;
    }
  }
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

namespace {

// One propagation step of one channel over a grid padded by one zero cell on every side (so that
// every interior cell has its 6 neighbours without a bounds check): out = sum over the 6
// directions of transmittance x matrix x the neighbour's 4 coefficients (lpv.h, "Propagation").
// `src[q]`, `dst[q]`: the padded planes of coefficient q; `tr[d]`: the unpadded transmittance
// planes (null: no occlusion); `light[q]`: the unpadded accumulation planes, += the step.
// Rows (j, k) are skipped when neither they nor their 4 neighbour rows hold light in `src`
// (`lit_src`, padded (n+2)^2 flags), and `lit_dst` records which rows the step lit. Slabs
// [k0, k1) let threads share a step. AVX2 where the CPU has it (no FMA: -ffp-contract=off, so
// the same bits as SSE2).
DRTV_LPV_CLONES
void propagateChannel(int n, int k0, int k1, const std::array<const float*, 4>& src, const std::array<float*, 4>& dst,
                      const std::array<const float*, kDirs>& tr, const std::array<float*, 4>& light,
                      const uint8_t* lit_src, uint8_t* lit_dst) {
  const auto& mats = matrices();
  const ptrdiff_t np = n + 2;
  const ptrdiff_t off[kDirs] = {1, -1, np, -np, np * np, -np * np};  // source = cell - off
  for (int k = k0; k < k1; ++k)
    for (int j = 0; j < n; ++j) {
      const size_t row_u = size_t(n) * (size_t(j) + size_t(n) * size_t(k));
      const size_t row_p = size_t(1 + np * ((j + 1) + np * (k + 1)));
      const size_t r = size_t((j + 1) + np * (k + 1));
      if (!(lit_src[r] | lit_src[r - 1] | lit_src[r + 1] | lit_src[r - size_t(np)] | lit_src[r + size_t(np)])) {
        if (lit_dst[r]) {  // what the buffer held two steps ago
          for (int q = 0; q < 4; ++q) std::fill_n(dst[size_t(q)] + row_p, n, 0.f);
        }
        lit_dst[r] = 0;
        continue;
      }
      lit_dst[r] = 1;
      float o[4][128];
      for (int q = 0; q < 4; ++q)
        for (int i = 0; i < n; ++i) o[q][i] = 0.f;
      for (int d = 0; d < kDirs; ++d) {
        const DirMatrix& m = mats[size_t(d)];
        const float* __restrict s0 = src[0] + row_p - off[d];
        const float* __restrict sa = src[size_t(m.a)] + row_p - off[d];
        const float* __restrict s1 = src[size_t(m.o1)] + row_p - off[d];
        const float* __restrict s2 = src[size_t(m.o2)] + row_p - off[d];
        float* __restrict o0 = o[0];
        float* __restrict oa = o[m.a];
        float* __restrict o1 = o[m.o1];
        float* __restrict o2 = o[m.o2];
        if (tr[size_t(d)]) {
          const float* __restrict t = tr[size_t(d)] + row_u;
          for (int i = 0; i < n; ++i) {
            const float f = t[i], a0 = s0[i], aa = sa[i];
            o0[i] += f * (m.m00 * a0 + m.m0a * aa);
            oa[i] += f * (m.ma0 * a0 + m.maa * aa);
            o1[i] += f * m.moo * s1[i];
            o2[i] += f * m.moo * s2[i];
          }
        } else {
          for (int i = 0; i < n; ++i) {
            const float a0 = s0[i], aa = sa[i];
            o0[i] += m.m00 * a0 + m.m0a * aa;
            oa[i] += m.ma0 * a0 + m.maa * aa;
            o1[i] += m.moo * s1[i];
            o2[i] += m.moo * s2[i];
          }
        }
      }
      for (int q = 0; q < 4; ++q) {
        float* __restrict out = dst[size_t(q)] + row_p;
        float* __restrict acc = light[size_t(q)] + row_u;
        for (int i = 0; i < n; ++i) {
          out[i] = o[q][i];
          acc[i] += o[q][i];
        }
      }
    }
}

}  // namespace

void CascadedLpv::propagate(int c) {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  Cascade& g = cascades_[size_t(c)];
  const int n = g.n;
  const size_t N = g.cells;
  const size_t np = size_t(n) + 2, P = np * np * np;
  g.light = g.injected;
  // The padded step buffers: borders are never written (nothing enters from outside the grid);
  // lit_a_ / lit_b_ say which interior rows of each may hold light, so rows that hold none are
  // neither computed nor cleared. The injected light overwrites every interior row of step_a_.
  for (int q = 0; q < kPlanes; ++q)
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j) {
        const float* in = g.injected.data() + size_t(q) * N + g.index(0, j, k);
        std::copy_n(in, n, step_a_.data() + size_t(q) * P + 1 + np * (size_t(j + 1) + np * size_t(k + 1)));
      }
  for (int ch = 0; ch < 3; ++ch)
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j) {
        bool any = false;
        for (int q = 0; q < 4; ++q) {
          const float* in = g.injected.data() + size_t(ch * 4 + q) * N + g.index(0, j, k);
          any = any || std::any_of(in, in + n, [](float v) { return v != 0.f; });
        }
        lit_a_[size_t(ch) * np * np + size_t(j + 1) + np * size_t(k + 1)] = any;
      }
  float* cur = step_a_.data();
  float* next = step_b_.data();
  uint8_t* lit_cur = lit_a_.data();
  uint8_t* lit_next = lit_b_.data();
  const int threads = std::clamp(options_.threads, 1, n);
  for (int it = 1; it <= options_.iterations; ++it) {
    const bool occluded = options_.occlusion && it >= 2;
    std::array<const float*, kDirs> tr{};
    for (int d = 0; d < kDirs; ++d) tr[size_t(d)] = occluded ? g.face_t.data() + size_t(d) * N : nullptr;
    auto slab = [&](int k0, int k1) {
      for (int ch = 0; ch < 3; ++ch) {
        std::array<const float*, 4> src;
        std::array<float*, 4> dst, light;
        for (int q = 0; q < 4; ++q) {
          src[size_t(q)] = cur + size_t(ch * 4 + q) * P;
          dst[size_t(q)] = next + size_t(ch * 4 + q) * P;
          light[size_t(q)] = g.light.data() + size_t(ch * 4 + q) * N;
        }
        propagateChannel(n, k0, k1, src, dst, tr, light, lit_cur + size_t(ch) * np * np, lit_next + size_t(ch) * np * np);
      }
    };
    if (threads == 1) {
      slab(0, n);
    } else {
      // Slabs of z write disjoint rows of `next`, `light` and the flags: no synchronisation
      // beyond the join; the sums per cell are the same whatever the slabs.
      std::vector<std::thread> pool;
      for (int t = 1; t < threads; ++t) pool.emplace_back(slab, n * t / threads, n * (t + 1) / threads);
      slab(0, n / threads);
      for (std::thread& th : pool) th.join();
    }
    std::swap(cur, next);
    std::swap(lit_cur, lit_next);
  }
  // The last step's band 0 (tests): what `cur` holds now, unpadded.
  for (int ch = 0; ch < 3; ++ch)
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j) {
        float* out = g.last_step.data() + size_t(ch) * N + g.index(0, j, k);
        if (options_.iterations == 0) std::fill_n(out, n, 0.f);
        else std::copy_n(cur + size_t(ch * 4) * P + 1 + np * (size_t(j + 1) + np * size_t(k + 1)), n, out);
      }
}

namespace {
// Trilinear over the cell centres of planes [p0, p1) at cell coordinates u (clamped to the grid).
template <class Grid>
void trilinear(const Grid& g, const std::vector<float>& planes, const glm::dvec3& u, int p0, int p1, float* acc) {
  const glm::dvec3 uc = glm::clamp(u, glm::dvec3(0.0), glm::dvec3(g.n - 1));
  const glm::ivec3 i0 = glm::min(glm::ivec3(glm::floor(uc)), glm::ivec3(g.n - 2));
  const glm::vec3 f = glm::vec3(uc - glm::dvec3(i0));
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx) {
        const float w = (dx ? f.x : 1.f - f.x) * (dy ? f.y : 1.f - f.y) * (dz ? f.z : 1.f - f.z);
        if (w == 0.f) continue;
        const size_t idx = g.index(i0.x + dx, i0.y + dy, i0.z + dz);
        for (int p = p0; p < p1; ++p) acc[p] += w * planes[size_t(p) * g.cells + idx];
      }
}
}  // namespace

glm::vec3 CascadedLpv::lookup(int c, const glm::dvec3& position, const glm::vec3& normal, bool sky) const {
  const Cascade& g = cascades_[size_t(c)];
  const double s = g.box.cell_m;
  const glm::dvec3 u = (position + double(options_.lookup_offset_cells) * s * glm::dvec3(normal) - g.box.min) / s - 0.5;
  const std::vector<float>& planes = sky ? g.sky : g.light;
  std::array<float, kPlanes> acc{};
  trilinear(g, planes, u, 0, kPlanes, acc.data());
  const sh::Sh4 lobe = sh::cosineLobe(sky ? normal : -normal);
  glm::vec3 e;
  for (int ch = 0; ch < 3; ++ch)
    e[ch] = lobe.x * acc[size_t(ch * 4)] + lobe.y * acc[size_t(ch * 4 + 1)] + lobe.z * acc[size_t(ch * 4 + 2)] +
            lobe.w * acc[size_t(ch * 4 + 3)];
  if (!sky && options_.damping) {
    // Damping against self-bleeding [1] (seed 003, "Final scene rendering": "dampen based on
    // the gradient's deviation from the intensity distribution's direction"): light that a
    // surface receives travels towards it, so where the cell's light mostly travels out of the
    // surface (its band-1 direction d along the normal, n.d > 0), it is the surface's own or its
    // plane's, and is scaled by 1 - n.d.
    for (int ch = 0; ch < 3; ++ch) {
      const glm::vec3 d(acc[size_t(ch * 4 + 3)], acc[size_t(ch * 4 + 1)], acc[size_t(ch * 4 + 2)]);
      const float len = glm::length(d);
      if (len > 0.f) e[ch] *= 1.f - std::max(0.f, glm::dot(normal, d) / len);
    }
  }
  return e;
}

namespace {
// The share of cascade c that a point at cell coordinates u keeps before the next cascade takes
// over: 1 deep inside, falling to 0 over `blend` cells at the border.
float keepWeight(const glm::dvec3& u, int n, float blend) {
  double edge = 1e30;
  for (int a = 0; a < 3; ++a) edge = std::min({edge, u[a] + 0.5, double(n) - 0.5 - u[a]});
  if (blend <= 0.f) return edge > 0 ? 1.f : 0.f;
  return float(std::clamp((edge - 0.5) / double(blend), 0.0, 1.0));
}
}  // namespace

glm::vec3 CascadedLpv::blended(const glm::dvec3& position, const glm::vec3& normal, bool sky) const {
  glm::vec3 out(0.f);
  float rest = 1.f;
  for (int c = 0; c < cascadeCount() && rest > 0.f; ++c) {
    const Cascade& g = cascades_[size_t(c)];
    if (!g.box.contains(position)) continue;
    const glm::dvec3 u = (position - g.box.min) / g.box.cell_m - 0.5;
    const float w = c + 1 == cascadeCount() ? 1.f : keepWeight(u, g.n, options_.blend_cells);
    if (w <= 0.f) continue;
    out += rest * w * lookup(c, position, normal, sky);
    rest *= 1.f - w;
  }
  return glm::max(out, glm::vec3(0.f));
}

glm::vec3 CascadedLpv::indirect(const glm::dvec3& position, const glm::vec3& normal) const { return blended(position, normal, false); }

glm::vec3 CascadedLpv::sky(const glm::dvec3& position, const glm::vec3& normal) const { return blended(position, normal, true); }

glm::vec3 CascadedLpv::indirectIn(int c, const glm::dvec3& position, const glm::vec3& normal) const {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  return glm::max(lookup(c, position, normal, false), glm::vec3(0.f));
}

glm::vec3 CascadedLpv::skyIn(int c, const glm::dvec3& position, const glm::vec3& normal) const {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  return glm::max(lookup(c, position, normal, true), glm::vec3(0.f));
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
  size_t b = (step_a_.size() + step_b_.size()) * sizeof(float);
  for (const Cascade& c : cascades_)
    b += (c.injected.size() + c.light.size() + c.last_step.size() + c.geometry.size() + c.face_t.size() + c.sky.size()) *
             sizeof(float) +
         c.sky_t.size();
  return b;
}

}  // namespace drtv::lpv
