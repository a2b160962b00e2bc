// Cascaded light propagation volumes (lpv.h; references there).
#include "drtv/lpv/lpv.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "simd_clones.h"

namespace drtv::lpv {
namespace {

// The propagation's loops are DRTV_SIMD_CLONES (simd_clones.h): compiled for the baseline, AVX2
// and AVX-512, chosen at load time; no FMA (-ffp-contract=off, lpv/CMakeLists.txt): the same
// operations in the same order, so the same bits.

constexpr int kPlanes = 12;  // 3 channels x 4 SH coefficients, plane p = channel * 4 + coefficient

// Propagation steps made in one sweep over the slabs (propagate): their ring buffers, 3 slabs
// each, stay in the L2 cache (8 x 3 x 4 x 34^2 floats = 444 KB at 32 cells).
constexpr int kWaveDepth = 8;

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

// One channel's 4 planes of a padded grid ((n+2)^3, a zero cell around it) and its per-slab
// row flags ((n+2) x (n+2), 0: the row holds only zeros): a sweep's last step, read by the next.
struct StepGrid {
  std::vector<float> planes;
  std::vector<uint8_t> lit;
  void allocate(int n) {
    const size_t np = size_t(n) + 2;
    if (!planes.empty()) return;
    planes.assign(4 * np * np * np, 0.f);
    lit.assign(np * np, 0);
  }
  size_t bytes() const { return planes.size() * sizeof(float) + lit.size(); }
};

}  // namespace

struct CascadedLpv::Cascade {
  CascadeBox box;
  int n = 0;
  size_t cells = 0;
  // kPlanes x (n+2)^3, padded by a zero cell on every side (the propagation reads it in place);
  // inj_lit: per padded slab, channel and padded row (((k+1) * 3 + ch) * (n+2) + j+1), whether
  // an injection added non-zero flux to the row (the propagation skips rows without light, and
  // clearLight clears only the flagged ones).
  std::vector<float> injected;
  std::vector<uint8_t> inj_lit;
  std::vector<float> light;        // kPlanes x cells: injected + every step
  std::vector<uint8_t> light_lit;  // per slab, channel and row ((k * 3 + ch) * n + j): may be non-zero
  std::vector<float> last_step;  // band-0 of the last step, per channel (3 x cells): tests
  std::vector<uint8_t> last_lit;  // per slab, channel and row, as light_lit: may be non-zero
  std::vector<float> geometry;   // 4 x (n+1)^3 blocking potential SH on the corners
  std::vector<float> face_t;     // kDirs x cells: transmittance of light entering through that face
  std::vector<uint8_t> sky_t;    // kSkyDirections x cells, T in 1/255
  std::vector<float> sky;        // kPlanes x cells: visible sky radiance SH
  size_t index(int i, int j, int k) const { return size_t(i) + size_t(n) * (size_t(j) + size_t(n) * size_t(k)); }
  size_t padded() const { return size_t(n + 2) * size_t(n + 2) * size_t(n + 2); }
  size_t paddedIndex(int i, int j, int k) const {
    const size_t np = size_t(n) + 2;
    return size_t(i + 1) + np * (size_t(j + 1) + np * size_t(k + 1));
  }
  size_t corner(int i, int j, int k) const {
    const size_t m = size_t(n) + 1;
    return size_t(i) + m * (size_t(j) + m * size_t(k));
  }
};

// One thread's propagation scratch (see propagate): the ring buffers of the steps of a sweep and,
// for more than kWaveDepth iterations, two padded grids that carry a sweep's last step to the next.
struct CascadedLpv::Scratch {
  std::vector<float> ring;        // kWaveDepth x 3 slots x 4 planes x (n+2)^2
  std::vector<uint8_t> ring_lit;  // kWaveDepth x 3 slots x (n+2) rows
  std::array<StepGrid, 2> grids;  // allocated when needed
};

// Two threads' propagation (see propagate): per channel, the grid where the first job leaves
// the last of its steps for the second job, and how many of that grid's slabs of z are made.
struct CascadedLpv::Pipeline {
  std::array<StepGrid, 3> grids;  // allocated when needed
  std::array<std::atomic<int>, 3> made{};
};

// Threads beside the caller, started once and asleep between calls: a propagation has 3 jobs of
// ~0.3 ms, and starting a thread per call cost about as much as it saved (DESIGN.md: waking an idle
// worker costs 75-100 us, starting one more).
class CascadedLpv::Workers {
 public:
  explicit Workers(int count) {
    for (int w = 1; w <= count; ++w) threads_.emplace_back([this, w] { loop(w); });
  }
  ~Workers() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
  }
  int count() const { return int(threads_.size()); }
  // Runs job(index, worker) for every index in [0, jobs), each once, on the caller (worker 0) and
  // the workers (1..count()); returns when all have finished. Which thread runs which index is
  // not fixed: jobs must not depend on it beyond choosing the worker's scratch.
  void run(int jobs, const std::function<void(int, int)>& job) {
    {
      std::lock_guard lock(mutex_);
      job_ = &job;
      jobs_ = jobs;
      next_.store(0);
      busy_ = count();
      ++generation_;
    }
    wake_.notify_all();
    work(0);
    std::unique_lock lock(mutex_);
    done_.wait(lock, [&] { return busy_ == 0; });
    job_ = nullptr;
  }

 private:
  void work(int worker) {
    for (int i = next_.fetch_add(1); i < jobs_; i = next_.fetch_add(1)) (*job_)(i, worker);
  }
  void loop(int worker) {
    uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
      }
      work(worker);
      {
        std::lock_guard lock(mutex_);
        --busy_;
      }
      done_.notify_one();
    }
  }
  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(int, int)>* job_ = nullptr;
  int jobs_ = 0;
  std::atomic<int> next_{0};
  int busy_ = 0;
  uint64_t generation_ = 0;
  bool stop_ = false;
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

namespace {

// One padded slab ((n+2)^2 cells, a zero cell around it) of a channel's 4 coefficient planes, and
// its (n+2) row flags: a row whose flag is 0 holds only zeros.
struct Slab {
  std::array<float*, 4> q{};
  uint8_t* lit = nullptr;
};

// Zeros the rows of `s` that may hold light (the slabs beyond the grid: nothing enters from there).
void clearSlab(int n, const Slab& s) {
  const size_t np = size_t(n) + 2;
  for (int j = 1; j <= n; ++j) {
    if (!s.lit[j]) continue;
    for (int q = 0; q < 4; ++q) std::fill_n(s.q[size_t(q)] + 1 + np * size_t(j), n, 0.f);
    s.lit[j] = 0;
  }
}

// The propagation's 5 constants (lpv.h, "Propagation"): every direction's matrix is the +x one's
// with the axis relabelled and, for the - directions, m0a and ma0 negated (checked when built).
struct StepConstants {
  float m00, m0a, ma0, maa, moo;
};
StepConstants stepConstants() {
  const auto& mats = matrices();
  const DirMatrix& x = mats[0];
  for (int d = 0; d < kDirs; ++d) {
    const DirMatrix& m = mats[size_t(d)];
    const float sign = (d % 2) ? -1.f : 1.f;
    DRTV_CHECK(m.m00 == x.m00 && m.maa == x.maa && m.moo == x.moo && m.m0a == sign * x.m0a && m.ma0 == sign * x.ma0);
  }
  return {x.m00, x.m0a, x.ma0, x.maa, x.moo};
}

// One row of one step of one channel: the sums over the 6 directions of transmittance x matrix x
// the neighbour's 4 coefficients, grouped by matrix entry: each neighbour's 4 coefficients are
// scaled by its face's transmittance once (24 products), then each entry multiplies its sum of
// them (8 products), 71 operations per cell against 94 entry by entry. `mid`, `below`, `above`:
// the row's cell 0 in the previous step's slabs z, z-1, z+1, each with its 4 planes `sp` apart;
// `t`: the row of direction 0's transmittance, the others `st` apart (used when kOccluded);
// `out`, `acc`: the row of the step's slab and of the accumulation, planes `so` and `sacc` apart.
// With kFirst (step 1, which reads the injected grid) the accumulation is set to mid + the step
// instead of += the step: the same sum as copying the injected light first and adding, without
// the copy. kN > 0 fixes n (and so np and the strides of a grid of kN cells: kSrc, kDst 1 for a
// ring slot's planes (np^2 apart), 2 for a padded grid's (np^3), 0 for the run-time ones): every
// stream is then a base register and a constant offset, where with run-time strides the 34
// streams' pointers did not fit in the registers and were reloaded from the stack.
#if defined(__GNUC__)
#define DRTV_LPV_INLINE inline __attribute__((always_inline))  // into each clone, for its vector width
#else
#define DRTV_LPV_INLINE inline
#endif
template <bool kOccluded, bool kFirst, int kN, int kSrc, int kDst>
DRTV_LPV_INLINE void propagateRow(int n_rt, const StepConstants& k, const float* __restrict mid, const float* __restrict below,
                                  const float* __restrict above, ptrdiff_t sp_rt, const float* __restrict t, ptrdiff_t st_rt,
                                  float* __restrict out, ptrdiff_t so_rt, float* __restrict acc, ptrdiff_t sacc_rt,
                                  float* __restrict last) {
  constexpr auto planeStride = [](int kind, ptrdiff_t np) { return kind == 1 ? np * np : np * np * np; };
  const ptrdiff_t n = kN ? kN : n_rt;
  const ptrdiff_t np = n + 2;
  const ptrdiff_t sp = kN && kSrc ? planeStride(kSrc, np) : sp_rt;
  const ptrdiff_t so = kN && kDst ? planeStride(kDst, np) : so_rt;
  const ptrdiff_t st = kN ? n * n * n : st_rt, sacc = kN ? n * n * n : sacc_rt;
  // The outputs are other buffers than the inputs (restrict on these locals does not survive the
  // inlining, and 34 streams are more than GCC versions a loop for).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC ivdep
#endif
  for (ptrdiff_t i = 0; i < n; ++i) {
    // mid's, below's and above's planes: band 0, y, z, x (sh.h). Direction d's source: +x (d 0)
    // from i-1, -x from i+1, +y from the row j-1, -y from j+1, +z from slab z-1 (below), -z from
    // z+1 (above); f_d its face's transmittance.
    const float* m0 = mid;
    const float* my = mid + sp;
    const float* mz = mid + 2 * sp;
    const float* mx = mid + 3 * sp;
    const float f0 = kOccluded ? t[i] : 1.f, f1 = kOccluded ? t[st + i] : 1.f, f2 = kOccluded ? t[2 * st + i] : 1.f;
    const float f3 = kOccluded ? t[3 * st + i] : 1.f, f4 = kOccluded ? t[4 * st + i] : 1.f, f5 = kOccluded ? t[5 * st + i] : 1.f;
    auto sc = [](float f, float v) { return kOccluded ? f * v : v; };
    // Band 0 (u) and the direction's own axis coefficient (w), scaled.
    const float u0 = sc(f0, m0[i - 1]), u1 = sc(f1, m0[i + 1]), u2 = sc(f2, m0[i - np]), u3 = sc(f3, m0[i + np]);
    const float u4 = sc(f4, below[i]), u5 = sc(f5, above[i]);
    const float w0 = sc(f0, mx[i - 1]), w1 = sc(f1, mx[i + 1]), w2 = sc(f2, my[i - np]), w3 = sc(f3, my[i + np]);
    const float w4 = sc(f4, below[2 * sp + i]), w5 = sc(f5, above[2 * sp + i]);
    // Each band-1 coefficient's sum over the 4 directions across its axis.
    const float vx = (sc(f2, mx[i - np]) + sc(f3, mx[i + np])) + (sc(f4, below[3 * sp + i]) + sc(f5, above[3 * sp + i]));
    const float vy = (sc(f0, my[i - 1]) + sc(f1, my[i + 1])) + (sc(f4, below[sp + i]) + sc(f5, above[sp + i]));
    const float vz = (sc(f0, mz[i - 1]) + sc(f1, mz[i + 1])) + (sc(f2, mz[i - np]) + sc(f3, mz[i + np]));
    const float o0 = k.m00 * (((u0 + u1) + (u2 + u3)) + (u4 + u5)) + k.m0a * (((w0 - w1) + (w2 - w3)) + (w4 - w5));
    const float ox = k.ma0 * (u0 - u1) + k.maa * (w0 + w1) + k.moo * vx;
    const float oy = k.ma0 * (u2 - u3) + k.maa * (w2 + w3) + k.moo * vy;
    const float oz = k.ma0 * (u4 - u5) + k.maa * (w4 + w5) + k.moo * vz;
    out[i] = o0;
    out[so + i] = oy;
    out[2 * so + i] = oz;
    out[3 * so + i] = ox;
    if (kFirst) {
      acc[i] = m0[i] + o0;
      acc[sacc + i] = my[i] + oy;
      acc[2 * sacc + i] = mz[i] + oz;
      acc[3 * sacc + i] = mx[i] + ox;
    } else {
      acc[i] += o0;
      acc[sacc + i] += oy;
      acc[2 * sacc + i] += oz;
      acc[3 * sacc + i] += ox;
    }
  }
  if (last) std::copy_n(out, n, last);
}

// propagateRow with the strides fixed at compile time where they are the default grid's (32
// cells: a ring slot's planes or a padded grid's, the transmittances' and the accumulation's).
template <bool kOccluded, bool kFirst>
DRTV_LPV_INLINE void propagateRowAt(int n, const StepConstants& k, const float* mid, const float* below, const float* above,
                                    ptrdiff_t sp, const float* t, ptrdiff_t st, float* out, ptrdiff_t so, float* acc,
                                    ptrdiff_t sacc, float* last) {
  constexpr ptrdiff_t kS = 34 * 34, kP = 34 * 34 * 34, kCells = 32 * 32 * 32;
  if (n == 32 && (!kOccluded || st == kCells) && sacc == kCells && (sp == kS || sp == kP) && (so == kS || so == kP)) {
    if (sp == kS && so == kS) propagateRow<kOccluded, kFirst, 32, 1, 1>(n, k, mid, below, above, sp, t, st, out, so, acc, sacc, last);
    else if (sp == kS) propagateRow<kOccluded, kFirst, 32, 1, 2>(n, k, mid, below, above, sp, t, st, out, so, acc, sacc, last);
    else if (so == kS) propagateRow<kOccluded, kFirst, 32, 2, 1>(n, k, mid, below, above, sp, t, st, out, so, acc, sacc, last);
    else propagateRow<kOccluded, kFirst, 32, 2, 2>(n, k, mid, below, above, sp, t, st, out, so, acc, sacc, last);
  } else {
    propagateRow<kOccluded, kFirst, 0, 0, 0>(n, k, mid, below, above, sp, t, st, out, so, acc, sacc, last);
  }
}

// One propagation step of one channel on one slab z: dst = sum over the 6 directions of
// transmittance x matrix x the neighbour's 4 coefficients (lpv.h, "Propagation"), the neighbours
// read from the previous step's slabs z-1 (`below`), z (`mid`) and z+1 (`above`).
// `tr[d]`: the unpadded transmittance plane of direction d at slab z (null: no occlusion);
// `light[q]`: the unpadded accumulation at slab z, += the step (with `first`, step 1: = mid + the
// step); `light_lit`: its n row flags; `last`: null, or the unpadded band-0 slab that receives
// the step (the last one), with its n row flags `last_lit` (0: the row holds zeros).
// Rows are skipped when neither they nor their 4 neighbour rows hold light in the previous step.
// AVX-512 or AVX2 where the CPU has it (no FMA: -ffp-contract=off, so the same bits as SSE2).
DRTV_SIMD_CLONES
void propagateSlab(int n, const Slab& below, const Slab& mid, const Slab& above, const Slab& dst,
                   const std::array<const float*, kDirs>& tr, const std::array<float*, 4>& light, uint8_t* light_lit,
                   bool first, float* last, uint8_t* last_lit) {
  static const StepConstants k = stepConstants();
  const ptrdiff_t np = n + 2;
  // Every stream's planes evenly apart (the previous step's 3 slabs alike): propagateRow takes
  // one base and one stride per stream.
  const ptrdiff_t sp = mid.q[1] - mid.q[0], so = dst.q[1] - dst.q[0], sacc = light[1] - light[0];
  const ptrdiff_t st = tr[0] ? tr[1] - tr[0] : 0;
  for (int q = 1; q < 4; ++q)
    DRTV_CHECK(mid.q[size_t(q)] - mid.q[0] == q * sp && below.q[size_t(q)] - below.q[0] == q * sp &&
               above.q[size_t(q)] - above.q[0] == q * sp && dst.q[size_t(q)] - dst.q[0] == q * so &&
               light[size_t(q)] - light[0] == q * sacc);
  for (int d = 1; d < kDirs; ++d) DRTV_CHECK(tr[0] ? tr[size_t(d)] - tr[0] == d * st : !tr[size_t(d)]);
  for (int j = 0; j < n; ++j) {
    const size_t row_u = size_t(n) * size_t(j);
    const size_t row_p = size_t(1 + np * (j + 1));
    const size_t r = size_t(j + 1);
    if (!(mid.lit[r] | mid.lit[r - 1] | mid.lit[r + 1] | below.lit[r] | above.lit[r])) {
      if (dst.lit[r]) {  // what the slot held three slabs ago
        for (int q = 0; q < 4; ++q) std::fill_n(dst.q[size_t(q)] + row_p, n, 0.f);
      }
      dst.lit[r] = 0;
      if (first) {  // mid's row is zero: so is the light's (it may hold the last update's)
        if (light_lit[j])
          for (int q = 0; q < 4; ++q) std::fill_n(light[size_t(q)] + row_u, n, 0.f);
        light_lit[j] = 0;
      }
      if (last && last_lit[j]) {
        std::fill_n(last + row_u, n, 0.f);
        last_lit[j] = 0;
      }
      continue;
    }
    dst.lit[r] = 1;
    light_lit[j] = 1;
    if (last) last_lit[j] = 1;
    float* last_row = last ? last + row_u : nullptr;
    const float* m = mid.q[0] + row_p;
    const float* bl = below.q[0] + row_p;
    const float* ab = above.q[0] + row_p;
    const float* t = tr[0] ? tr[0] + row_u : nullptr;
    float* out = dst.q[0] + row_p;
    float* acc = light[0] + row_u;
    if (t) {
      DRTV_CHECK(!first);  // occlusion starts at step 2
      propagateRowAt<true, false>(n, k, m, bl, ab, sp, t, st, out, so, acc, sacc, last_row);
    } else if (first) {
      propagateRowAt<false, true>(n, k, m, bl, ab, sp, t, st, out, so, acc, sacc, last_row);
    } else {
      propagateRowAt<false, false>(n, k, m, bl, ab, sp, t, st, out, so, acc, sacc, last_row);
    }
  }
}


// The steps the two-thread pipeline's first job makes (propagate): 5/8 of them, not half: light
// spreads a cell per step, so later steps have more rows to make. On the benchmark's ground (3
// cascades, occlusion on, one thread) 4, 5 and 8 steps took 0.84, 1.18 and 2.18 ms: half the
// steps left the second job 61 % of the work, 5 of 8 leave it 46 %.
int pipelineFront(int iterations) { return std::clamp((iterations * 5 + 4) / 8, iterations - kWaveDepth, kWaveDepth); }

}  // namespace

void CascadedLpv::propagateJob(int c, int job, int worker, bool pipelined) {
  Cascade& g = cascades_[size_t(c)];
  const int n = g.n;
  const size_t N = g.cells;
  const size_t np = size_t(n) + 2, P = g.padded(), S = np * np;
  const int iterations = options_.iterations;
  // Within a channel, the steps are made in sweeps over the slabs of z (temporal blocking): at
  // time t, step s makes slab t - s from step s - 1's slabs t - s - 1 .. t - s + 1, the last of
  // them made at the same t, so each step needs only a ring of its last 3 slabs, and the injected
  // light, the accumulation and the transmittances are read once per sweep instead of once per
  // step (a step over a whole grid moved about 8 MB through a cache too small for it). The
  // accumulation takes every cell's steps in order, and each step's arithmetic is the whole-grid
  // step's, so the bits are the same as step by step, however the steps are cut into sweeps.
  auto lightPlanes = [&](int ch) {
    std::array<float*, 4> light;
    for (int q = 0; q < 4; ++q) light[size_t(q)] = g.light.data() + size_t(ch * 4 + q) * N;
    return light;
  };
  auto lightLit = [&](int ch, int z) { return g.light_lit.data() + (size_t(z) * 3 + size_t(ch)) * size_t(n); };
  auto injectedSlab = [&](int ch, int z) {
    Slab v;
    for (int q = 0; q < 4; ++q) v.q[size_t(q)] = g.injected.data() + size_t(ch * 4 + q) * P + size_t(z + 1) * S;
    v.lit = g.inj_lit.data() + (size_t(z + 1) * 3 + size_t(ch)) * np;
    return v;
  };
  auto startLight = [&](int ch, int z) {  // light = injected, slab z (rows without light: zeros)
    const Slab v = injectedSlab(ch, z);
    const std::array<float*, 4> light = lightPlanes(ch);
    uint8_t* lit = lightLit(ch, z);
    for (int j = 0; j < n; ++j) {
      const size_t row_p = 1 + np * size_t(j + 1);
      if (v.lit[j + 1]) {
        for (int q = 0; q < 4; ++q) std::copy_n(v.q[size_t(q)] + row_p, n, light[size_t(q)] + g.index(0, j, z));
      } else if (lit[j]) {
        for (int q = 0; q < 4; ++q) std::fill_n(light[size_t(q)] + g.index(0, j, z), n, 0.f);
      }
      lit[j] = v.lit[j + 1];
    }
  };
  auto gridSlab = [&](StepGrid& grid, int z) {  // a padded grid's slab z in [-1, n]
    Slab v;
    for (int q = 0; q < 4; ++q) v.q[size_t(q)] = grid.planes.data() + size_t(q) * P + size_t(z + 1) * S;
    v.lit = grid.lit.data() + size_t(z + 1) * np;
    return v;
  };
  // Steps done + 1 .. done + depth (<= kWaveDepth) of channel ch in one sweep on worker w's ring:
  // step `done` read from `from` (the injected grid if null), the sweep's last step written into
  // `to` (if not null) for a later sweep. ready(t) returns once `from`'s slabs up to t are made
  // (t < n); made(z) says that the sweep's last step has made slab z.
  auto sweep = [&](int ch, Scratch& w, int done, int depth, StepGrid* from, StepGrid* to, const auto& ready,
                   const auto& made) {
    const std::array<float*, 4> light = lightPlanes(ch);
    auto ringSlab = [&](int s, int z) {  // step s (1..kWaveDepth) of the sweep, slab z in [-1, n]
      const size_t slot = size_t(s - 1) * 3 + size_t(z + 1) % 3;
      Slab v;
      for (int q = 0; q < 4; ++q) v.q[size_t(q)] = w.ring.data() + (slot * 4 + size_t(q)) * S;
      v.lit = w.ring_lit.data() + slot * np;
      return v;
    };
    auto slab = [&](int s, int z) {
      if (s == 0) return from ? gridSlab(*from, z) : injectedSlab(ch, z);
      if (s == depth && to) return gridSlab(*to, z);
      return ringSlab(s, z);
    };
    for (int t = 0; t < n + depth; ++t) {
      if (t < n) ready(t);  // step 1 reads slab t of step `done` now
      for (int s = 1; s <= depth; ++s) {
        const int z = t - s;
        if (z < -1 || z > n) continue;
        if (z == -1 || z == n) {
          // Step s's slabs beyond the grid, read by step s + 1: zero (a grid's border always is).
          if (s < depth) clearSlab(n, ringSlab(s, z));
          continue;
        }
        const int step = done + s;
        std::array<const float*, kDirs> tr{};
        if (options_.occlusion && step >= 2)
          for (int d = 0; d < kDirs; ++d) tr[size_t(d)] = g.face_t.data() + size_t(d) * N + size_t(z) * size_t(n) * size_t(n);
        std::array<float*, 4> acc;
        for (int q = 0; q < 4; ++q) acc[size_t(q)] = light[size_t(q)] + size_t(z) * size_t(n) * size_t(n);
        float* last = step == iterations ? g.last_step.data() + size_t(ch) * N + size_t(z) * size_t(n) * size_t(n) : nullptr;
        uint8_t* last_lit = g.last_lit.data() + (size_t(z) * 3 + size_t(ch)) * size_t(n);
        propagateSlab(n, slab(s - 1, z - 1), slab(s - 1, z), slab(s - 1, z + 1), slab(s, z), tr, acc, lightLit(ch, z), step == 1,
                      last, last_lit);
        if (s == depth) made(z);
      }
    }
  };
  auto always = [](int) {};
  Scratch& w = scratch_[size_t(worker)];
  if (!pipelined) {
    // A channel on one worker: sweeps of up to kWaveDepth steps; between two, one of the
    // worker's padded grids holds the earlier one's last step.
    const int ch = job;
    if (iterations == 0) {
      for (int z = 0; z < n; ++z) startLight(ch, z);
      std::fill_n(g.last_step.data() + size_t(ch) * N, N, 0.f);
      for (int z = 0; z < n; ++z) std::fill_n(g.last_lit.data() + (size_t(z) * 3 + size_t(ch)) * size_t(n), n, uint8_t(0));
    }
    StepGrid* from = nullptr;
    for (int done = 0; done < iterations;) {
      const int depth = std::min(kWaveDepth, iterations - done);
      StepGrid* to = nullptr;
      if (done + depth < iterations) {
        const int which = from == &w.grids[0] ? 1 : 0;
        w.grids[size_t(which)].allocate(n);
        to = &w.grids[size_t(which)];
      }
      sweep(ch, w, done, depth, from, to, always, always);
      done += depth;
      from = to;
    }
    return;
  }
  // The two-thread pipeline (propagate): job 0 makes the first `front` steps of every channel
  // into the pipeline's grids, job 1 the rest a slab behind.
  Pipeline& pl = *pipeline_;
  const int front = pipelineFront(iterations);
  for (int ch = 0; ch < 3; ++ch) {
    std::atomic<int>& made = pl.made[size_t(ch)];
    StepGrid* grid = &pl.grids[size_t(ch)];
    if (job == 0) {
      sweep(ch, w, 0, front, nullptr, grid, always, [&](int z) { made.store(z + 1, std::memory_order_release); });
    } else {
      auto ready = [&](int t) {
        const int need = std::min(t + 1, n);  // slabs 0 .. t: step 1 at t - 1 reads up to t
        for (int spins = 0; made.load(std::memory_order_acquire) < need; ++spins) {
          if (spins > 64) std::this_thread::yield();
        }
      };
      sweep(ch, w, front, iterations - front, grid, nullptr, ready, always);
    }
  }
}

void CascadedLpv::propagate(int c) {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  const int iterations = options_.iterations;
  if (!workers_) {
    for (int ch = 0; ch < 3; ++ch) propagateJob(c, ch, 0, false);
  } else if (scratch_.size() == 2 && iterations >= 2 && iterations <= 2 * kWaveDepth) {
    // Two threads: 3 channel jobs would keep one thread idle a third of the time. Instead a
    // pipeline: job 0 makes the first steps of every channel in one sweep, into a grid per
    // channel, and job 1 the rest in a sweep that follows it a slab behind (it waits on the
    // first's progress), so each thread does about half the work. Whichever thread takes job 1,
    // job 0 has been taken before it, so the wait always ends (one thread runs them in turn).
    for (int ch = 0; ch < 3; ++ch) {
      pipeline_->grids[size_t(ch)].allocate(cascades_[size_t(c)].n);
      pipeline_->made[size_t(ch)].store(0, std::memory_order_relaxed);
    }
    workers_->run(2, [&](int job, int worker) { propagateJob(c, job, worker, true); });
  } else {
    workers_->run(3, [&](int ch, int worker) { propagateJob(c, ch, worker, false); });
  }
}

void CascadedLpv::relight(std::span<const VplList> lists) {
  // The cascades named, in increasing order: one injection job each (jobs 0 .. R-1), then one
  // job per cascade and channel for the propagation (R .. 4R-1). Workers take jobs in index
  // order, so a cascade's injection has been taken before any of its channels: a channel job
  // that waits for it waits on a thread that is running it, and on one thread the jobs simply
  // run in order.
  std::array<int, 8> relit{};
  int R = 0;
  for (int c = 0; c < cascadeCount(); ++c) {
    bool named = false;
    for (const VplList& l : lists) {
      DRTV_CHECK(l.cascade >= 0 && l.cascade < cascadeCount());
      named |= l.cascade == c;
    }
    if (named) relit[size_t(R++)] = c;
  }
  if (R == 1 && workers_) {
    // One cascade: its injection would be one job on one thread, while injectLight splits it over
    // the threads (a camera step, the finest cascade alone: BM_LpvCameraStep 18.8-19.2 ms by the
    // calls against 22.8-23.9 ms as one job, 2026-12-02). The same bits either way (lpv.h).
    clearLight(relit[0]);
    for (const VplList& l : lists) injectLight(relit[0], l.surfels);
    propagate(relit[0]);
    return;
  }
  std::array<std::atomic<bool>, 8> injected{};
  auto job = [&](int i, int worker) {
    if (i < R) {
      const int c = relit[size_t(i)];
      // clearLight's injected half: propagate overwrites every row of the accumulation (light =
      // injected, then += each step), so clearing it first would change nothing.
      clearInjected(c);
      for (const VplList& l : lists)
        if (l.cascade == c) injectJob(c, l.surfels, 0, 1);
      injected[size_t(i)].store(true, std::memory_order_release);
      return;
    }
    const int r = (i - R) / 3, ch = (i - R) % 3;
    for (int spins = 0; !injected[size_t(r)].load(std::memory_order_acquire); ++spins) {
      if (spins > 64) std::this_thread::yield();
    }
    propagateJob(relit[size_t(r)], ch, worker, false);
  };
  if (!workers_) {
    for (int i = 0; i < 4 * R; ++i) job(i, 0);
  } else {
    workers_->run(4 * R, job);
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
