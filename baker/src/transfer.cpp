// The transfer bake (see transfer.h for the maths and references).
#include "drtv/baker/transfer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>

#include "drtv/raytrace/sampling.h"
#include "drtv/formats/sh.h"
#include "drtv/baker/stopwatch.h"
#include "surface_cells.h"

namespace drtv::baker {
namespace {

using detail::Clock;
using detail::since;
using namespace detail::cells;

// Surfel rays start this far off the surface along its normal: 1 mm is ~60 float ulps at the
// 200 m coordinates of a sector with its halo, and far below modelled detail.
constexpr float kRayOffsetM = 1e-3f;
// LPRT shadow rays stop this short of the source (a source probe sits 1.5 m above a surface; the
// margin only keeps the segment from ending exactly on geometry).
constexpr float kSourceClearanceM = 0.05f;
constexpr float kPi = sh::kPi;

// One traced ray: where it went (a cell key, kEscaped or kBackface), how far, what it hit.
struct RayResult {
  uint64_t key = kEscaped;
  float t = 0.f;
  uint32_t prim = raytrace::kNoPrim;
  glm::vec3 position{0.f};  // of the hit: kept so that linking needs no second sin/cos
  glm::vec3 normal{0.f};    // of the side hit (RayScene::facingNormal: double-sided surfaces)
};

struct Edge {
  uint32_t child = kNoSurfel;
  uint16_t material = 0;
};

using Sh4Rgb = std::array<sh::Sh4, 3>;

// The surface cache's graph: surfels [0, traced) were traced, and ray i of surfel si landed on
// surfel edges[si * M + i].child (kNoSurfel: escaped, a back face, or past the last level).
struct SurfelLinks {
  std::vector<Edge> edges;
  size_t traced = 0;
};

glm::vec2 shiftFor(uint64_t key) { return {raytrace::unitFloat(raytrace::hashKey(key, 1)), raytrace::unitFloat(raytrace::hashKey(key, 2))}; }

// Ray i of a probe's basis b, or of a surfel: cosine-weighted about `n`.

RayResult classify(const raytrace::RayScene& scene, const raytrace::Ray& ray, const raytrace::Hit& h, float inv_cell) {
  RayResult r;
  if (!h.hit()) return r;
  r.t = h.t;
  r.prim = h.prim;
  if (!scene.frontFace(ray, h.prim)) {
    r.key = kBackface;
    return r;
  }
  r.position = ray.origin + h.t * ray.dir;
  r.normal = scene.facingNormal(ray, h.prim);
  r.key = cellKey(r.position, r.normal, inv_cell);
  return r;
}

// probe.h's kProbeSkyFit: the band-1 fit [e0, e_y, e_z, e_x] of the direct-sky irradiance at the
// six axis normals, E_a = integral max(0, a.w) V(w) L(w) dw, by weighted least squares with weight
// w_a = 1 + kSkyFitReceiverWeight 6 s_a, where s_a is the share of the surfaces round the probe
// (its rays' front-face hits within kSkyFitReceiverRangeM) that face axis a (sum over hits of
// max(0, n.a)^2, which sums to 1 over the axes). Band 1 cannot fit the sky's sqrt(z) gradient at
// all six axes (probe.h): with equal weights open ground reads pi (H + 0.737 (Z - H)) against
// the exact pi (H + 0.8 (Z - H)), so the fit leans towards the normals the probe's receivers
// have. Under a uniform sky the masked irradiance is linear in n and every weighting is exact.
inline constexpr double kSkyFitReceiverWeight = 0.5;
inline constexpr float kSkyFitReceiverRangeM = 8.f;

// The fit's coefficients as a combination of the six axis integrals (cubeAxis order): e =
// sum_a k[a] E_a, for the receivers' axis shares `share` (all zero: the unweighted fit,
// K = [(|x| + |y| + |z|) / 6, y / 2, z / 2, x / 2]).
std::array<glm::dvec4, kCubeAxes> skyFitWeights(const std::array<double, kCubeAxes>& share) {
  glm::dmat4 m(0.0);  // sum of w_a phi_a phi_a^T, phi_a = [1, a.y, a.z, a.x]
  std::array<glm::dvec4, kCubeAxes> k{};
  for (int a = 0; a < kCubeAxes; ++a) {
    const glm::dvec3 n(cubeAxis(a));
    const glm::dvec4 phi(1.0, n.y, n.z, n.x);
    const double w = 1.0 + kSkyFitReceiverWeight * double(kCubeAxes) * share[size_t(a)];
    m += w * glm::outerProduct(phi, phi);
    k[size_t(a)] = w * phi;
  }
  const glm::dmat4 inv = glm::inverse(m);  // m >= the unweighted diag(6, 2, 2, 2): invertible
  for (glm::dvec4& v : k) v = inv * v;
  return k;
}

// What every step of one sector's transfer bake reads.
struct TransferContext {
  const raytrace::RayScene& scene;
  const raytrace::SectorGeometry& geometry;
  const TransferSettings& s;
  size_t P, N, M;
  float inv_cell;
  uint64_t sector_key;
  const glm::vec3& albedo(uint32_t prim) const { return geometry.materials[geometry.material[prim]]; }
};

// The probes' rays: 4 bases x N cosine-weighted rays, plus one straight down for height_m. Fills
// sky visibility, back-face fraction, mean hit distance and height; `probe_res` gets every ray's
// result in probe, basis, sample order.
void traceProbes(const TransferContext& ctx, std::span<const glm::vec3> probes, std::vector<ProbeData>& out,
                 std::vector<RayResult>& probe_res, CubeTransfer* cube) {
  const raytrace::RayScene& scene = ctx.scene;
  const TransferSettings& s = ctx.s;
  const size_t P = ctx.P, N = ctx.N;
  const float inv_cell = ctx.inv_cell;
  const uint64_t sector_key = ctx.sector_key;
  const raytrace::CosineSampler probe_sampler{static_cast<uint32_t>(N)};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, P, 1), [&](const tbb::blocked_range<size_t>& range) {
    std::vector<raytrace::Ray> rays(N);
    std::vector<raytrace::Hit> hits(N);
    std::vector<glm::vec3> dirs(N);
    for (size_t p = range.begin(); p < range.end(); ++p) {
      ProbeData& d = out[p];
      d.position = probes[p];
      size_t escaped_total = 0, back = 0, hit = 0;
      double hit_t = 0.0;
      glm::dvec4 vis_sh(0.0);
      std::array<double, kCubeAxes> cube_h{}, cube_delta{}, receivers{};
      size_t near_hits = 0;
      for (int b = 0; b < 4; ++b) {
        const raytrace::Frame frame(sh::kBasis[b]);
        const glm::vec2 shift = shiftFor(raytrace::hashKey(sector_key, p * 4 + b));
        probe_sampler.generate(frame, shift, dirs);
        for (size_t i = 0; i < N; ++i) rays[i] = raytrace::Ray{probes[p], 0.f, dirs[i], INFINITY};
        scene.intersect(rays, hits);
        size_t escaped = 0;
        for (size_t i = 0; i < N; ++i) {
          const RayResult r = classify(scene, rays[i], hits[i], inv_cell);
          probe_res[(p * 4 + b) * N + i] = r;
          if (r.key == kEscaped) {
            ++escaped;
            // Mixture pdf of the four cosine lobes (balance heuristic).
            float pdf = 0.f;
            for (int k = 0; k < 4; ++k) pdf += std::max(0.f, glm::dot(sh::kBasis[k], rays[i].dir));
            pdf *= 0.25f / kPi;
            if (pdf > 0.f) {
              const glm::vec3& w = rays[i].dir;
              vis_sh += glm::dvec4(sh::evaluate(w) / pdf);
              // The six axis irradiances of the direct sky's fit (kProbeSkyFit) and of the ambient
              // cube, and their sqrt(z) gradient above the horizon.
              for (int a = 0; a < kCubeAxes; ++a) {
                const double c = std::max(0.f, glm::dot(cubeAxis(a), w)) / double(pdf);
                cube_h[size_t(a)] += c;
                if (w.z > 0.f) cube_delta[size_t(a)] += c * std::sqrt(double(w.z));
              }
            }
          } else {
            ++hit;
            hit_t += r.t;
            back += r.key == kBackface;
            if (r.key != kBackface && r.t < kSkyFitReceiverRangeM) {
              ++near_hits;
              for (int a = 0; a < kCubeAxes; ++a) {
                const double c = std::max(0.f, glm::dot(cubeAxis(a), r.normal));
                receivers[size_t(a)] += c * c;
              }
            }
          }
        }
        escaped_total += escaped;
        if (s.sky_visibility) d.sky_vis[b] = float(double(escaped) / double(N));
      }
      if (s.sky_visibility) d.sky_vis_sh = glm::vec4(vis_sh / double(4 * N));
      if (s.representation == Representation::kShL1) {
        d.flags |= kProbeSkyFit;
        if (s.sky_visibility) {
          std::array<double, kCubeAxes> share{};
          for (size_t a = 0; a < size_t(kCubeAxes); ++a) share[a] = near_hits ? receivers[a] / double(near_hits) : 0.0;
          const std::array<glm::dvec4, kCubeAxes> k = skyFitWeights(share);
          glm::dvec4 h(0.0), delta(0.0);
          for (size_t a = 0; a < size_t(kCubeAxes); ++a) {
            h += k[a] * (cube_h[a] / double(4 * N));
            delta += k[a] * (cube_delta[a] / double(4 * N));
          }
          d.sky_fit_h = glm::vec4(h);
          d.sky_fit_delta = glm::vec4(delta);
        }
      }
      if (cube && s.sky_visibility)
        for (size_t a = 0; a < size_t(kCubeAxes); ++a) {
          cube->sky_h[p][a] = float(cube_h[a] / double(4 * N));
          cube->sky_delta[p][a] = float(cube_delta[a] / double(4 * N));
        }
      d.backface_frac = float(double(back) / double(4 * N));
      d.mean_hit_m = hit ? float(hit_t / double(hit)) : 0.f;
      const raytrace::Hit down = scene.intersect(raytrace::Ray{probes[p], 0.f, glm::vec3(0, 0, -1), INFINITY});
      d.height_m = down.hit() ? std::min(down.t, 655.35f) : 0.f;
    }
  });
}

// Level-1 surfels: the probes' hits, one per cell in probe, basis, sample order; `probe_surfel`
// names each probe ray's surfel. Returns how many there are (level 1's size).
size_t levelOneSurfels(const TransferContext& ctx, const std::vector<RayResult>& probe_res, SurfaceCells& cells,
                       std::vector<Surfel>& surfels, std::vector<uint32_t>& probe_surfel, TransferStats& stats) {
  probe_surfel.assign(probe_res.size(), kNoSurfel);
  std::atomic<uint64_t> side_rays{0};
  const std::vector<uint32_t> side = sidesOfHits(
      cells, probe_res.size(), [&](size_t i) { return probe_res[i].key; },
      [&](size_t i) { return Surfel{probe_res[i].position, probe_res[i].normal}; }, side_rays);
  stats.surfel_rays += side_rays;
  for (size_t idx = 0; idx < probe_res.size(); ++idx) {  // probe, basis, sample order
    const RayResult& r = probe_res[idx];
    if (r.key >= kBackface) continue;
    bool made = false;
    probe_surfel[idx] = cells.side(r.key, side[idx], [&] {
      made = true;
      surfels.push_back({r.position, r.normal});
      return uint32_t(surfels.size() - 1);
    });
    stats.probe_hits_cached += !made;
  }
  const size_t level1 = surfels.size();
  // Level 1 sits where the probes look: its representative is the probe hit nearest the mean of
  // the cell's probe hits (a real surface point, chosen in a fixed order), not the first one, so
  // that what the cell stands for is centred on what the probes saw (the LPRT error near a light in
  // Transfer.LprtIsTheBounceOfAUnitPointLight went from 12% low with the first hit to 2% high).
  {
    std::vector<glm::dvec3> sum(level1, glm::dvec3(0.0));
    std::vector<uint32_t> count(level1, 0);
    for (size_t idx = 0; idx < probe_surfel.size(); ++idx)
      if (probe_surfel[idx] != kNoSurfel) {
        sum[probe_surfel[idx]] += glm::dvec3(probe_res[idx].position);
        ++count[probe_surfel[idx]];
      }
    std::vector<float> best(level1, INFINITY);
    for (size_t idx = 0; idx < probe_surfel.size(); ++idx) {
      const uint32_t si = probe_surfel[idx];
      if (si == kNoSurfel) continue;
      const glm::vec3 mean(sum[si] / double(count[si]));
      const glm::vec3 d = probe_res[idx].position - mean;
      if (const float d2 = glm::dot(d, d); d2 < best[si]) {
        best[si] = d2;
        surfels[si] = {probe_res[idx].position, probe_res[idx].normal};
      }
    }
  }
  return level1;
}

// The surface cache: trace level by level from level 1 (cells found while tracing, new ones
// created in (surfel, ray) order), then Jacobi sweeps for the bounces. Returns each traced
// surfel's transfer.
// `direct_out` (optional) receives each traced surfel's direct part D_x (the sky it sees), `links_out`
// (optional) the surfel-to-surfel edges the sweeps used, for LPRT's own sweeps.
std::vector<Sh4Rgb> surfaceCache(const TransferContext& ctx, SurfaceCells& cells, std::vector<Surfel>& surfels, TransferStats& stats,
                                 std::vector<sh::Sh4>* direct_out = nullptr, SurfelLinks* links_out = nullptr) {
  const raytrace::RayScene& scene = ctx.scene;
  const raytrace::SectorGeometry& geometry = ctx.geometry;
  const TransferSettings& s = ctx.s;
  const size_t M = ctx.M;
  const float inv_cell = ctx.inv_cell;
  const uint64_t sector_key = ctx.sector_key;
  const raytrace::CosineSampler surfel_sampler{static_cast<uint32_t>(M)};
  std::vector<Sh4Rgb> transfer;
  std::vector<sh::Sh4> direct;
  std::vector<Edge> edges;
  // A hit whose cell did not exist before its level: where it landed, linked after the trace.
  struct Miss {
    uint64_t key;
    glm::vec3 position;
    glm::vec3 normal;
    uint32_t sides;  // the cell's sides when traced (none on this hit's side)
  };
  std::atomic<uint64_t> side_rays{0};
  std::vector<Miss> misses;
  size_t lo = 0;
  for (int level = 1; level <= s.bounces && lo < surfels.size(); ++level) {
    const size_t hi = surfels.size();
    const bool last = level == s.bounces;
    direct.resize(hi, sh::Sh4(0.f));
    edges.resize(hi * M);
    if (!last) misses.resize((hi - lo) * M);
    // The cell map is read-only while the level is traced, so each ray finds the cell it
    // landed in right there; only hits in cells that do not exist yet (at the last level they
    // stay unlinked) are left for the serial pass below, which creates them in (surfel, ray)
    // order: the ids are those a serial insert of every hit would give.
    tbb::parallel_for(tbb::blocked_range<size_t>(lo, hi, 16), [&](const tbb::blocked_range<size_t>& range) {
      uint64_t local_side_rays = 0;
      std::vector<raytrace::Ray> rays(M), side_batch;
      std::vector<raytrace::Hit> hits(M);
      std::vector<glm::vec3> dirs(M);
      std::vector<RayResult> results(M);
      std::vector<uint32_t> tested;
      std::vector<uint8_t> blocked;
      for (size_t si = range.begin(); si < range.end(); ++si) {
        const Surfel& sf = surfels[si];
        const raytrace::Frame frame(sf.normal);
        const glm::vec2 shift = shiftFor(raytrace::hashKey(sector_key, (1ull << 40) | si));
        const glm::vec3 origin = sf.position + kRayOffsetM * sf.normal;
        surfel_sampler.generate(frame, shift, dirs);
        for (size_t i = 0; i < M; ++i) rays[i] = raytrace::Ray{origin, 0.f, dirs[i], INFINITY};
        scene.intersect(rays, hits);
        sh::Sh4 d(0.f);
        // Each hit's cell's first side: the hits that must see its surfel, in one batch.
        side_batch.clear();
        tested.clear();
        for (size_t i = 0; i < M; ++i) {
          const RayResult& r = results[i] = classify(scene, rays[i], hits[i], inv_cell);
          Edge& e = edges[si * M + i];
          e = Edge{};
          if (r.key == kEscaped) d += sh::evaluate(rays[i].dir);
          if (r.key >= kBackface) continue;
          e.material = geometry.material[r.prim];
          e.child = cells.first(r.key);
          raytrace::Ray ray;
          if (e.child != kNoSurfel && cells.mayHaveSides(r.key) &&
              SurfaceCells::sideRay(r.position, r.normal, surfels[e.child].position, surfels[e.child].normal, ray)) {
            side_batch.push_back(ray);
            tested.push_back(uint32_t(i));
          }
        }
        blocked.assign(side_batch.size(), 0);
        if (!side_batch.empty()) cells.occluded(side_batch, blocked);
        local_side_rays += side_batch.size();
        for (size_t j = 0; j < tested.size(); ++j)
          if (blocked[j]) {  // not the first side's: the others, one by one
            Edge& e = edges[si * M + tested[j]];
            const RayResult& r = results[tested[j]];
            uint32_t sides = 1;
            e.child = cells.find(cells.next(e.child), r.position, r.normal, surfels, local_side_rays, sides);
            if (e.child == kNoSurfel && !last) {
              e.child = kPending;
              misses[(si - lo) * M + tested[j]] = Miss{r.key, r.position, r.normal, sides};
            }
          }
        if (!last)
          for (size_t i = 0; i < M; ++i) {
            Edge& e = edges[si * M + i];
            if (e.child == kNoSurfel && results[i].key < kBackface) {  // a cell not made yet
              e.child = kPending;
              misses[(si - lo) * M + i] = Miss{results[i].key, results[i].position, results[i].normal, 0};
            }
          }
        direct[si] = d * (kPi / float(M));
      }
      side_rays += local_side_rays;
    });
    stats.surfel_rays += uint64_t(hi - lo) * M;
    if (!last) {
      const std::vector<uint32_t> side = sidesOfHits(
          cells, (hi - lo) * M, [&](size_t j) { return edges[lo * M + j].child == kPending ? misses[j].key : kEscaped; },
          [&](size_t j) { return Surfel{misses[j].position, misses[j].normal}; }, side_rays);
      for (size_t j = 0; j < (hi - lo) * M; ++j) {  // surfel, ray order
        Edge& e = edges[lo * M + j];
        if (e.child != kPending) continue;
        const Miss& m = misses[j];
        e.child = cells.side(m.key, m.sides + side[j], [&] {
          surfels.push_back({m.position, m.normal});
          return uint32_t(surfels.size() - 1);
        });
      }
    }
    lo = hi;
  }
  stats.surfel_rays += side_rays;
  const size_t count = lo;  // surfels traced (the last level creates none)
  transfer.resize(count);
  for (size_t si = 0; si < count; ++si) transfer[si] = {direct[si], direct[si], direct[si]};
  std::vector<Sh4Rgb> next(count);
  for (int sweep = 0; sweep < sweepCount(s); ++sweep) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 256), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t si = range.begin(); si < range.end(); ++si) {
        Sh4Rgb acc{sh::Sh4(0.f), sh::Sh4(0.f), sh::Sh4(0.f)};
        for (size_t i = 0; i < M; ++i) {
          const Edge& e = edges[si * M + i];
          if (e.child == kNoSurfel) continue;
          const glm::vec3& rho = geometry.materials[e.material];
          for (int c = 0; c < 3; ++c) acc[c] += rho[c] * transfer[e.child][c];
        }
        for (int c = 0; c < 3; ++c) next[si][c] = direct[si] + acc[c] * (1.f / float(M));
      }
    });
    std::swap(transfer, next);
  }
  stats.surfels += count;
  if (direct_out) *direct_out = std::move(direct);
  if (links_out) {
    links_out->edges = std::move(edges);
    links_out->traced = count;
  }
  return transfer;
}

}  // namespace

glm::vec3 cubeAxis(int a) {
  glm::vec3 v(0.f);
  v[a / 2] = a % 2 ? -1.f : 1.f;
  return v;
}

sh::Sh4 linearSunLobe(const glm::vec3& d) {
  sh::Sh4 s = sh::evaluate(d) * 2.f;
  s.x = 0.f;
  return s;
}

std::vector<glm::vec3> sunSamples(const Sky& sky, int count) {
  std::vector<glm::vec3> out;
  if (count < 2) return out;
  auto elevation = [&](double h) { return sky.sunDirection(h).z; };
  if (!(elevation(12.0) > 0.0)) return out;  // the sun never rises
  double rise = 0.0;
  if (elevation(0.0) > 0.0) {
    // It never sets: the whole day, midnight included once.
    for (int k = 0; k < count; ++k) out.push_back(glm::vec3(sky.sunDirection(24.0 * k / count)));
    return out;
  }
  double lo = 0.0, hi = 12.0;  // elevation(lo) <= 0 < elevation(hi): the path is symmetric about noon
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    (elevation(mid) > 0.0 ? hi : lo) = mid;
  }
  rise = hi;
  const double set = 24.0 - rise;
  for (int k = 0; k < count; ++k) {
    glm::dvec3 d = sky.sunDirection(rise + (set - rise) * k / (count - 1));
    d.z = std::max(d.z, 0.0);
    out.push_back(glm::vec3(glm::normalize(d)));
  }
  return out;
}

namespace {

// Gather: T[c][b] = (1/N) sum rho_c(x_i) T_{x_i}[c] over each probe basis' rays.
// The sh-l1 weight of a probe ray towards `hit` from `probe`: Y(w) / S(w) (transfer.h).
sh::Sh4 sphereWeight(const glm::vec3& probe, const glm::vec3& hit) {
  const glm::vec3 w = glm::normalize(hit - probe);
  float S = 0.f;
  for (int k = 0; k < 4; ++k) S += std::max(0.f, glm::dot(sh::kBasis[k], w));
  return S > 0.f ? sh::evaluate(w) / S : sh::Sh4(0.f);
}

// The ambient cube's weight of a probe ray towards `hit`: max(0, A_a.w) / S(w) per axis (transfer.h).
std::array<float, kCubeAxes> cubeWeight(const glm::vec3& probe, const glm::vec3& hit) {
  const glm::vec3 w = glm::normalize(hit - probe);
  float S = 0.f;
  for (int k = 0; k < 4; ++k) S += std::max(0.f, glm::dot(sh::kBasis[k], w));
  std::array<float, kCubeAxes> out{};
  if (S > 0.f)
    for (int a = 0; a < kCubeAxes; ++a) out[size_t(a)] = std::max(0.f, glm::dot(cubeAxis(a), w)) / S;
  return out;
}

// Ambient cube gather: C[c][a] = (1/N) sum over all 4N rays rho_c T_x[c] max(0, A_a.w) / S(w).
void gatherPrtCube(const TransferContext& ctx, std::span<const glm::vec3> probes, const std::vector<RayResult>& probe_res,
                   const std::vector<uint32_t>& probe_surfel, const std::vector<Sh4Rgb>& transfer, CubeTransfer& cube) {
  const size_t P = ctx.P, N = ctx.N;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, P, 4), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t p = range.begin(); p < range.end(); ++p) {
      std::array<std::array<glm::dvec4, kCubeAxes>, 3> acc{};
      for (size_t idx = p * 4 * N; idx < (p + 1) * 4 * N; ++idx) {
        const uint32_t si = probe_surfel[idx];
        if (si == kNoSurfel) continue;
        const glm::vec3& rho = ctx.albedo(probe_res[idx].prim);
        const std::array<float, kCubeAxes> y = cubeWeight(probes[p], probe_res[idx].position);
        for (int c = 0; c < 3; ++c)
          for (size_t a = 0; a < size_t(kCubeAxes); ++a)
            if (y[a] > 0.f) acc[c][a] += glm::dvec4(rho[c] * y[a] * transfer[si][c]);
      }
      for (int c = 0; c < 3; ++c)
        for (size_t a = 0; a < size_t(kCubeAxes); ++a) cube.prt[p][c][a] = glm::vec4(acc[c][a] / double(N));
    }
  });
}

// sh-l1 gather: M[c][i][j] = (1/N) sum over all 4N rays rho_c T_x[c][j] Y_i(w) / S(w).
void gatherPrtShL1(const TransferContext& ctx, std::span<const glm::vec3> probes, const std::vector<RayResult>& probe_res,
                   const std::vector<uint32_t>& probe_surfel, const std::vector<Sh4Rgb>& transfer, std::vector<ProbeData>& out) {
  const size_t P = ctx.P, N = ctx.N;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, P, 4), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t p = range.begin(); p < range.end(); ++p) {
      std::array<std::array<glm::dvec4, 4>, 3> acc{};
      for (size_t idx = p * 4 * N; idx < (p + 1) * 4 * N; ++idx) {
        const uint32_t si = probe_surfel[idx];
        if (si == kNoSurfel) continue;
        const glm::vec3& rho = ctx.albedo(probe_res[idx].prim);
        const sh::Sh4 y = sphereWeight(probes[p], probe_res[idx].position);
        for (int c = 0; c < 3; ++c)
          for (int i = 0; i < 4; ++i) acc[c][i] += glm::dvec4(rho[c] * y[i] * transfer[si][c]);
      }
      for (int c = 0; c < 3; ++c)
        for (int i = 0; i < 4; ++i) out[p].prt[c][i] = glm::vec4(acc[c][i] / double(N));
    }
  });
}

void gatherPrt(const TransferContext& ctx, const std::vector<RayResult>& probe_res, const std::vector<uint32_t>& probe_surfel,
               const std::vector<Sh4Rgb>& transfer, std::vector<ProbeData>& out) {
  const size_t P = ctx.P, N = ctx.N;
  auto albedo = [&](uint32_t prim) -> const glm::vec3& { return ctx.albedo(prim); };
  tbb::parallel_for(tbb::blocked_range<size_t>(0, P, 4), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t p = range.begin(); p < range.end(); ++p)
      for (int b = 0; b < 4; ++b) {
        Sh4Rgb acc{sh::Sh4(0.f), sh::Sh4(0.f), sh::Sh4(0.f)};
        for (size_t i = 0; i < N; ++i) {
          const size_t idx = (p * 4 + b) * N + i;
          const uint32_t si = probe_surfel[idx];
          if (si == kNoSurfel) continue;
          const glm::vec3& rho = albedo(probe_res[idx].prim);
          for (int c = 0; c < 3; ++c) acc[c] += rho[c] * transfer[si][c];
        }
        for (int c = 0; c < 3; ++c) out[p].prt[c][b] = acc[c] * (1.f / float(N));
      }
  });
}

// One bounce of per-surfel values to the probes, the sh-l1 (and cube) gather: for J values v[si][j]
// per level-1 surfel (kC = 1: one for all channels; kC = 3: v[si][j][c], per channel),
// out[p][j][c][w] = (1/N) sum over the probe's 4N rays that end on a cached surfel si of
// rho_c v[si][j] W_w(probe, hit), with the weights W of sphereWeight (4) or cubeWeight (6);
// accumulated in double. Used by the sun transfer and by LPRT.
template <size_t kW, size_t kC = 1, class WeightFn>
void bounceToProbes(const TransferContext& ctx, std::span<const glm::vec3> probes, const std::vector<RayResult>& probe_res,
                    const std::vector<uint32_t>& probe_surfel, const std::vector<float>& v, size_t J, WeightFn weight,
                    std::vector<float>& out) {
  static_assert(kC == 1 || kC == 3);
  const size_t P = ctx.P, N = ctx.N, row = J * 3 * kW;
  out.assign(P * row, 0.f);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, P, 1), [&](const tbb::blocked_range<size_t>& range) {
    std::vector<double> acc(row);
    for (size_t p = range.begin(); p < range.end(); ++p) {
      std::fill(acc.begin(), acc.end(), 0.0);
      for (size_t idx = p * 4 * N; idx < (p + 1) * 4 * N; ++idx) {
        const uint32_t si = probe_surfel[idx];
        if (si == kNoSurfel) continue;
        const glm::vec3& rho = ctx.albedo(probe_res[idx].prim);
        const auto y = weight(probes[p], probe_res[idx].position);
        const float* e = &v[si * J * kC];
        for (size_t j = 0; j < J; ++j) {
          for (int c = 0; c < 3; ++c) {
            const float ej = e[j * kC + (kC == 3 ? size_t(c) : 0)];
            if (ej == 0.f) continue;
            for (size_t w = 0; w < kW; ++w) acc[(j * 3 + size_t(c)) * kW + w] += double(rho[c] * ej * y[w]);
          }
        }
      }
      for (size_t q = 0; q < row; ++q) out[p * row + q] = float(acc[q] / double(N));
    }
  });
}

// The sun transfer (transfer.h): per level-1 surfel and sun sample, the exact direct sun
// irradiance V(x, d) max(0, n.d) less what the linear lobe gives it through D_x; then one bounce
// to the probes with the sh-l1 gather's weights.
void bakeSunTransfer(const TransferContext& ctx, std::span<const glm::vec3> probes, const std::vector<Surfel>& surfels,
                     size_t level1, const std::vector<sh::Sh4>& direct, const std::vector<RayResult>& probe_res,
                     const std::vector<uint32_t>& probe_surfel, std::span<const glm::vec3> sun, std::vector<float>* out_sh,
                     std::vector<float>* out_cube, TransferStats& stats) {
  const size_t K = sun.size();
  std::vector<sh::Sh4> lobe(K);
  for (size_t k = 0; k < K; ++k) lobe[k] = linearSunLobe(sun[k]);
  std::vector<float> wrong(level1 * K, 0.f);
  std::atomic<uint64_t> sun_rays{0};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, level1, 64), [&](const tbb::blocked_range<size_t>& range) {
    uint64_t cast = 0;
    std::vector<raytrace::Ray> rays;
    std::vector<uint32_t> which;
    std::vector<uint8_t> blocked;
    for (size_t si = range.begin(); si < range.end(); ++si) {
      const Surfel& sf = surfels[si];
      const glm::vec3 origin = sf.position + kRayOffsetM * sf.normal;
      rays.clear();
      which.clear();
      for (size_t k = 0; k < K; ++k) {
        wrong[si * K + k] = -glm::dot(direct[si], lobe[k]);
        if (glm::dot(sf.normal, sun[k]) <= 0.f) continue;
        rays.push_back(raytrace::Ray{origin, 0.f, sun[k], INFINITY});
        which.push_back(uint32_t(k));
      }
      blocked.resize(rays.size());
      ctx.scene.occluded(rays, blocked);
      cast += rays.size();
      for (size_t r = 0; r < rays.size(); ++r)
        if (!blocked[r]) wrong[si * K + which[r]] += glm::dot(sf.normal, sun[which[r]]);
    }
    sun_rays += cast;
  });
  stats.sun_rays += sun_rays;
  // The ambient cube's correction and sh-l1's: the same per-surfel error, each with its weights.
  if (out_cube) bounceToProbes<kCubeAxes>(ctx, probes, probe_res, probe_surfel, wrong, K, cubeWeight, *out_cube);
  if (out_sh) bounceToProbes<4>(ctx, probes, probe_res, probe_surfel, wrong, K, sphereWeight, *out_sh);
}

// LPRT: the direct irradiance of each source at each traced surfel, lprtSweepCount sweeps through
// the surface cache's links (T's links), then one bounce to the probes.
void bakeLprt(const TransferContext& ctx, std::span<const glm::vec3> probes, const std::vector<Surfel>& surfels, size_t level1,
              const SurfelLinks* links, const std::vector<RayResult>& probe_res,
              const std::vector<uint32_t>& probe_surfel, std::span<const glm::vec3> lprt_sources, std::vector<float>* lprt,
              std::vector<float>* cube_lprt, TransferStats& stats) {
  const raytrace::RayScene& scene = ctx.scene;
  const size_t P = ctx.P, N = ctx.N, M = ctx.M, S = lprt_sources.size();
  const bool sweeps = links != nullptr && lprtSweepCount(ctx.s) > 0;
  // Without later bounces only level 1 (what the probes see) needs the light.
  const size_t lit = sweeps ? links->traced : level1;
  DRTV_CHECK_LE(level1, lit);
  auto albedo = [&](uint32_t prim) -> const glm::vec3& { return ctx.albedo(prim); };
  std::vector<float> irradiance(lit * S, 0.f);
  std::atomic<uint64_t> lprt_rays{0};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, lit, 16), [&](const tbb::blocked_range<size_t>& range) {
    uint64_t cast = 0;
    std::vector<raytrace::Ray> rays;
    std::vector<uint32_t> which;
    std::vector<float> value;
    std::vector<uint8_t> blocked;
    for (size_t si = range.begin(); si < range.end(); ++si) {
      const Surfel& sf = surfels[si];
      const glm::vec3 origin = sf.position + kRayOffsetM * sf.normal;
      rays.clear();
      which.clear();
      value.clear();
      for (size_t j = 0; j < S; ++j) {
        const glm::vec3 to = lprt_sources[j] - origin;
        const float d2 = glm::dot(to, to);
        if (!(d2 > 0.f)) continue;
        const float d = std::sqrt(d2);
        const glm::vec3 l = to / d;
        const float cos = glm::dot(sf.normal, l);
        if (cos <= 0.f) continue;
        rays.push_back(raytrace::Ray{origin, 0.f, l, std::max(0.f, d - kSourceClearanceM)});
        which.push_back(uint32_t(j));
        value.push_back(cos / std::max(d2, kLprtMinDistance2));
      }
      blocked.resize(rays.size());
      scene.occluded(rays, blocked);
      cast += rays.size();
      for (size_t k = 0; k < rays.size(); ++k)
        if (!blocked[k]) irradiance[si * S + which[k]] = value[k];
    }
    lprt_rays += cast;
  });
  stats.lprt_rays += lprt_rays;

  if (!sweeps) {
    // One bounce: the same surfel irradiance for every channel.
    irradiance.resize(level1 * S);
    if (cube_lprt) bounceToProbes<kCubeAxes>(ctx, probes, probe_res, probe_surfel, irradiance, S, cubeWeight, *cube_lprt);
    if (!lprt) return;
    if (ctx.s.representation == Representation::kShL1) {
      bounceToProbes<4>(ctx, probes, probe_res, probe_surfel, irradiance, S, sphereWeight, *lprt);
      return;
    }
  }
  // Later bounces: the Jacobi sweeps of surfaceCache, B_s = E_s + (1/M) sum rho B_child, per
  // channel (walls of different colours tint what they pass on), so that the local light carries
  // as many bounces as the sun and sky do (the path tracer carries all of them).
  std::vector<float> bounced;  // [surfel][source][channel], level-1 surfels only at the end
  if (sweeps) {
    const raytrace::SectorGeometry& geometry = ctx.geometry;
    std::vector<float> cur(lit * S * 3), next(lit * S * 3);
    for (size_t si = 0; si < lit; ++si)
      for (size_t j = 0; j < S; ++j)
        for (size_t c = 0; c < 3; ++c) cur[(si * S + j) * 3 + c] = irradiance[si * S + j];
    for (int sweep = 0; sweep < lprtSweepCount(ctx.s); ++sweep) {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, lit, 64), [&](const tbb::blocked_range<size_t>& range) {
        std::vector<float> acc(S * 3);
        for (size_t si = range.begin(); si < range.end(); ++si) {
          std::fill(acc.begin(), acc.end(), 0.f);
          for (size_t i = 0; i < M; ++i) {
            const Edge& e = links->edges[si * M + i];
            if (e.child == kNoSurfel) continue;
            const glm::vec3& rho = geometry.materials[e.material];
            const float* b = &cur[size_t(e.child) * S * 3];
            for (size_t j = 0; j < S; ++j)
              for (int c = 0; c < 3; ++c) acc[j * 3 + size_t(c)] += rho[c] * b[j * 3 + size_t(c)];
          }
          for (size_t j = 0; j < S; ++j)
            for (size_t c = 0; c < 3; ++c)
              next[(si * S + j) * 3 + c] = irradiance[si * S + j] + acc[j * 3 + c] * (1.f / float(M));
        }
      });
      std::swap(cur, next);
    }
    cur.resize(level1 * S * 3);
    bounced = std::move(cur);
    if (cube_lprt) bounceToProbes<kCubeAxes, 3>(ctx, probes, probe_res, probe_surfel, bounced, S, cubeWeight, *cube_lprt);
    if (!lprt) return;
    if (ctx.s.representation == Representation::kShL1) {
      bounceToProbes<4, 3>(ctx, probes, probe_res, probe_surfel, bounced, S, sphereWeight, *lprt);
      return;
    }
  }
  // fc3: on the bases, each ray counting towards the basis it was cast about (k).
  lprt->assign(P * S * 12, 0.f);
  const size_t kc = sweeps ? 3 : 1;
  const std::vector<float>& v = sweeps ? bounced : irradiance;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, P, 1), [&](const tbb::blocked_range<size_t>& range) {
    std::vector<float> acc(S * 12);
    for (size_t p = range.begin(); p < range.end(); ++p) {
      std::fill(acc.begin(), acc.end(), 0.f);
      for (int k = 0; k < 4; ++k)
        for (size_t i = 0; i < N; ++i) {
          const size_t idx = (p * 4 + k) * N + i;
          const uint32_t si = probe_surfel[idx];
          if (si == kNoSurfel) continue;
          const glm::vec3& rho = albedo(probe_res[idx].prim);
          const float* e = &v[si * S * kc];
          for (size_t j = 0; j < S; ++j)
            for (int c = 0; c < 3; ++c) {
              const float ej = e[j * kc + (kc == 3 ? size_t(c) : 0)];
              if (ej == 0.f) continue;
              acc[(j * 3 + c) * 4 + k] += rho[c] * ej;
            }
        }
      for (size_t q = 0; q < S * 12; ++q) (*lprt)[p * S * 12 + q] = acc[q] / float(N);
    }
  });
}

}  // namespace

std::vector<ProbeData> bakeTransfer(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry,
                                    std::span<const glm::vec3> probes, const TransferSettings& s,
                                    TransferStats& stats, std::span<const glm::vec3> lprt_sources,
                                    std::vector<float>* lprt, std::span<const glm::vec3> sun_directions,
                                    std::vector<float>* sun, CubeTransfer* cube) {
  DRTV_CHECK(s.probe_rays_per_basis > 0 && s.surfel_rays > 0 && s.bounces >= 1 && s.surfel_cell_m > 0.f);
  const size_t P = probes.size(), N = size_t(s.probe_rays_per_basis), M = size_t(s.surfel_rays);
  const bool want_lprt = !lprt_sources.empty() && (lprt != nullptr || cube != nullptr);
  const bool want_sun = s.prt && !sun_directions.empty() && sun != nullptr && s.representation == Representation::kShL1;
  const bool want_cube_sun = cube && s.prt && !sun_directions.empty();
  if (sun) sun->clear();
  if (cube) {
    *cube = CubeTransfer{};
    cube->prt.resize(P);
    cube->sky_h.resize(P);
    cube->sky_delta.resize(P);
  }
  const TransferContext ctx{scene, geometry, s, P, N, M, 1.f / s.surfel_cell_m,
                            raytrace::hashKey(s.seed, uint64_t(uint32_t(geometry.key.ix)), uint64_t(uint32_t(geometry.key.iy)), 0x7472616eull)};

  auto t0 = Clock::now();
  std::vector<ProbeData> out(P);
  std::vector<RayResult> probe_res(P * 4 * N);
  traceProbes(ctx, probes, out, probe_res, cube);
  stats.probe_rays += uint64_t(P) * (4 * N + 1);
  stats.probe_seconds += since(t0);
  if (!s.prt && !want_lprt) return out;

  t0 = Clock::now();
  SurfaceCells cells(scene, s.cell_sides && s.representation == Representation::kShL1);
  cells.markObjects(geometry, ctx.inv_cell);
  std::vector<Surfel> surfels;
  std::vector<uint32_t> probe_surfel;
  const size_t level1 = levelOneSurfels(ctx, probe_res, cells, surfels, probe_surfel, stats);
  std::vector<sh::Sh4> direct;
  // LPRT's later bounces walk the surface cache's links; without PRT the cache is traced for them
  // alone (its transfer is then dropped: T stays 0).
  // fc3 keeps the talk's single bounce, so that its archives stay those of every build before
  // (DESIGN.md: fc3 reproducible bit for bit); sh-l1 (and a cube baked beside it) carries all
  // `bounces`.
  SurfelLinks links;
  const bool lprt_links = want_lprt && lprtSweepCount(s) > 0 && s.representation == Representation::kShL1;
  std::vector<Sh4Rgb> transfer;
  if (s.prt || lprt_links)
    transfer = surfaceCache(ctx, cells, surfels, stats, want_sun || want_cube_sun ? &direct : nullptr, lprt_links ? &links : nullptr);
  if (s.prt) {
    if (cube) gatherPrtCube(ctx, probes, probe_res, probe_surfel, transfer, *cube);
    if (s.representation == Representation::kShL1)
      gatherPrtShL1(ctx, probes, probe_res, probe_surfel, transfer, out);
    else
      gatherPrt(ctx, probe_res, probe_surfel, transfer, out);
  }
  stats.surfel_seconds += since(t0);
  if (want_sun || want_cube_sun) {
    t0 = Clock::now();
    bakeSunTransfer(ctx, probes, surfels, level1, direct, probe_res, probe_surfel, sun_directions, want_sun ? sun : nullptr,
                    want_cube_sun ? &cube->sun : nullptr, stats);
    stats.sun_seconds += since(t0);
  }
  if (!want_lprt) return out;

  t0 = Clock::now();
  bakeLprt(ctx, probes, surfels, level1, lprt_links ? &links : nullptr, probe_res, probe_surfel, lprt_sources, lprt,
           cube ? &cube->lprt : nullptr, stats);
  stats.lprt_seconds += since(t0);
  return out;
}

}  // namespace drtv::baker
