// The accuracy sweep. See accuracy.h for the method, the knobs and the references [1]-[3].
#include "drtv/eval/accuracy.h"
#include "drtv/eval/technique.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>

#include "drtv/baker/placement.h"
#include "drtv/reference/reference.h"
#include "drtv/raytrace/sampling.h"
#include "drtv/formats/memory_limit.h"
#include "drtv/formats/sh.h"
#include "render_support.h"
#include "drtv/baker/stopwatch.h"

namespace drtv::eval {
using namespace baker;
using namespace reference;
namespace {

using baker::detail::Clock;
using baker::detail::since;

// Share of the sample points put on dynamic objects when the world has some (the talk's spheres
// are what its slides 7-9 show; the rest are static surfaces seen from the probes).
constexpr double kDynamicShare = 0.25;
// Attempts per wanted point before giving up on finding more (rays that escape or leave the
// sample region are retried).
constexpr int kAttemptsPerPoint = 64;
// Rays of the buried-point test (buried()).
constexpr int kBuriedTestRays = 16;
// Distinct hash streams of the sample-point generator.
constexpr uint64_t kStreamStatic = 1, kStreamDynamic = 2;

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

struct Point {
  glm::dvec3 position;
  glm::vec3 normal;
  bool dynamic;
};

// One configuration's ambient at every (hour, point): values[h * points + i].
using Values = std::vector<glm::vec3>;

struct Truth {
  std::vector<glm::vec3> mean, std_error;  // [h * points + i]
  std::array<std::vector<glm::vec3>, 4> parts;  // sun bounce, sky bounce, direct sky, local lights
};

using ErrorStats = AmbientError;

ErrorStats compare(const Values& v, const Truth& t) { return ambientError(v, t.mean); }

// Appends to a row's note that its relative figures are relative to the floor.
std::string flooredNote(std::string note, bool floored) {
  if (!floored) return note;
  return note + (note.empty() ? "" : "; ") + "reference ambient below the floor (" + std::to_string(kAmbientErrorFloor) +
         " per channel): errors relative to the floor, see abs_error";
}

bool inRange(const raytrace::SectorRange& r, const glm::dvec3& p) { return r.contains(sectorAt(p.x, p.y)); }

// The block's sectors whose eight neighbours are all in the block; all of it when none are.
raytrace::SectorRange innerRange(const raytrace::SectorRange& block) {
  raytrace::SectorRange r{block.x0 + 1, block.x1 - 1, block.y0 + 1, block.y1 - 1};
  return r.empty() ? block : r;
}

glm::dvec3 probeWorld(const Sector& s, const ProbeRecord& r) {
  return glm::dvec3(s.key.ix * kSectorSizeM, s.key.iy * kSectorSizeM, 0.0) +
         glm::dvec3(r.position[0], r.position[1], r.position[2]);
}

// Static sample points (accuracy.h, "Method"): the first front-face hit of a ray from a probe
// in a random direction, inside `region`; keyed by the seed.
std::vector<Point> staticPoints(const ReferenceScene& scene, const InMemoryBake& bake, const raytrace::SectorRange& region, int count,
                                uint64_t seed) {
  std::vector<glm::dvec3> probes;
  for (const Sector& s : bake.sectors)
    for (const ProbeRecord& r : s.probes) probes.push_back(probeWorld(s, r));
  std::vector<Point> out;
  if (probes.empty()) return out;
  for (int i = 0; int(out.size()) < count && i < kAttemptsPerPoint * count; ++i) {
    const uint64_t h = raytrace::hashKey(seed, kStreamStatic, uint64_t(i));
    const glm::dvec3 origin = probes[raytrace::mix64(h) % probes.size()];
    const glm::vec3 dir = raytrace::uniformSphere({raytrace::unitFloat(raytrace::mix64(h ^ 1)), raytrace::unitFloat(raytrace::mix64(h ^ 2))});
    const raytrace::Ray ray{scene.toLocal(origin), 0.f, dir, std::numeric_limits<float>::infinity()};
    const raytrace::Hit hit = scene.rays().intersect(ray);
    if (!hit.hit() || !scene.rays().frontFace(ray, hit.prim)) continue;
    const glm::dvec3 p = scene.toWorld(ray.origin + dir * hit.t);
    if (!inRange(region, p)) continue;
    out.push_back({p, scene.rays().normal(hit.prim), false});
  }
  return out;
}

// True when a surface point is buried in static geometry (a dynamic object pushed into a wall or
// a block): more than kInsideBackfaceFraction of kBuriedTestRays rays over its hemisphere hit
// back faces. No camera sees such a point, and the reference gives it no light at all (a back
// face carries none), so counting it would measure the scene's overlap, not the technique: on the
// Cornell world the sphere sinks into the short block and 68 of its 120 samples were buried,
// carrying most of the local-light error.
bool buried(const ReferenceScene& scene, const glm::dvec3& p, const glm::vec3& n, uint64_t seed) {
  const glm::vec3 local = scene.toLocal(p);
  const glm::vec3 origin = local + n * rayOffset(local);
  int back = 0;
  for (int k = 0; k < kBuriedTestRays; ++k) {
    const uint64_t h = raytrace::hashKey(seed, uint64_t(k));
    glm::vec3 d = raytrace::uniformSphere({raytrace::unitFloat(raytrace::mix64(h)), raytrace::unitFloat(raytrace::mix64(h ^ 1))});
    if (glm::dot(d, n) < 0.f) d = -d;
    const raytrace::Ray ray{origin, 0.f, d, std::numeric_limits<float>::infinity()};
    const raytrace::Hit hit = scene.rays().intersect(ray);
    back += hit.hit() && !scene.rays().frontFace(ray, hit.prim);
  }
  return back > kInsideBackfaceFraction * kBuriedTestRays;
}

// Points on the world's dynamic instances inside `region`, area-weighted, not buried in static
// geometry (above), keyed by the seed.
std::vector<Point> dynamicPoints(const worlds::World& world, const ReferenceScene& scene, const raytrace::SectorRange& region, int count,
                                 uint64_t seed) {
  struct Tri {
    glm::dvec3 a, b, c;
  };
  std::vector<Tri> tris;
  std::vector<double> cdf;
  double total = 0;
  for (const worlds::Instance& inst : world.instances) {
    if (inst.cls != worlds::InstanceClass::kDynamic || inst.mesh >= world.meshes.size()) continue;
    const worlds::Mesh& m = world.meshes[inst.mesh];
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      glm::dvec3 v[3];
      bool ok = true;
      for (int k = 0; k < 3; ++k) {
        if (m.indices[t + k] >= m.positions.size()) { ok = false; break; }
        v[k] = glm::dvec3(inst.transform * glm::dvec4(glm::dvec3(m.positions[m.indices[t + k]]), 1.0));
      }
      if (!ok) continue;
      const double a = 0.5 * glm::length(glm::cross(v[1] - v[0], v[2] - v[0]));
      if (!(a > 0.0) || !std::isfinite(a) || !inRange(region, (v[0] + v[1] + v[2]) / 3.0)) continue;
      tris.push_back({v[0], v[1], v[2]});
      total += a;
      cdf.push_back(total);
    }
  }
  std::vector<Point> out;
  if (tris.empty()) return out;
  for (int i = 0; int(out.size()) < count && i < kAttemptsPerPoint * count; ++i) {
    const uint64_t h = raytrace::hashKey(seed, kStreamDynamic, uint64_t(i));
    const double u = double(raytrace::unitFloat(raytrace::mix64(h))) * total;
    const size_t k = std::min(size_t(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin()), tris.size() - 1);
    double s = raytrace::unitFloat(raytrace::mix64(h ^ 1)), t = raytrace::unitFloat(raytrace::mix64(h ^ 2));
    if (s + t > 1.0) s = 1.0 - s, t = 1.0 - t;
    const Tri& tr = tris[k];
    const glm::dvec3 p = tr.a + s * (tr.b - tr.a) + t * (tr.c - tr.a);
    const glm::vec3 n(glm::normalize(glm::cross(tr.b - tr.a, tr.c - tr.a)));
    if (buried(scene, p, n, h)) continue;
    out.push_back({p, n, true});
  }
  return out;
}

// Runtime ambient at every (hour, point) for `bake` under `options`.
Result<Values> runtimeValues(const InMemoryBake& bake, runtime::RuntimeOptions options, const std::vector<double>& hours,
                             const std::vector<Point>& points) {
  options.cache.max_sectors = std::max<int>(options.cache.max_sectors, int(bake.sectors.size()));
  Values v;
  v.reserve(hours.size() * points.size());
  for (double hour : hours) {
    auto rt = detail::makeRuntime(bake.manifest, bake.sectors, hour, options, points.front().position,
                                  [](SectorKey) { return true; }, nullptr);
    if (!rt) return std::unexpected(rt.error());
    for (const Point& p : points) {
      (*rt)->update(p.position);
      v.push_back((*rt)->ambient(p.position, p.normal).irradiance);
    }
  }
  return v;
}

// A technique's ambient at every (hour, point), the camera at each point in turn (as runtimeValues).
Result<Values> techniqueValues(Technique& t, const worlds::World& world, const std::vector<double>& hours,
                               const std::vector<Point>& points) {
  Values v;
  v.reserve(hours.size() * points.size());
  for (double hour : hours) {
    if (auto r = t.setLighting(hour, world.lights); !r) return std::unexpected(r.error());
    for (const Point& p : points) {
      if (auto r = t.update(p.position); !r) return std::unexpected(r.error());
      v.push_back(t.ambient(p.position, p.normal));
    }
  }
  return v;
}

// Median wall milliseconds of a relight + full fill (accuracy.h, "Costs").
Result<double> relightFillMs(const InMemoryBake& bake, runtime::RuntimeOptions options, const std::vector<double>& hours,
                             const glm::dvec3& camera, int repeats) {
  options.cache.max_sectors = std::max<int>(options.cache.max_sectors, int(bake.sectors.size()));
  auto rt = detail::makeRuntime(bake.manifest, bake.sectors, hours.front(), options, camera, [](SectorKey) { return true; }, nullptr);
  if (!rt) return std::unexpected(rt.error());
  std::vector<double> ms;
  for (int r = 0; r < repeats; ++r) {
    // Alternate between two times far enough apart that lightingChange forces a relight.
    if (auto t = (*rt)->setTime(hours.front() + (r % 2 ? 0.0 : 3.0)); !t) return std::unexpected(t.error());
    const auto t0 = Clock::now();
    (*rt)->update(camera);
    ms.push_back(1e3 * since(t0));
  }
  std::sort(ms.begin(), ms.end());
  return ms[ms.size() / 2];
}

// The volume emulated outside the runtime with `levels` steps per unit of the HDR scale (0 =
// float): nearest fill, no blur, trilinear over texels, the talk's shading weights.
Result<Values> emulatedVolumeValues(const InMemoryBake& bake, runtime::RuntimeOptions options, const std::vector<double>& hours,
                                    const std::vector<Point>& points, double levels) {
  options.cache.max_sectors = std::max<int>(options.cache.max_sectors, int(bake.sectors.size()));
  Values v;
  for (double hour : hours) {
    auto rt = detail::makeRuntime(bake.manifest, bake.sectors, hour, options, points.front().position,
                                  [](SectorKey) { return true; }, nullptr);
    if (!rt) return std::unexpected(rt.error());
    const runtime::ProbeCache& cache = (*rt)->cache();
    const double scale = cache.packedScale();
    auto quantise = [&](float x) {
      if (levels <= 0.0) return x;
      const double q = std::round(std::clamp(double(x) / scale, 0.0, 1.0) * levels) / levels;
      return float(q * scale);
    };
    const glm::dvec3 ts(options.volume.texel_size_m);
    for (const Point& p : points) {
      const glm::dvec3 s = p.position + glm::dvec3(p.normal) * double(options.normal_offset_m);
      const glm::dvec3 t = s / ts - 0.5;
      const glm::dvec3 g0 = glm::floor(t), f = t - g0;
      std::array<glm::vec3, 4> colour{};
      for (int corner = 0; corner < 8; ++corner) {
        const glm::dvec3 g = g0 + glm::dvec3(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        const double w = (corner & 1 ? f.x : 1 - f.x) * (corner & 2 ? f.y : 1 - f.y) * (corner & 4 ? f.z : 1 - f.z);
        const runtime::ProbeRef pr = cache.probeAt((g + 0.5) * ts);
        const runtime::BasisColours c = pr.valid() ? cache.colours(pr) : cache.fallback();
        for (int b = 0; b < 4; ++b)
          for (int ch = 0; ch < 3; ++ch) colour[b][ch] += float(w) * quantise(c[b][ch]);
      }
      const glm::vec4 wt = sh::shadingWeights(p.normal);
      v.push_back(wt.x * colour[0] + wt.y * colour[1] + wt.z * colour[2] + wt.w * colour[3]);
    }
  }
  return v;
}

// Keeps the first `keep` LPRT sources of every sector (they are sorted nearest first, bake.cpp).
InMemoryBake truncateLprt(const InMemoryBake& base, size_t keep) {
  InMemoryBake b = base;
  b.bytes = 0;
  for (Sector& s : b.sectors) {
    const size_t S = s.lprt.sources.size();
    if (S > keep) {
      std::vector<int16_t> coeffs(s.probes.size() * keep * 12);
      for (size_t p = 0; p < s.probes.size(); ++p)
        for (size_t j = 0; j < keep; ++j)
          for (int k = 0; k < 12; ++k) coeffs[(p * keep + j) * 12 + k] = s.lprt.coeffs[(p * S + j) * 12 + k];
      s.lprt.coeffs = std::move(coeffs);
      s.lprt.sources.resize(keep);
    }
    b.bytes += encodedSectorBytes(s.probes.size(), s.lprt.sources.size(), s.has_ground);
  }
  return b;
}

size_t volumeBytes(const runtime::RuntimeOptions& o, double bytes_per_texel) {
  return size_t(double(o.volume.size.x) * o.volume.size.y * o.volume.size.z * bytes_per_texel);
}

}  // namespace

Result<AccuracyReport> measureAccuracy(const worlds::World& world, const std::string& where, const AccuracyOptions& options) {
  const auto t_start = Clock::now();
  if (options.hours.empty()) return fail("accuracy: no hours to evaluate");
  for (double h : options.hours)
    if (!std::isfinite(h)) return fail("accuracy: hour " + fmt(h) + " is not finite");
  if (options.points < 1) return fail("accuracy: --points must be >= 1");
  if (options.reference_samples < 2 || options.probe_samples < 2) return fail("accuracy: --samples must be >= 2");
  // Per point and hour: the reference's answer (mean, error and four parts, ~140 B as it is
  // returned, 72 B kept), each configuration's values (12 B, a few held at once) and the queries.
  {
    constexpr uint64_t kBytesPerPointHour = 400;
    const uint64_t n = uint64_t(options.points) * options.hours.size();
    if (auto ok = checkMemory(n * kBytesPerPointHour, where + ": --points " + std::to_string(options.points),
                              std::to_string(n) + " reference points x hours");
        !ok)
      return std::unexpected(ok.error());
  }
  auto progress = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  std::optional<tbb::global_control> limit;
  if (options.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(options.threads));

  AccuracyReport report;
  report.world = where;
  report.hours = options.hours;
  report.reference_samples = options.reference_samples;

  // The block baked: the 3 x 3 sectors around the centre of the geometry unless asked otherwise.
  auto geometry = raytrace::WorldGeometry::build(world, where);
  if (!geometry) return std::unexpected(geometry.error());
  const raytrace::SectorRange all = geometry->sectors();
  raytrace::SectorRange block = all;
  if (options.sectors) {
    block = *options.sectors;
  } else {
    const glm::dvec3 c = 0.5 * (geometry->boundsMin() + geometry->boundsMax());
    const SectorKey k = sectorAt(c.x, c.y);
    block = {k.ix - 1, k.ix + 1, k.iy - 1, k.iy + 1};
  }
  block = {std::max(block.x0, all.x0), std::min(block.x1, all.x1), std::max(block.y0, all.y0), std::min(block.y1, all.y1)};
  if (block.empty()) return fail(where + ": the sector block holds no sector of the world");
  report.sectors = block;
  const raytrace::SectorRange region = innerRange(block);

  const BakeSettings base_settings = BakeSettings::forQuality(Quality::kDefault, options.seed);
  progress("bake default");
  auto base = bakeInMemory(world, where, base_settings, block, options.threads);
  if (!base) return std::unexpected(base.error());
  if (base->probes == 0) return fail(where + ": the sector block has no probes");

  auto scene = ReferenceScene::build(world, where);
  if (!scene) return std::unexpected(scene.error());
  report.notes = scene->notes();

  // Sample points.
  std::vector<Point> dyn = dynamicPoints(world, *scene, region, int(std::lround(kDynamicShare * options.points)), options.seed);
  std::vector<Point> points = staticPoints(*scene, *base, region, options.points - int(dyn.size()), options.seed);
  report.dynamic_points = dyn.size();
  points.insert(points.end(), dyn.begin(), dyn.end());
  if (points.empty()) return fail(where + ": no sample point found in sectors " + toString(SectorKey{region.x0, region.y0}) + ".." +
                                  toString(SectorKey{region.x1, region.y1}));
  report.points = points.size();

  // The reference at every (hour, point).
  progress("reference at " + std::to_string(points.size()) + " points");
  const auto t_ref = Clock::now();
  Truth truth;
  ReferenceSettings rs;
  rs.samples = options.reference_samples;
  rs.seed = options.seed;
  for (double hour : options.hours) {
    std::vector<ReferenceQuery> q;
    for (size_t i = 0; i < points.size(); ++i) q.push_back({points[i].position, points[i].normal, uint64_t(i)});
    const ReferenceLighting lighting{world.sky, hour, world.lights};
    for (const ReferenceIrradiance& r : referenceIrradiance(*scene, lighting, q, rs, options.threads)) {
      truth.mean.push_back(r.ambient.mean);
      truth.std_error.push_back(r.ambient.std_error);
      for (int k = 0; k < 4; ++k) truth.parts[size_t(k)].push_back(r.parts[size_t(k)].mean);
    }
  }
  report.reference_s = since(t_ref);
  {
    double se = 0, sum = 0;
    for (size_t i = 0; i < truth.mean.size(); ++i)
      for (int c = 0; c < 3; ++c) se += truth.std_error[i][c], sum += truth.mean[i][c];
    report.reference_noise = se / std::max(sum, 3.0 * double(truth.mean.size()) * kAmbientErrorFloor);
    for (const glm::vec3& m : truth.mean) report.reference_mean += glm::dvec3(m);
    report.reference_mean /= double(truth.mean.size());
  }

  const runtime::RuntimeOptions base_rt = detail::runtimeOptionsFor(base->manifest.effects, false);
  const glm::dvec3 camera = points.front().position;
  auto base_ms = relightFillMs(*base, base_rt, options.hours, camera, options.timing_repeats);
  if (!base_ms) return std::unexpected(base_ms.error());

  // One row from a bake and runtime options.
  auto row = [&](const std::string& knob, const std::string& value, bool is_default, const InMemoryBake& bake,
                 const runtime::RuntimeOptions& rt_options, const std::string& note) -> Result<void> {
    progress(knob + "=" + value);
    auto v = runtimeValues(bake, rt_options, options.hours, points);
    if (!v) return std::unexpected(v.error());
    auto ms = &bake == &*base && rt_options.volume.fill == base_rt.volume.fill &&
                      rt_options.volume.texel_size_m == base_rt.volume.texel_size_m &&
                      rt_options.sun_band1_window == base_rt.sun_band1_window
                  ? Result<double>(*base_ms)
                  : relightFillMs(bake, rt_options, options.hours, camera, options.timing_repeats);
    if (!ms) return std::unexpected(ms.error());
    const ErrorStats e = compare(*v, truth);
    report.rows.push_back({knob, value, is_default, e.rel, e.bias, bake.bake_s, *ms, bake.bytes, volumeBytes(rt_options, 12.0),
                           flooredNote(note, e.floored), e.abs});
    return {};
  };
  auto bakeRow = [&](const std::string& knob, const std::string& value, BakeSettings s) -> Result<void> {
    progress("bake " + knob + "=" + value);
    auto b = bakeInMemory(world, where, s, block, options.threads);
    if (!b) return std::unexpected(b.error());
    return row(knob, value, false, *b, base_rt, "");
  };

  // rays_per_basis
  for (int rays : {32, 64, 128, 256, 512}) {
    if (rays == base_settings.transfer.probe_rays_per_basis) {
      if (auto r = row("rays_per_basis", std::to_string(rays), true, *base, base_rt, "the default bake"); !r) return std::unexpected(r.error());
      continue;
    }
    BakeSettings s = base_settings;
    s.transfer.probe_rays_per_basis = rays;
    if (auto r = bakeRow("rays_per_basis", std::to_string(rays), s); !r) return std::unexpected(r.error());
  }
  // bounces
  for (int bounces : {1, 2, 3, 4}) {
    if (bounces == base_settings.transfer.bounces) {
      if (auto r = row("bounces", std::to_string(bounces), true, *base, base_rt, "the default bake"); !r) return std::unexpected(r.error());
      continue;
    }
    BakeSettings s = base_settings;
    s.transfer.bounces = bounces;
    if (auto r = bakeRow("bounces", std::to_string(bounces), s); !r) return std::unexpected(r.error());
  }

  // part: the default configuration one relighting term at a time against the reference's part,
  // as a share of the whole reference ambient (so that the rows' biases add up to the total's).
  // Shares of the whole reference ambient, floored as every row's are (kAmbientErrorFloor).
  double total = 0;
  for (const glm::vec3& m : truth.mean) total += double(m.r) + m.g + m.b;
  const double terms = 3.0 * double(truth.mean.size());
  const bool floored = total < terms * kAmbientErrorFloor;
  total = std::max(total, terms * kAmbientErrorFloor);
  struct PartError {
    double rel = 0, bias = 0, share = 0;  // |error|, signed error and the reference's term, / total
    double abs = 0;                       // mean absolute error per point, hour and channel
  };
  auto partError = [&](const InMemoryBake& bake, runtime::RuntimeOptions o, uint32_t component, size_t k) -> Result<PartError> {
    o.components = component;
    auto v = runtimeValues(bake, o, options.hours, points);
    if (!v) return std::unexpected(v.error());
    PartError e;
    for (size_t i = 0; i < v->size(); ++i)
      for (int c = 0; c < 3; ++c) {
        e.rel += std::abs(double((*v)[i][c]) - truth.parts[k][i][c]);
        e.bias += double((*v)[i][c]) - truth.parts[k][i][c];
        e.share += truth.parts[k][i][c];
      }
    e.abs = e.rel / std::max(terms, 1.0);
    e.rel /= total, e.bias /= total, e.share /= total;
    return e;
  };
  {
    const std::array<std::pair<const char*, uint32_t>, 4> parts = {
        std::pair{"sun_bounce", uint32_t(runtime::kComponentSunBounce)}, std::pair{"sky_bounce", uint32_t(runtime::kComponentSkyBounce)},
        std::pair{"direct_sky", uint32_t(runtime::kComponentDirectSky)}, std::pair{"local_lights", uint32_t(runtime::kComponentLocalLights)}};
    for (size_t k = 0; k < parts.size(); ++k) {
      if (!(base_rt.components & parts[k].second)) continue;
      progress(std::string("part=") + parts[k].first);
      auto e = partError(*base, base_rt, parts[k].second, k);
      if (!e) return std::unexpected(e.error());
      char note[160];
      std::snprintf(note, sizeof note,
                    "this term alone vs the reference's, as a share of the total ambient (the reference's term: %.1f%% of it)",
                    100.0 * e->share);
      report.rows.push_back({"part", parts[k].first, false, e->rel, e->bias, base->bake_s, *base_ms, base->bytes,
                             volumeBytes(base_rt, 12.0), flooredNote(note, floored), e->abs});
    }
  }

  // sun_window: how the runtime's band-1 window on the sun's SH trades ringing for blur.
  for (const auto& [name, w] : {std::pair{"hanning", runtime::kHanningBand1}, std::pair{"lanczos", runtime::kLanczosBand1},
                                std::pair{"none", runtime::kNoWindowBand1}}) {
    runtime::RuntimeOptions o = base_rt;
    o.sun_band1_window = w;
    if (auto r = row("sun_window", name, w == base_rt.sun_band1_window, *base, o, "band-1 factor " + fmt(w)); !r)
      return std::unexpected(r.error());
  }

  // basis: path-traced probe values at the probe the index grid names (accuracy.h).
  {
    progress("basis (path-traced probes)");
    runtime::RuntimeOptions o = base_rt;
    o.cache.max_sectors = std::max<int>(o.cache.max_sectors, int(base->sectors.size()));
    auto rt = detail::makeRuntime(base->manifest, base->sectors, options.hours.front(), o, camera, [](SectorKey) { return true; }, nullptr);
    if (!rt) return std::unexpected(rt.error());
    std::vector<glm::dvec3> probe_pos;
    std::vector<int> point_probe(points.size(), -1);
    std::vector<std::pair<int, int>> seen;  // (slot, index) -> probe_pos index
    std::vector<int> seen_id;
    for (size_t i = 0; i < points.size(); ++i) {
      const runtime::ProbeRef pr =
          (*rt)->cache().probeAt(points[i].position + glm::dvec3(points[i].normal) * double(o.normal_offset_m));
      if (!pr.valid()) continue;
      const auto it = std::find(seen.begin(), seen.end(), std::pair{pr.slot, pr.index});
      if (it != seen.end()) {
        point_probe[i] = seen_id[size_t(it - seen.begin())];
        continue;
      }
      seen.push_back({pr.slot, pr.index});
      seen_id.push_back(int(probe_pos.size()));
      point_probe[i] = int(probe_pos.size());
      probe_pos.push_back((*rt)->cache().worldPosition(pr));
    }
    // 10 normals per probe: the 4 bases, then +x -x +y -y +z -z.
    const std::array<glm::vec3, 10> normals = {sh::kBasis[0], sh::kBasis[1], sh::kBasis[2], sh::kBasis[3],
                                               glm::vec3(1, 0, 0),  glm::vec3(-1, 0, 0), glm::vec3(0, 1, 0),
                                               glm::vec3(0, -1, 0), glm::vec3(0, 0, 1),  glm::vec3(0, 0, -1)};
    ReferenceSettings ps = rs;
    ps.samples = options.probe_samples;
    std::vector<std::array<glm::vec3, 10>> probe_e;  // [h * probes + k]
    const auto t0 = Clock::now();
    for (double hour : options.hours) {
      std::vector<ReferenceQuery> q;
      for (size_t k = 0; k < probe_pos.size(); ++k)
        for (int d = 0; d < 10; ++d) q.push_back({probe_pos[k], normals[size_t(d)], uint64_t(1u << 30) + k * 10 + d});
      const auto r = referenceIrradiance(*scene, ReferenceLighting{world.sky, hour, world.lights}, q, ps, options.threads);
      for (size_t k = 0; k < probe_pos.size(); ++k) {
        std::array<glm::vec3, 10> e;
        for (int d = 0; d < 10; ++d) e[size_t(d)] = r[k * 10 + d].ambient.mean;
        probe_e.push_back(e);
      }
    }
    const double probe_ref_s = since(t0);
    Values four, cube, shl1;
    for (size_t h = 0; h < options.hours.size(); ++h)
      for (size_t i = 0; i < points.size(); ++i) {
        if (point_probe[i] < 0) {
          four.push_back(glm::vec3(0.f)), cube.push_back(glm::vec3(0.f)), shl1.push_back(glm::vec3(0.f));
          continue;
        }
        const auto& e = probe_e[h * probe_pos.size() + size_t(point_probe[i])];
        const glm::vec3 n = points[i].normal;
        const glm::vec4 w = sh::shadingWeights(n);
        four.push_back(w.x * e[0] + w.y * e[1] + w.z * e[2] + w.w * e[3]);
        // Ambient cube [2]: the squared normal components weigh the axis the normal leans to.
        cube.push_back(n.x * n.x * (n.x >= 0 ? e[4] : e[5]) + n.y * n.y * (n.y >= 0 ? e[6] : e[7]) +
                       n.z * n.z * (n.z >= 0 ? e[8] : e[9]));
        // Band-1 SH irradiance from the six axes [3].
        glm::vec3 a(0.f);
        for (int d = 4; d < 10; ++d) a += e[size_t(d)] / 6.f;
        const glm::vec3 bx = 0.5f * (e[4] - e[5]), by = 0.5f * (e[6] - e[7]), bz = 0.5f * (e[8] - e[9]);
        shl1.push_back(glm::max(a + n.x * bx + n.y * by + n.z * bz, glm::vec3(0.f)));
      }
    const std::string note = "path-traced probe values, nearest probe, no volume";
    auto add = [&](const std::string& value, bool is_default, const Values& v, double bytes_per_texel) {
      const ErrorStats e = compare(v, truth);
      report.rows.push_back({"basis", value, is_default, e.rel, e.bias, probe_ref_s, std::nan(""), base->bytes,
                             volumeBytes(base_rt, bytes_per_texel), flooredNote(note, e.floored), e.abs});
    };
    add("4-basis", true, four, 12.0);
    add("ambient-cube", false, cube, 18.0);
    add("sh-l1", false, shl1, 12.0);
  }

  // fill and texel size: runtime only.
  {
    if (auto r = row("fill", "nearest", true, *base, base_rt, "the default bake"); !r) return std::unexpected(r.error());
    runtime::RuntimeOptions o = base_rt;
    o.volume.fill = runtime::FillMode::kSmooth;
    if (auto r = row("fill", "smooth", false, *base, o, "trilinear over index-grid cells"); !r) return std::unexpected(r.error());
    for (float t : {1.f, 2.f, 4.f}) {
      runtime::RuntimeOptions ot = base_rt;
      ot.volume.texel_size_m = glm::vec3(t, t, 2.f * t);
      const bool def = ot.volume.texel_size_m == base_rt.volume.texel_size_m;
      const std::string note = "96x96x16 texels cover +-" + fmt(47.5 * t) + " m";
      if (auto r = row("texel_m", fmt(t), def, *base, ot, note); !r) return std::unexpected(r.error());
    }
  }

  // storage: emulated volume precision.
  {
    progress("storage");
    runtime::RuntimeOptions o = base_rt;
    auto real = runtimeValues(*base, o, options.hours, points);
    if (!real) return std::unexpected(real.error());
    o.volume.blur = false;
    const struct {
      const char* name;
      double levels, bytes;
    } kinds[] = {{"8-bit", 255.0, 12.0}, {"16-bit", 65535.0, 24.0}, {"float", 0.0, 48.0}};
    for (const auto& k : kinds) {
      auto v = emulatedVolumeValues(*base, o, options.hours, points, k.levels);
      if (!v) return std::unexpected(v.error());
      if (k.levels == 255.0) {
        double d = 0, s = 0;
        for (size_t i = 0; i < v->size(); ++i)
          for (int c = 0; c < 3; ++c) d += std::abs((*v)[i][c] - (*real)[i][c]), s += (*real)[i][c];
        report.emulation_check = d / std::max(s, 3.0 * double(v->size()) * kAmbientErrorFloor);
      }
      const ErrorStats e = compare(*v, truth);
      report.rows.push_back({"storage", k.name, k.levels == 255.0, e.rel, e.bias, base->bake_s, *base_ms, base->bytes,
                             volumeBytes(o, k.bytes), flooredNote("emulated: nearest fill, no blur", e.floored), e.abs});
    }
  }

  // LPRT sources, and how many of them one light is spread onto (probe_cache.h). Their rows give
  // the local-light term's error (as the part rows do): the total hides it under the sky's.
  if ((base->manifest.effects & kEffectLocalLights) && !world.lights.empty()) {
    for (int n : {1, 2, 4, 8, 16}) {
      runtime::RuntimeOptions o = base_rt;
      o.cache.sources_per_light = n;
      progress("sources_per_light=" + std::to_string(n));
      auto e = partError(*base, o, runtime::kComponentLocalLights, 3);
      if (!e) return std::unexpected(e.error());
      report.rows.push_back({"sources_per_light", std::to_string(n), n == base_rt.cache.sources_per_light, e->rel, e->bias,
                             base->bake_s, *base_ms, base->bytes, volumeBytes(o, 12.0),
                             flooredNote("local_lights term alone vs the reference's, as a share of the total ambient", floored),
                             e->abs});
    }
    for (const auto& [name, mode] : {std::pair{"visible", runtime::LightSources::kVisibleFromLight},
                                     std::pair{"nearest", runtime::LightSources::kNearest}}) {
      runtime::RuntimeOptions o = base_rt;
      o.cache.light_sources = mode;
      progress(std::string("light_sources=") + name);
      auto e = partError(*base, o, runtime::kComponentLocalLights, 3);
      if (!e) return std::unexpected(e.error());
      report.rows.push_back({"light_sources", name, mode == base_rt.cache.light_sources, e->rel, e->bias, base->bake_s, *base_ms,
                             base->bytes, volumeBytes(o, 12.0),
                             flooredNote(mode == runtime::LightSources::kNearest ? "the talk's rule: the nearest source probes"
                                                                                 : "the probes the index grid names around the light",
                                         floored),
                             e->abs});
    }
    for (size_t keep : {size_t(8), size_t(32), size_t(64), size_t(kMaxLprtSources)}) {
      const bool all = keep == size_t(kMaxLprtSources);
      const InMemoryBake truncated = all ? InMemoryBake{} : truncateLprt(*base, keep);
      const InMemoryBake& b = all ? *base : truncated;
      progress("lprt_sources=" + std::to_string(keep));
      auto e = partError(b, base_rt, runtime::kComponentLocalLights, 3);
      if (!e) return std::unexpected(e.error());
      report.rows.push_back({"lprt_sources", std::to_string(keep), all, e->rel, e->bias, b.bake_s, *base_ms, b.bytes,
                             volumeBytes(base_rt, 12.0),
                             std::string(all ? "the default bake" : "the first sources of the default bake") +
                                 "; local_lights term alone vs the reference's, as a share of the total ambient",
                             e->abs});
    }
  } else {
    report.skipped.push_back("lprt_sources: the world has no point lights (no LPRT baked)");
  }
  // technique: each registered technique (or those asked for) prepared for the block and
  // evaluated through the Technique interface (technique.h) at the same points and hours, with
  // the same comparison as every row; its costs are its own.
  for (const TechniqueInfo& info : registeredTechniques()) {
    if (!options.techniques.empty() &&
        std::find(options.techniques.begin(), options.techniques.end(), info.name) == options.techniques.end())
      continue;
    progress("technique=" + info.name);
    auto t = makeTechnique(info.name);
    if (!t) return std::unexpected(t.error());
    if (auto r = (*t)->prepare({world, where, block, options.seed, options.threads}); !r) return std::unexpected(r.error());
    auto v = techniqueValues(**t, world, options.hours, points);
    if (!v) return std::unexpected(v.error());
    std::vector<double> ms;
    for (int r = 0; r < options.timing_repeats; ++r) {
      // Alternate between two times far enough apart that the runtime relights (as relightFillMs).
      if (auto l = (*t)->setLighting(options.hours.front() + (r % 2 ? 0.0 : 3.0), world.lights); !l) return std::unexpected(l.error());
      if (auto u = (*t)->update(camera); !u) return std::unexpected(u.error());
      ms.push_back((*t)->costs().update_ms);
    }
    std::sort(ms.begin(), ms.end());
    const TechniqueCosts c = (*t)->costs();
    const ErrorStats e = compare(*v, truth);
    report.rows.push_back({"technique", info.name, info.name == "drtv", e.rel, e.bias, c.prepare_s, ms.empty() ? 0.0 : ms[ms.size() / 2],
                           c.stored_bytes, c.runtime_bytes, flooredNote(info.description, e.floored), e.abs});
  }

  report.wall_s = since(t_start);
  return report;
}

AmbientError ambientError(const std::vector<glm::vec3>& values, const std::vector<glm::vec3>& reference) {
  DRTV_CHECK_EQ(values.size(), reference.size());
  double abs_sum = 0, sum = 0, ref = 0;
  for (size_t i = 0; i < values.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      abs_sum += std::abs(double(values[i][c]) - reference[i][c]);
      sum += double(values[i][c]) - reference[i][c];
      ref += reference[i][c];
    }
  const double terms = 3.0 * double(values.size());
  AmbientError e;
  e.floored = ref < terms * kAmbientErrorFloor;
  const double denominator = std::max({ref, terms * kAmbientErrorFloor, 1e-300});
  e.rel = abs_sum / denominator;
  e.bias = sum / denominator;
  e.abs = abs_sum / std::max(terms, 1.0);
  return e;
}

}  // namespace drtv::eval
