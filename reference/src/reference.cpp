// The path-traced reference. See reference.h for the model, the estimator and the references:
//  [1] pbrt-v4 (Pharr, Jakob, Humphreys 2023), [2] the talk, [3] DESIGN.md.
#include "drtv/reference/reference.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "drtv/raytrace/sampling.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/formats/sector.h"
#include "drtv/formats/sh.h"

namespace drtv::reference {
namespace {

// The absolute part of rayOffset: 0.1 mm, below any modelled detail.
constexpr float kRayOffsetAbsM = 1e-4f;
// The relative part: 30 float ulps (2^-23 each) of the largest coordinate.
constexpr float kRayOffsetRel = 30.f * 1.1920929e-7f;
// A shadow ray towards a point light stops this fraction short of it, so that a light sitting
// exactly on a surface is not shadowed by that surface.
constexpr float kLightSegmentEnd = 0.9999f;
// Margin added to the halo that takes in the whole world, metres.
constexpr double kWholeWorldMarginM = 1.0;

glm::vec3 safeNormal(const glm::vec3& n) {
  if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) return {0.f, 0.f, 1.f};
  const glm::dvec3 d(n);
  const double m = std::max({std::fabs(d.x), std::fabs(d.y), std::fabs(d.z)});
  if (!(m > 0.0)) return {0.f, 0.f, 1.f};
  return glm::vec3(glm::normalize(d / m));
}

// The random number of dimension `dim` of path `sample` at query `point` (reference.h).
struct PathRng {
  uint64_t key;
  uint32_t dim = 0;
  PathRng(uint64_t seed, uint64_t point, uint64_t sample) : key(raytrace::hashKey(seed, point, sample)) {}
  glm::vec2 next2() {
    const uint64_t bits = raytrace::mix64(key ^ raytrace::mix64(dim++));
    // Two 24-bit floats from one 64-bit hash: the top 24 bits and the next 24.
    return {raytrace::unitFloat(bits), raytrace::unitFloat(bits << 24)};
  }
  float next1() { return raytrace::unitFloat(raytrace::mix64(key ^ raytrace::mix64(dim++))); }
};

// Per-channel running sums of one part over paths (double: N up to millions of small values).
struct Accum {
  glm::dvec3 sum{0.0}, sum2{0.0};
  void add(const glm::vec3& v) {
    const glm::dvec3 d(v);
    sum += d;
    sum2 += d * d;
  }
  Estimate finish(int n) const {
    Estimate e;
    const glm::dvec3 mean = sum / double(n);
    glm::dvec3 var = (sum2 - sum * mean) / double(std::max(1, n - 1));
    var = glm::max(var, glm::dvec3(0.0));  // rounding can make it slightly negative
    e.mean = glm::vec3(mean);
    e.std_error = glm::vec3(glm::sqrt(var / double(n)));
    return e;
  }
};

struct LocalLight {
  glm::vec3 position;   // local frame
  glm::vec3 intensity;  // per sr
};

// Everything a path needs, resolved once per batch.
struct Prepared {
  ReferenceSun sun;
  std::vector<LocalLight> lights;
  const Sky* sky;
  double hour;
};

Prepared prepare(const glm::dvec3& origin, const ReferenceLighting& lighting) {
  Prepared p;
  p.sun = referenceSun(lighting.sky, lighting.hour);
  p.sky = &lighting.sky;
  p.hour = lighting.hour;
  for (const PointLight& l : lighting.lights) p.lights.push_back({glm::vec3(l.position - origin), l.intensity});
  return p;
}

glm::vec3 skyRadiance(const Prepared& p, const glm::vec3& dir) { return p.sky->skyRadiance(glm::dvec3(dir), p.hour); }

// Past this many lights a path's vertices trace shadow rays to the lights that matter and sample
// the rest (a town of 1,255 lamps: 1,255 shadow rays a vertex made its reference 40x slower than a
// town of 85). Each vertex weighs every light by its unoccluded irradiance there (no ray); a light
// carrying at least kExactLightShare of the sum is traced as before, the others ("the tail") by
// kTailLightSamples draws in proportion to their weights, each counted as its irradiance over its
// probability: unbiased, with the variance of the tail only (the noise the accuracy reports).
constexpr size_t kExactLightsUpTo = 16;
constexpr float kExactLightShare = 0.05f;  // so at most 20 lights a vertex are traced
constexpr int kTailLightSamples = 4;

// Direct irradiance at local point x (already offset off its surface) with unit normal n.
// Returns (sun, lights) and counts rays. `rng` (a path's vertex): lights past kExactLightsUpTo
// are sampled as above; nullptr: every light traced.
std::pair<glm::vec3, glm::vec3> direct(const raytrace::RayScene& scene, const Prepared& p, const glm::vec3& x, const glm::vec3& n,
                                       uint64_t& rays, PathRng* rng = nullptr) {
  glm::vec3 sun(0.f), lights(0.f);
  const float cs = glm::dot(n, p.sun.direction);
  if (cs > 0.f && glm::any(glm::greaterThan(p.sun.irradiance, glm::vec3(0.f)))) {
    ++rays;
    if (!scene.occluded(raytrace::Ray{x, 0.f, p.sun.direction, std::numeric_limits<float>::infinity()}))
      sun = p.sun.irradiance * cs;
  }
  // Light l's unoccluded irradiance factor at x (intensity times this), 0 when it cannot reach.
  auto geometric = [&](const LocalLight& l, glm::vec3& d) {
    d = l.position - x;
    const float r2 = glm::dot(d, d);
    if (!(r2 > 0.f)) return 1.f / kMinLightDistance2;  // on the point itself: cosine taken as 1
    const float cl = glm::dot(n, d) / std::sqrt(r2);
    if (!(cl > 0.f) || !glm::any(glm::greaterThan(l.intensity, glm::vec3(0.f)))) return 0.f;
    return cl / std::max(r2, kMinLightDistance2);
  };
  auto visible = [&](const glm::vec3& d) {
    if (!(glm::dot(d, d) > 0.f)) return true;
    ++rays;
    return !scene.occluded(raytrace::Ray{x, 0.f, d, kLightSegmentEnd});
  };
  if (!rng || p.lights.size() <= kExactLightsUpTo) {
    for (const LocalLight& l : p.lights) {
      glm::vec3 d;
      const float g = geometric(l, d);
      if (g > 0.f && visible(d)) lights += l.intensity * g;
    }
    return {sun, lights};
  }
  thread_local std::vector<float> weight;
  weight.resize(p.lights.size());
  double total = 0.0;
  for (size_t i = 0; i < p.lights.size(); ++i) {
    glm::vec3 d;
    const LocalLight& l = p.lights[i];
    weight[i] = geometric(l, d) * (l.intensity.r + l.intensity.g + l.intensity.b);
    total += weight[i];
  }
  if (!(total > 0.0)) return {sun, lights};
  double tail = 0.0;
  for (size_t i = 0; i < p.lights.size(); ++i) {
    if (!(weight[i] > 0.f)) continue;
    if (weight[i] >= kExactLightShare * total) {
      glm::vec3 d;
      const float g = geometric(p.lights[i], d);
      if (visible(d)) lights += p.lights[i].intensity * g;
      weight[i] = 0.f;  // out of the tail
    } else {
      tail += weight[i];
    }
  }
  if (!(tail > 0.0)) return {sun, lights};
  for (int k = 0; k < kTailLightSamples; ++k) {
    // The light whose cumulative weight passes u * tail (a linear walk: the tail's weights are
    // not kept sorted, and one walk costs far less than the shadow rays it saves).
    const double u = double(rng->next1()) * tail;
    double acc = 0.0;
    size_t pick = p.lights.size();
    for (size_t i = 0; i < p.lights.size(); ++i) {
      if (!(weight[i] > 0.f)) continue;
      acc += weight[i];
      pick = i;
      if (acc > u) break;
    }
    if (pick == p.lights.size()) break;
    glm::vec3 d;
    const float g = geometric(p.lights[pick], d);
    if (visible(d)) lights += p.lights[pick].intensity * (g * float(tail / double(weight[pick]) / kTailLightSamples));
  }
  return {sun, lights};
}

ReferenceIrradiance estimate(const ReferenceScene& scene, const Prepared& prep, const ReferenceQuery& q,
                             const ReferenceSettings& s) {
  DRTV_CHECK_LE(2, s.samples);
  DRTV_CHECK_LE(1, s.max_bounces);
  DRTV_CHECK_LE(1, s.roulette_after);
  const raytrace::RayScene& rs = scene.rays();
  const glm::vec3 n0 = safeNormal(q.normal);
  const glm::vec3 p0 = scene.toLocal(q.position);
  const glm::vec3 o0 = p0 + n0 * rayOffset(p0);
  const raytrace::Frame frame0(n0);

  ReferenceIrradiance out;
  {
    const auto [sun, lights] = direct(rs, prep, o0, n0, out.rays);
    out.parts[kRefDirectSun].mean = sun;
    out.parts[kRefDirectLocal].mean = lights;
  }

  std::array<Accum, 4> acc;  // sun bounce, sky bounce, direct sky, local lights
  Accum total;
  for (int k = 0; k < s.samples; ++k) {
    PathRng rng(s.seed, q.point_id, uint64_t(k));
    // The tail of many lights (direct()) draws from its own stream: the path's directions are the
    // same whatever the lights.
    PathRng light_rng(raytrace::mix64(s.seed ^ 0x6c69676874730000ull), q.point_id, uint64_t(k));
    glm::vec3 sun_b(0.f), sky_b(0.f), sky_d(0.f), loc_b(0.f);
    raytrace::Ray ray{o0, 0.f, frame0.toWorld(raytrace::cosineHemisphere(rng.next2())), std::numeric_limits<float>::infinity()};
    glm::vec3 beta(1.f);  // throughput after the hits so far (pi cancels the pdf's 1/pi [1, A.5])
    for (int bounce = 0;; ++bounce) {
      ++out.rays;
      const raytrace::Hit h = rs.intersect(ray);
      if (!h.hit()) {
        const glm::vec3 L = skyRadiance(prep, ray.dir) * sh::kPi;
        if (bounce == 0) sky_d += L;
        else sky_b += beta * L;
        break;
      }
      // A back face: the ray entered geometry, which carries no light (reference.h); a
      // double-sided surface has no back face.
      if (!rs.frontFace(ray, h.prim)) break;
      beta *= scene.albedo(h.prim);
      const float rr_max = std::max({beta.r, beta.g, beta.b});
      if (!(rr_max > 0.f)) break;
      const glm::vec3 n = rs.facingNormal(ray, h.prim);
      const glm::vec3 x = ray.origin + ray.dir * h.t;
      const glm::vec3 o = x + n * rayOffset(x);
      const auto [sun, lights] = direct(rs, prep, o, n, out.rays, &light_rng);
      sun_b += beta * sun;
      loc_b += beta * lights;
      if (bounce + 1 >= s.max_bounces) break;
      if (bounce + 1 >= s.roulette_after) {
        // Russian roulette [1, sec. 14.5]: survive with probability max(beta), reweighted.
        const float survive = std::min(1.f, rr_max);
        if (rng.next1() >= survive) break;
        beta /= survive;
      }
      ray = raytrace::Ray{o, 0.f, raytrace::Frame(n).toWorld(raytrace::cosineHemisphere(rng.next2())), std::numeric_limits<float>::infinity()};
    }
    acc[0].add(sun_b);
    acc[1].add(sky_b);
    acc[2].add(sky_d);
    acc[3].add(loc_b);
    total.add(sun_b + sky_b + sky_d + loc_b);
  }
  out.parts[kRefSunBounce] = acc[0].finish(s.samples);
  out.parts[kRefSkyBounce] = acc[1].finish(s.samples);
  out.parts[kRefDirectSky] = acc[2].finish(s.samples);
  out.parts[kRefLocalLights] = acc[3].finish(s.samples);
  out.ambient = total.finish(s.samples);
  return out;
}

}  // namespace

// ---- ReferenceScene ------------------------------------------------------------------------

struct ReferenceScene::Impl {
  glm::dvec3 origin{0.0};
  raytrace::RayScene rays;
  std::vector<glm::vec3> albedo;  // per triangle
  float top_z = 0.f;              // the gathered triangles' highest z (world metres)
  std::vector<std::string> notes;
  std::optional<raytrace::RayScene> view;
  std::vector<glm::vec3> view_albedo;
  std::vector<uint8_t> view_dynamic;
  explicit Impl(raytrace::RayScene r) : rays(std::move(r)) {}
};

namespace {

// Appends every dynamic instance overlapping [lo, hi] (xy, world metres) to the camera view's
// soup, in the local frame at `origin`; bad triangles are skipped with a note. The world's mesh
// indices are sound (ReferenceScene::build has the geometry validate the world first).
void appendDynamic(const worlds::World& world, const glm::dvec3& origin, const glm::dvec2& lo, const glm::dvec2& hi,
                   std::vector<glm::vec3>& vertices, std::vector<glm::vec3>& albedo, std::vector<uint8_t>& dynamic,
                   std::vector<std::string>& notes) {
  for (const worlds::Instance& inst : world.instances) {
    if (inst.cls != worlds::InstanceClass::kDynamic) continue;
    DRTV_CHECK_LT(inst.mesh, world.meshes.size());
    const worlds::Mesh& mesh = world.meshes[inst.mesh];
    size_t skipped = 0;
    std::vector<glm::vec3> tri;
    for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      glm::dvec3 w[3];
      bool ok = true;
      for (int k = 0; k < 3; ++k) {
        const uint32_t i = mesh.indices[t + k];
        if (i >= mesh.positions.size()) { ok = false; break; }
        w[k] = glm::dvec3(inst.transform * glm::dvec4(glm::dvec3(mesh.positions[i]), 1.0));
      }
      if (ok) {
        for (int k = 0; k < 3; ++k) ok = ok && std::isfinite(w[k].x) && std::isfinite(w[k].y) && std::isfinite(w[k].z);
      }
      if (ok) {
        const glm::dvec3 mn = glm::min(w[0], glm::min(w[1], w[2])), mx = glm::max(w[0], glm::max(w[1], w[2]));
        if (mx.x < lo.x || mn.x > hi.x || mx.y < lo.y || mn.y > hi.y) continue;  // outside the region
      }
      glm::vec3 v[3];
      if (ok) {
        for (int k = 0; k < 3; ++k) v[k] = glm::vec3(w[k] - origin);
        const glm::vec3 c = glm::cross(v[1] - v[0], v[2] - v[0]);
        ok = glm::dot(c, c) > 0.f && std::isfinite(glm::dot(c, c));
      }
      if (!ok) {
        ++skipped;
        continue;
      }
      vertices.insert(vertices.end(), {v[0], v[1], v[2]});
      albedo.push_back(glm::clamp(mesh.albedo, 0.f, 1.f));
      dynamic.push_back(1);
    }
    if (skipped > 0)
      notes.push_back("skipped: dynamic instance '" + inst.name + "' (mesh '" + mesh.name + "'): " + std::to_string(skipped) +
                      " bad or degenerate triangles");
  }
}

}  // namespace

ReferenceScene::ReferenceScene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ReferenceScene::ReferenceScene(ReferenceScene&&) noexcept = default;
ReferenceScene& ReferenceScene::operator=(ReferenceScene&&) noexcept = default;
ReferenceScene::~ReferenceScene() = default;

Result<ReferenceScene> ReferenceScene::build(const worlds::World& world, const std::string& where,
                                             const ReferenceRegion& region) {
  auto geometry = raytrace::WorldGeometry::build(world, where);
  if (!geometry) return std::unexpected(geometry.error());
  SectorKey key;
  double halo = 0.0;
  if (region.whole_world) {
    const glm::dvec3 lo = geometry->boundsMin(), hi = geometry->boundsMax();
    key = sectorAt(0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y));
    // The smallest halo around the centre sector's square that takes in the whole xy bounds.
    const double x0 = key.ix * kSectorSizeM, y0 = key.iy * kSectorSizeM;
    halo = std::max({x0 - lo.x, hi.x - x0 - kSectorSizeM, y0 - lo.y, hi.y - y0 - kSectorSizeM, 0.0}) +
           kWholeWorldMarginM;
  } else {
    if (!std::isfinite(region.centre.x) || !std::isfinite(region.centre.y) || !(region.halo_m >= 0.0))
      return fail(where + ": reference region: centre must be finite and halo >= 0");
    key = sectorAt(region.centre.x, region.centre.y);
    halo = region.halo_m;
  }
  const raytrace::SectorGeometry g = geometry->gather(key, halo);
  const std::vector<uint8_t> two_sided = g.twoSided();
  auto rays = raytrace::RayScene::build(g.vertices, two_sided);
  if (!rays) return std::unexpected(rays.error().context(where));
  auto impl = std::make_unique<Impl>(std::move(*rays));
  impl->origin = glm::dvec3(key.ix * kSectorSizeM, key.iy * kSectorSizeM, 0.0);
  impl->albedo.resize(g.triangleCount());
  for (size_t i = 0; i < g.triangleCount(); ++i) impl->albedo[i] = glm::clamp(g.materials[g.material[i]], 0.f, 1.f);
  impl->notes = geometry->notes();
  impl->top_z = g.z_max;
  if (region.camera_view) {
    std::vector<glm::vec3> vertices = g.vertices;
    impl->view_albedo = impl->albedo;
    impl->view_dynamic.assign(impl->albedo.size(), 0);
    const glm::dvec2 lo = region.whole_world ? glm::dvec2(-1e300) : glm::dvec2(impl->origin) - halo;
    const glm::dvec2 hi = region.whole_world ? glm::dvec2(1e300) : glm::dvec2(impl->origin) + kSectorSizeM + halo;
    appendDynamic(world, impl->origin, lo, hi, vertices, impl->view_albedo, impl->view_dynamic, impl->notes);
    std::vector<uint8_t> view_two_sided = two_sided;  // dynamic objects: one-sided
    if (!view_two_sided.empty()) view_two_sided.resize(vertices.size() / 3, 0);
    auto view = raytrace::RayScene::build(vertices, view_two_sided);
    if (!view) return std::unexpected(view.error().context(where));
    impl->view.emplace(std::move(*view));
  }
  return ReferenceScene(std::move(impl));
}

glm::dvec3 ReferenceScene::origin() const { return impl_->origin; }
const raytrace::RayScene& ReferenceScene::rays() const { return impl_->rays; }
glm::vec3 ReferenceScene::albedo(uint32_t prim) const {
  DRTV_CHECK_LT(size_t(prim), impl_->albedo.size());
  return impl_->albedo[prim];
}
size_t ReferenceScene::triangleCount() const { return impl_->albedo.size(); }
double ReferenceScene::topZ() const { return impl_->top_z; }
const std::vector<std::string>& ReferenceScene::notes() const { return impl_->notes; }
bool ReferenceScene::hasCameraView() const { return impl_->view.has_value(); }
const raytrace::RayScene& ReferenceScene::viewRays() const {
  DRTV_CHECK(impl_->view.has_value());
  return *impl_->view;
}
glm::vec3 ReferenceScene::viewAlbedo(uint32_t prim) const {
  DRTV_CHECK_LT(size_t(prim), impl_->view_albedo.size());
  return impl_->view_albedo[prim];
}
bool ReferenceScene::viewDynamic(uint32_t prim) const {
  DRTV_CHECK_LT(size_t(prim), impl_->view_dynamic.size());
  return impl_->view_dynamic[prim] != 0;
}

// ---- Queries -------------------------------------------------------------------------------

const char* referencePartName(ReferencePart part) {
  switch (part) {
    case kRefSunBounce: return "sun_bounce";
    case kRefSkyBounce: return "sky_bounce";
    case kRefDirectSky: return "direct_sky";
    case kRefLocalLights: return "local_lights";
    case kRefDirectSun: return "direct_sun";
    case kRefDirectLocal: return "direct_local";
    case kRefPartCount: break;
  }
  return "?";
}

float rayOffset(const glm::vec3& p) {
  const float m = std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
  return kRayOffsetAbsM + kRayOffsetRel * (std::isfinite(m) ? m : 0.f);
}

ReferenceSun referenceSun(const Sky& sky, double hour) {
  ReferenceSun s;
  const glm::dvec3 d = sky.sunDirection(hour);
  s.direction = glm::vec3(d);
  if (d.z > 0.0) s.irradiance = sky.sun_irradiance.at(hour);
  return s;
}

ReferenceIrradiance referenceIrradiance(const ReferenceScene& scene, const ReferenceLighting& lighting,
                                        const ReferenceQuery& query, const ReferenceSettings& settings) {
  return estimate(scene, prepare(scene.origin(), lighting), query, settings);
}

std::vector<ReferenceIrradiance> referenceIrradiance(const ReferenceScene& scene, const ReferenceLighting& lighting,
                                                     std::span<const ReferenceQuery> queries,
                                                     const ReferenceSettings& settings, int threads) {
  const Prepared prep = prepare(scene.origin(), lighting);
  std::vector<ReferenceIrradiance> out(queries.size());
  auto body = [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) out[i] = estimate(scene, prep, queries[i], settings);
  };
  if (threads == 1) {
    body(tbb::blocked_range<size_t>(0, queries.size()));
    return out;
  }
  std::optional<tbb::global_control> limit;
  if (threads > 1) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(threads));
  tbb::parallel_for(tbb::blocked_range<size_t>(0, queries.size(), 1), body);
  return out;
}

DirectIrradiance directIrradiance(const raytrace::RayScene& occluders, const glm::dvec3& origin, const ReferenceLighting& lighting,
                                  const glm::dvec3& position, const glm::vec3& normal) {
  const Prepared prep = prepare(origin, lighting);
  const glm::vec3 n = safeNormal(normal);
  const glm::vec3 p(position - origin);
  uint64_t rays = 0;
  const auto [sun, lights] = direct(occluders, prep, p + n * rayOffset(p), n, rays);
  return {sun, lights};
}

}  // namespace drtv::reference
