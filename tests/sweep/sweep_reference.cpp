// The slow reference for the sweep (tests only): sweep/src/sweep.cpp as issue 15 first built it,
// before the sweep was restructured for speed (exp of each path's summed optical depth per cell and
// direction, the per-cell reflection for every cell, one packing call per value). Its model is
// sweep.h's; the optimised sweep must agree with it up to float rounding (sweep_test.cpp,
// OptimisedSweepAgreesWithTheReference). Keep it as it is: it is the yardstick, not a second
// implementation to maintain.
// Layout: every per-level buffer is a padded plane of (nx + 2 kPad) x (ny + 2 kPad) floats, one
// plane per direction and channel; the pad ring holds the edges' light.
#include "sweep_reference.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <glm/gtc/packing.hpp>

#include "drtv/formats/error.h"

namespace drtv::sweep::reference {
namespace {

constexpr int kPad = kNearHorizontalStep + 1;  // the farthest source: 4 sideways + 1 smoothing tap
constexpr int kTaps = 5;
constexpr float kFourPi = 12.566370614359172f;
constexpr float kInf = std::numeric_limits<float>::infinity();

// A material cell a gathered path crosses between its source and its target: offset from the
// target, on the target's level (src_level false) or the source's, and the length in cell units.
struct Crossed {
  int dx, dy;
  bool src_level;
  float len;
};
struct Tap {
  int ox, oy;  // source offset from the target, cells
  float w;
  std::vector<Crossed> crossed;
};
struct BinPath {
  int bin;
  std::array<Tap, kTaps> taps;
  float target_len;  // the path length the target cell itself attenuates
};

BinPath makePath(int bin, float smoothing) {
  const glm::ivec3 st = directions()[size_t(bin)].sweep_step;
  static constexpr int kTx[kTaps] = {0, 1, -1, 0, 0}, kTy[kTaps] = {0, 0, 0, 1, -1};
  BinPath p;
  p.bin = bin;
  for (int j = 0; j < kTaps; ++j) {
    Tap& t = p.taps[size_t(j)];
    t.ox = -st.x + kTx[j];
    t.oy = -st.y + kTy[j];
    t.w = j == 0 ? smoothing : (1.f - smoothing) / 4.f;
    // The segment between the centres, sampled at 512 midpoints: a cell's length is its samples'.
    const glm::dvec3 a(t.ox, t.oy, -st.z);
    constexpr int kSamples = 512;
    const double step_len = glm::length(a) / kSamples;
    for (int m = 0; m < kSamples; ++m) {
      const glm::dvec3 q = a * (1.0 - (m + 0.5) / kSamples);
      const glm::ivec3 c(glm::floor(q + 0.5));
      if (c == glm::ivec3(a) || c == glm::ivec3(0)) continue;
      auto it = std::find_if(t.crossed.begin(), t.crossed.end(),
                             [&](const Crossed& x) { return x.dx == c.x && x.dy == c.y && x.src_level == (c.z != 0); });
      if (it == t.crossed.end()) t.crossed.push_back({c.x, c.y, c.z != 0, 0.f}), it = t.crossed.end() - 1;
      it->len += float(step_len);
    }
  }
  float crossed = 0;
  for (const Crossed& c : p.taps[0].crossed) crossed += c.len;
  p.target_len = float(glm::length(glm::dvec3(st))) - crossed;
  return p;
}

float luminance(const glm::vec3& c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; }

// The edges' light: the open sky, or a coarser grid decoded once around this one.
class Edges {
 public:
  Edges(const GridShape& g, const SkyInput& sky, const SweptGrid* parent) : g_(g), sky_(sky), parent_(parent) {
    if (!parent_) return;
    DRTV_CHECK(parent_->light_has_direct || parent_->direct.has_value());
    const GridShape& p = parent_->light.shape;
    const glm::dvec3 lo = g.origin - double(kPad + 1) * g.cell_m, hi = g.max() + double(kPad + 1) * g.cell_m;
    i0_ = std::clamp(int(std::floor((lo.x - p.origin.x) / p.cell_m - 0.5)), 0, p.size.x - 1);
    j0_ = std::clamp(int(std::floor((lo.y - p.origin.y) / p.cell_m - 0.5)), 0, p.size.y - 1);
    const int i1 = std::clamp(int(std::floor((hi.x - p.origin.x) / p.cell_m - 0.5)) + 1, 0, p.size.x - 1);
    const int j1 = std::clamp(int(std::floor((hi.y - p.origin.y) / p.cell_m - 0.5)) + 1, 0, p.size.y - 1);
    ni_ = i1 - i0_ + 1;
    nj_ = j1 - j0_ + 1;
    full_.resize(size_t(ni_) * nj_ * p.size.z);
    direct_.resize(full_.size());
    for (int k = 0; k < p.size.z; ++k)
      for (int j = 0; j < nj_; ++j)
        for (int i = 0; i < ni_; ++i) {
          const size_t src = p.index(i0_ + i, j0_ + j, k), dst = (size_t(k) * nj_ + j) * ni_ + i;
          LightVector d{};
          if (parent_->direct) d = parent_->direct->cell(src);
          LightVector f = parent_->light.cell(src);
          if (!parent_->light_has_direct)
            for (int b = 0; b < kDirections; ++b) f[size_t(b)] += d[size_t(b)];
          full_[dst] = f;
          direct_[dst] = d;
        }
  }

  // The light of the cells (i, j) in `cells` at grid level k (may be -1 or size.z) for `bins`,
  // into planes[b * 3 + c][plane index].
  struct Cell {
    int i, j;
    size_t plane;
  };
  void fill(int k, bool direct, const std::vector<int>& bins, const std::vector<Cell>& cells, std::vector<float>& planes,
            size_t plane_size) {
    const size_t nb = bins.size();
    if (!parent_) {
      for (size_t b = 0; b < nb; ++b) {
        const int bin = bins[b];
        const glm::vec3 v = direct ? sky_.sun[size_t(bin)] : sky_.sky[size_t(bin)] + sky_.sun[size_t(bin)];
        for (int c = 0; c < 3; ++c)
          for (const Cell& cell : cells) planes[(b * 3 + size_t(c)) * plane_size + cell.plane] = v[c];
      }
      return;
    }
    const GridShape& p = parent_->light.shape;
    // The parent's columns interpolated to this level's height once, then bilinear per cell.
    const double zc = g_.origin.z + (k + 0.5) * g_.cell_m;
    const std::vector<LightVector>& src = direct ? direct_ : full_;
    slice_.resize(size_t(ni_) * nj_);
    for (size_t col = 0; col < slice_.size(); ++col) {
      const size_t pcol = size_t(i0_) + col % size_t(ni_) + size_t(p.size.x) * (size_t(j0_) + col / size_t(ni_));
      const double z = parent_->clear_z.empty() ? zc : std::max(zc, double(parent_->clear_z[pcol]));
      const double u = std::clamp((z - p.origin.z) / p.cell_m - 0.5, 0.0, double(p.size.z - 1));
      const int k0 = std::min(int(u), p.size.z - 1), k1 = std::min(k0 + 1, p.size.z - 1);
      const float fz = float(u - k0);
      for (size_t b = 0; b < nb; ++b) {
        const size_t bin = size_t(bins[b]);
        slice_[col][bin] = src[size_t(k0) * slice_.size() + col][bin] * (1 - fz) + src[size_t(k1) * slice_.size() + col][bin] * fz;
      }
    }
    for (const Cell& cell : cells) {
      const glm::dvec3 w = g_.centre(cell.i, cell.j, 0);
      const double ux = std::clamp((w.x - p.origin.x) / p.cell_m - 0.5 - i0_, 0.0, double(ni_ - 1));
      const double uy = std::clamp((w.y - p.origin.y) / p.cell_m - 0.5 - j0_, 0.0, double(nj_ - 1));
      const int a0 = std::min(int(ux), ni_ - 1), a1 = std::min(a0 + 1, ni_ - 1);
      const int b0 = std::min(int(uy), nj_ - 1), b1 = std::min(b0 + 1, nj_ - 1);
      const float fx = float(ux - a0), fy = float(uy - b0);
      const LightVector& s00 = slice_[size_t(b0) * ni_ + a0];
      const LightVector& s10 = slice_[size_t(b0) * ni_ + a1];
      const LightVector& s01 = slice_[size_t(b1) * ni_ + a0];
      const LightVector& s11 = slice_[size_t(b1) * ni_ + a1];
      for (size_t b = 0; b < nb; ++b) {
        const size_t bin = size_t(bins[b]);
        const glm::vec3 v = (s00[bin] * (1 - fx) + s10[bin] * fx) * (1 - fy) + (s01[bin] * (1 - fx) + s11[bin] * fx) * fy;
        for (int c = 0; c < 3; ++c) planes[(b * 3 + size_t(c)) * plane_size + cell.plane] = v[c];
      }
    }
  }

 private:
  GridShape g_;
  SkyInput sky_;
  const SweptGrid* parent_;
  int i0_ = 0, j0_ = 0, ni_ = 0, nj_ = 0;
  std::vector<LightVector> full_, direct_, slice_;
};

// One stream of light through the grid: a set of directions, its ping-pong level buffers.
struct Pass {
  std::vector<int> bins;
  std::vector<BinPath> paths;
  bool direct = false;
  std::vector<float> src, dst;  // bins.size() * 3 planes
  std::vector<float> acc;       // bins.size() * 3 rows of nx: one row's gathered light
};

class Sweeper {
 public:
  Sweeper(const MaterialGrid& m, const SkyInput& sky, const SweptGrid* parent, const SweepOptions& o)
      : m_(m), g_(m.shape), o_(o), edges_(m.shape, sky, parent) {
    DRTV_CHECK(g_.size.x >= 1 && g_.size.y >= 1 && g_.size.z >= 1 && g_.cell_m > 0);
    DRTV_CHECK_EQ(m.density.size(), g_.cellCount());
    DRTV_CHECK_EQ(m.reflectance.size(), g_.cellCount());
    w_ = g_.size.x + 2 * kPad;
    h_ = g_.size.y + 2 * kPad;
    plane_ = size_t(w_) * size_t(h_);
    // Optical depth per cell length, padded; outside the grid's sides: clear.
    sigma_.assign(plane_ * size_t(g_.size.z), 0.f);
    level_has_material_.assign(size_t(g_.size.z), 0);
    for (int k = 0; k < g_.size.z; ++k)
      for (int j = 0; j < g_.size.y; ++j)
        for (int i = 0; i < g_.size.x; ++i) {
          const float d = m.density[g_.index(i, j, k)];
          DRTV_CHECK(d >= 0.f && d <= 1.f);
          const float s = d >= 1.f ? kInf : -std::log1p(-d);
          sigma_[size_t(k) * plane_ + size_t(j + kPad) * size_t(w_) + size_t(i + kPad)] = s;
          if (s > 0) level_has_material_[size_t(k)] = 1;
        }
    // Sealed cells: full, and so are their neighbours in the grid (above its top: open; past its
    // sides and below its bottom: full).
    sealed_.assign(g_.cellCount(), 0);
    auto full = [&](int i, int j, int k) {
      if (k >= g_.size.z) return false;
      if (i < 0 || j < 0 || i >= g_.size.x || j >= g_.size.y || k < 0) return true;
      return m.density[g_.index(i, j, k)] >= 1.f;
    };
    for (int k = 0; k < g_.size.z; ++k)
      for (int j = 0; j < g_.size.y; ++j)
        for (int i = 0; i < g_.size.x; ++i) {
          bool all = true;
          for (int dk = -1; dk <= 1; ++dk)
            for (int dj = -1; dj <= 1; ++dj)
              for (int di = -1; di <= 1; ++di) all = all && full(i + di, j + dj, k + dk);
          sealed_[g_.index(i, j, k)] = all;
        }
    for (int j = -kPad; j < g_.size.y + kPad; ++j)
      for (int i = -kPad; i < g_.size.x + kPad; ++i) {
        const size_t pi = size_t(j + kPad) * size_t(w_) + size_t(i + kPad);
        all_cells_.push_back({i, j, pi});
        if (i < 0 || j < 0 || i >= g_.size.x || j >= g_.size.y) ring_cells_.push_back({i, j, pi});
      }
    const auto& dirs = directions();
    for (int b = 0; b < kDirections; ++b) {
      float a = 0;
      for (int o = 0; o < kDirections; ++o)
        a += dirs[size_t(o)].solid_angle_sr * glm::dot(dirs[size_t(o)].travel, dirs[size_t(b)].travel);
      cos_sum_[size_t(b)] = a;
    }
    full_.direct = false;
    for (int b = 0; b < kSwept; ++b) full_.bins.push_back(b);
    direct_.direct = true;
    if (!o_.direct_sun || o_.keep_direct)
      for (int b = 0; b < kSwept; ++b)
        if (sky.sun[size_t(b)] != glm::vec3(0.f)) direct_.bins.push_back(b);
    for (Pass* p : {&full_, &direct_}) setUp(*p);
    up_.direct = false;
    for (int b = kSwept; b < kDirections; ++b) up_.bins.push_back(b);
    if (o_.bottom_up) setUp(up_);
  }

  SweptGrid run(const SkyInput& sky) {
    SweptGrid out;
    out.sky = sky;
    out.light_has_direct = o_.direct_sun;
    out.light.shape = g_;
    out.light.light.assign(g_.cellCount() * kDirections, 0);
    out.light.average.assign(g_.cellCount(), 0);
    out.light.dominant.assign(g_.cellCount(), 0);
    if (o_.keep_direct) {
      out.direct.emplace();
      out.direct->shape = g_;
      out.direct->light.assign(g_.cellCount() * kDirections, 0);
      out.direct->average.assign(g_.cellCount(), 0);
      out.direct->dominant.assign(g_.cellCount(), 0);
    }
    avg_.assign(g_.cellCount(), glm::vec4(0.f));
    dom_.assign(g_.cellCount(), glm::vec3(0.f));
    emission_index_.assign(g_.cellCount(), -1);
    emission_.clear();
    const int nz = g_.size.z;
    if (!m_.ground_z.empty()) {
      DRTV_CHECK_EQ(m_.ground_z.size(), size_t(g_.size.x) * size_t(g_.size.y));
      out.clear_z.resize(m_.ground_z.size());
      for (size_t c = 0; c < m_.ground_z.size(); ++c) {
        const int k = std::clamp(int(std::ceil((double(m_.ground_z[c]) - g_.origin.z) / g_.cell_m)), 0, nz - 1);
        out.clear_z[c] = float(g_.origin.z + (k + 0.5) * g_.cell_m);
      }
    }
    for (Pass* p : {&full_, &direct_})
      if (!p->bins.empty()) edges_.fill(nz, p->direct, p->bins, all_cells_, p->src, plane_);
    for (int k = nz - 1; k >= 0; --k) {
      for (Pass* p : {&full_, &direct_})
        if (!p->bins.empty()) edges_.fill(k, p->direct, p->bins, ring_cells_, p->dst, plane_);
      level(k, out);
      for (Pass* p : {&full_, &direct_}) std::swap(p->src, p->dst);
    }
    upGoing(out);
    return out;
  }

 private:
  void setUp(Pass& p) {
    for (int b : p.bins) p.paths.push_back(makePath(b, o_.smoothing));
    p.src.assign(p.bins.size() * 3 * plane_, 0.f);
    p.dst = p.src;
    p.acc.assign(p.bins.size() * 3 * size_t(g_.size.x), 0.f);
  }

  // Gathers row j of level k (source level k_src) into p.acc.
  void gather(Pass& p, int k, int k_src, int j) {
    const int nx = g_.size.x;
    std::fill(p.acc.begin(), p.acc.end(), 0.f);
    const bool material = level_has_material_[size_t(k)] || (k_src >= 0 && k_src < g_.size.z && level_has_material_[size_t(k_src)]);
    const float* sig_t = sigma_.data() + size_t(k) * plane_;
    const float* sig_s = (k_src >= 0 && k_src < g_.size.z) ? sigma_.data() + size_t(k_src) * plane_ : nullptr;
    od_.resize(size_t(nx));
    for (size_t b = 0; b < p.bins.size(); ++b) {
      const BinPath& path = p.paths[b];
      for (const Tap& t : path.taps) {
        const size_t row = size_t(j + kPad + t.oy) * size_t(w_) + size_t(kPad + t.ox);
        bool any = false;
        if (material && !t.crossed.empty()) {
          std::fill(od_.begin(), od_.end(), 0.f);
          for (const Crossed& c : t.crossed) {
            const float* s = c.src_level ? sig_s : sig_t;
            if (!s) continue;
            s += size_t(j + kPad + c.dy) * size_t(w_) + size_t(kPad + c.dx);
            for (int x = 0; x < nx; ++x) od_[size_t(x)] += c.len * s[x];
          }
          for (int x = 0; x < nx; ++x) any |= od_[size_t(x)] > 0.f;
        }
        for (int c = 0; c < 3; ++c) {
          const float* s = p.src.data() + (b * 3 + size_t(c)) * plane_ + row;
          float* a = p.acc.data() + (b * 3 + size_t(c)) * size_t(nx);
          if (any)
            for (int x = 0; x < nx; ++x) a[x] += t.w * std::exp(-od_[size_t(x)]) * s[x];
          else
            for (int x = 0; x < nx; ++x) a[x] += t.w * s[x];
        }
      }
    }
    // A sealed cell gathers nothing (sweep.h).
    for (int x = 0; x < nx; ++x)
      if (sealed_[g_.index(x, j, k)])
        for (size_t plane = 0; plane < p.bins.size() * 3; ++plane) p.acc[plane * size_t(nx) + size_t(x)] = 0.f;
  }

  void level(int k, SweptGrid& out) {
    const int nx = g_.size.x, ny = g_.size.y;
    const auto& dirs = directions();
    const float* sig = sigma_.data() + size_t(k) * plane_;
    std::array<glm::vec3, kSwept> stored_full, stored_direct, in, tr;
    std::array<float, kSwept> trans{};
    for (int j = 0; j < ny; ++j) {
      gather(full_, k, k + 1, j);
      if (!direct_.bins.empty()) gather(direct_, k, k + 1, j);
      for (int i = 0; i < nx; ++i) {
        const size_t cell = g_.index(i, j, k);
        const size_t pi = size_t(j + kPad) * size_t(w_) + size_t(i + kPad);
        const float s = sig[pi];
        for (int b = 0; b < kSwept; ++b)
          for (int c = 0; c < 3; ++c) in[size_t(b)][c] = full_.acc[(size_t(b) * 3 + size_t(c)) * size_t(nx) + size_t(i)];
        if (s == 0.f) {
          for (int b = 0; b < kSwept; ++b) {
            stored_full[size_t(b)] = in[size_t(b)];
            for (int c = 0; c < 3; ++c) full_.dst[(size_t(b) * 3 + size_t(c)) * plane_ + pi] = in[size_t(b)][c];
          }
        } else {
          const float tau = std::exp(-s);
          const glm::vec3 rho = m_.reflectance[cell];
          glm::vec3 sum(0.f);
          glm::mat3 q(0.f);  // columns x, y, z of sum_i q_i travel_i, per channel in rows
          for (int b = 0; b < kSwept; ++b) {
            const float t = std::exp(-s * full_.paths[size_t(b)].target_len);
            trans[size_t(b)] = t;
            tr[size_t(b)] = in[size_t(b)] * t;
            const float norm = kFourPi - 0.5f * (1.f - tau) * (kFourPi + cos_sum_[size_t(b)]);
            const glm::vec3 qi = in[size_t(b)] * ((1.f - t) / norm);
            sum += qi;
            const glm::vec3& u = dirs[size_t(b)].travel;
            q[0] += qi * u.x;
            q[1] += qi * u.y;
            q[2] += qi * u.z;
          }
          const float fa = 0.5f * (1.f + tau), fb = 0.5f * (1.f - tau);
          auto reflected = [&](int o) {
            const glm::vec3& u = dirs[size_t(o)].travel;
            const glm::vec3 dq = q[0] * u.x + q[1] * u.y + q[2] * u.z;
            return rho * dirs[size_t(o)].solid_angle_sr * (fa * sum - fb * dq);
          };
          for (int b = 0; b < kSwept; ++b) {
            const glm::vec3 r = reflected(b);
            stored_full[size_t(b)] = in[size_t(b)] * std::sqrt(trans[size_t(b)]) + 0.5f * r;
            const glm::vec3 o = tr[size_t(b)] + r;
            for (int c = 0; c < 3; ++c) full_.dst[(size_t(b) * 3 + size_t(c)) * plane_ + pi] = o[c];
          }
          if (rho != glm::vec3(0.f)) {
            emission_index_[cell] = int(emission_.size());
            std::array<glm::vec3, kUp> e;
            for (int o = 0; o < kUp; ++o) e[size_t(o)] = reflected(kSwept + o);
            emission_.push_back(e);
          }
        }
        // The sun's unscattered light: the same attenuation, no reflection.
        for (int b = 0; b < kSwept; ++b) stored_direct[size_t(b)] = glm::vec3(0.f);
        for (size_t d = 0; d < direct_.bins.size(); ++d) {
          const int b = direct_.bins[d];
          glm::vec3 v;
          for (int c = 0; c < 3; ++c) v[c] = direct_.acc[(d * 3 + size_t(c)) * size_t(nx) + size_t(i)];
          const float t = s == 0.f ? 1.f : std::exp(-s * direct_.paths[d].target_len);
          stored_direct[size_t(b)] = v * std::sqrt(t);
          const glm::vec3 o = v * t;
          for (int c = 0; c < 3; ++c) direct_.dst[(d * 3 + size_t(c)) * plane_ + pi] = o[c];
        }
        uint32_t* dst = out.light.light.data() + cell * kDirections;
        for (int b = 0; b < kSwept; ++b) {
          const glm::vec3 v = o_.direct_sun ? stored_full[size_t(b)] : glm::max(stored_full[size_t(b)] - stored_direct[size_t(b)], glm::vec3(0.f));
          dst[b] = packR11G11B10(v);
          accumulate(cell, b, v);
        }
        if (out.direct) {
          uint32_t* dd = out.direct->light.data() + cell * kDirections;
          for (int b = 0; b < kSwept; ++b) dd[b] = packR11G11B10(stored_direct[size_t(b)]);
        }
      }
    }
  }

  void accumulate(size_t cell, int b, const glm::vec3& v) {
    avg_[cell] += glm::vec4(v, 0.f);
    const float l = luminance(v);
    avg_[cell].w += l;
    dom_[cell] += l * glm::normalize(directions()[size_t(b)].mean_from);
  }

  // The up-going directions: the cells' own reflected light (halved), or with bottom_up carried
  // up from the bottom level; then the cells' average and dominant direction.
  void upGoing(SweptGrid& out) {
    const int nx = g_.size.x, ny = g_.size.y, nz = g_.size.z;
    auto emission = [&](size_t cell, int o) {
      const int e = emission_index_[cell];
      return e < 0 ? glm::vec3(0.f) : emission_[size_t(e)][size_t(o)];
    };
    if (o_.bottom_up) {
      std::fill(up_.src.begin(), up_.src.end(), 0.f);  // below the grid: nothing comes up
      for (int k = 0; k < nz; ++k) {
        edges_.fill(k, false, up_.bins, ring_cells_, up_.dst, plane_);
        const float* sig = sigma_.data() + size_t(k) * plane_;
        for (int j = 0; j < ny; ++j) {
          gather(up_, k, k - 1, j);
          for (int i = 0; i < nx; ++i) {
            const size_t cell = g_.index(i, j, k);
            const size_t pi = size_t(j + kPad) * size_t(w_) + size_t(i + kPad);
            const float s = sig[pi];
            for (int o = 0; o < kUp; ++o) {
              glm::vec3 v;
              for (int c = 0; c < 3; ++c) v[c] = up_.acc[(size_t(o) * 3 + size_t(c)) * size_t(nx) + size_t(i)];
              const float t = s == 0.f ? 1.f : std::exp(-s * up_.paths[size_t(o)].target_len);
              const glm::vec3 e = emission(cell, o);
              const glm::vec3 leave = v * t + e;
              for (int c = 0; c < 3; ++c) up_.dst[(size_t(o) * 3 + size_t(c)) * plane_ + pi] = leave[c];
              const glm::vec3 stored = v * std::sqrt(t) + 0.5f * e;
              out.light.light[cell * kDirections + size_t(kSwept + o)] = packR11G11B10(stored);
              accumulate(cell, kSwept + o, stored);
            }
          }
        }
        std::swap(up_.src, up_.dst);
      }
    } else {
      for (size_t cell = 0; cell < g_.cellCount(); ++cell) {
        if (emission_index_[cell] < 0) continue;
        for (int o = 0; o < kUp; ++o) {
          const glm::vec3 stored = 0.5f * emission(cell, o);
          out.light.light[cell * kDirections + size_t(kSwept + o)] = packR11G11B10(stored);
          accumulate(cell, kSwept + o, stored);
        }
      }
    }
    for (size_t cell = 0; cell < g_.cellCount(); ++cell) {
      out.light.average[cell] = packR11G11B10(glm::vec3(avg_[cell]) / kFourPi);
      const glm::vec3 d = avg_[cell].w > 0 ? dom_[cell] / avg_[cell].w : glm::vec3(0.f);
      out.light.dominant[cell] = glm::packSnorm4x8(glm::vec4(d, 0.f));
    }
  }

  const MaterialGrid& m_;
  GridShape g_;
  SweepOptions o_;
  Edges edges_;
  int w_ = 0, h_ = 0;
  size_t plane_ = 0;
  std::vector<float> sigma_;
  std::vector<uint8_t> level_has_material_;
  std::vector<uint8_t> sealed_;
  std::vector<Edges::Cell> all_cells_, ring_cells_;
  std::array<float, kDirections> cos_sum_{};
  Pass full_, direct_, up_;
  std::vector<float> od_;
  std::vector<glm::vec4> avg_;  // rgb sum, luminance sum
  std::vector<glm::vec3> dom_;
  std::vector<int> emission_index_;
  std::vector<std::array<glm::vec3, kUp>> emission_;
};

}  // namespace

SweptGrid sweepReference(const MaterialGrid& material, const SkyInput& sky, const SweptGrid* parent, const SweepOptions& options) {
  DRTV_CHECK(options.smoothing >= 0.f && options.smoothing <= 1.f);
  Sweeper s(material, sky, parent, options);
  return s.run(sky);
}

}  // namespace drtv::sweep::reference
