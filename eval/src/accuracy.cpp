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
    for (const ProbeRecord& r : s.probes)
      if (!(r.flags & kProbeLightSource)) probes.push_back(probeWorld(s, r));  // not from inside a lamp's fitting
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
    out.push_back({p, scene.rays().facingNormal(ray, hit.prim), false});
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
  int back = 0, closed_in = 0, behind_two_sided = 0;
  for (int k = 0; k < kBuriedTestRays; ++k) {
    const uint64_t h = raytrace::hashKey(seed, uint64_t(k));
    const glm::vec3 d = raytrace::uniformSphere({raytrace::unitFloat(raytrace::mix64(h)), raytrace::unitFloat(raytrace::mix64(h ^ 1))});
    const raytrace::Ray ray{origin, 0.f, glm::dot(d, n) < 0.f ? -d : d, std::numeric_limits<float>::infinity()};
    const raytrace::Hit hit = scene.rays().intersect(ray);
    back += hit.hit() && !scene.rays().frontFace(ray, hit.prim);
    // The same direction over the whole sphere, for the double-sided test below.
    const raytrace::Ray all{origin, 0.f, d, std::numeric_limits<float>::infinity()};
    const raytrace::Hit any = scene.rays().intersect(all);
    closed_in += any.hit();
    behind_two_sided += any.hit() && scene.rays().behindTwoSided(all, any.prim);
  }
  // Inside a closed double-sided solid (the Cornell box's blocks are double-sided) no hit is a
  // back face: a point closed in on every side of the whole sphere, with more than the same
  // share of its rays behind the winding of double-sided triangles, is buried too. (The whole
  // sphere, not the hemisphere: the short block stands on the box's floor, and a point low on a
  // sphere inside it sees below mostly the coplanar floor's front, which hides the block's
  // bottom.) A room of double-sided walls wound outwards reads as buried as well; its points are
  // left out, which loses samples, not correctness.
  return back > kInsideBackfaceFraction * kBuriedTestRays ||
         (closed_in == kBuriedTestRays && behind_two_sided > kInsideBackfaceFraction * kBuriedTestRays);
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

// One row of the table: a technique with parameters (technique.h, KnobRow).
using RowSpec = KnobRow;

// Rays of the category tests (SurfaceCategory): upper-hemisphere sky and the horizontal wall search.
constexpr int kCategorySkyRays = 32, kCategoryWallRays = 8;
constexpr double kEnclosedSkyFraction = 0.3, kWallDistanceM = 2.0, kWallNormalZ = 0.5;
constexpr uint64_t kStreamCategory = 3;

// Each point's SurfaceCategory (accuracy.h), from the reference scene's static geometry.
std::vector<SurfaceCategory> categorise(const ReferenceScene& scene, const std::vector<Point>& points, uint64_t seed) {
  std::vector<SurfaceCategory> out;
  const raytrace::RayScene& rays = scene.rays();
  const raytrace::Frame up(glm::vec3(0, 0, 1));
  for (size_t i = 0; i < points.size(); ++i) {
    const Point& p = points[i];
    if (p.dynamic) {
      out.push_back(kOnDynamic);
      continue;
    }
    const glm::vec3 o = scene.toLocal(p.position) + 0.05f * p.normal;
    int open = 0;
    const uint64_t h = raytrace::hashKey(seed, kStreamCategory, i);
    const glm::vec2 shift(raytrace::unitFloat(raytrace::mix64(h)), raytrace::unitFloat(raytrace::mix64(h ^ 1)));
    for (int k = 0; k < kCategorySkyRays; ++k) {
      const glm::vec2 u = raytrace::r2Point(uint32_t(k), shift);
      const glm::vec3 d = up.toWorld(raytrace::cosineHemisphere(u));
      open += !rays.occluded(raytrace::Ray{o, 0.f, d, std::numeric_limits<float>::infinity()});
    }
    if (double(open) < kEnclosedSkyFraction * kCategorySkyRays) {
      out.push_back(kEnclosed);
      continue;
    }
    bool wall = std::abs(p.normal.z) < kWallNormalZ;
    for (int k = 0; k < kCategoryWallRays && !wall; ++k) {
      const double a = 2.0 * 3.14159265358979323846 * k / kCategoryWallRays;
      const raytrace::Ray r{o + glm::vec3(0, 0, 0.3f), 0.f, glm::vec3(float(std::cos(a)), float(std::sin(a)), 0.f), float(kWallDistanceM)};
      const raytrace::Hit h = rays.intersect(r);
      wall = h.hit() && std::abs(rays.normal(h.prim).z) < kWallNormalZ;
    }
    out.push_back(wall ? kWallOrFacade : kOpenGround);
  }
  return out;
}

// Stratified sampling (AccuracyOptions::stratify): of candidates in their order, `count`, each
// static category present an equal share; a category with fewer candidates than its share gives
// the rest to the others. Indices into `of`, ascending.
constexpr int kStratifyCandidates = 8;
std::vector<size_t> stratifiedPick(const std::vector<SurfaceCategory>& of, int count) {
  std::array<std::vector<size_t>, kSurfaceCategoryCount> buckets;
  for (size_t i = 0; i < of.size(); ++i) buckets[size_t(of[i])].push_back(i);
  std::array<size_t, kSurfaceCategoryCount> taken{};
  size_t remaining = size_t(std::max(0, count));
  while (remaining > 0) {
    std::vector<int> open;  // categories with candidates left
    for (int c = 0; c < kSurfaceCategoryCount; ++c)
      if (taken[size_t(c)] < buckets[size_t(c)].size()) open.push_back(c);
    if (open.empty()) break;
    const size_t share = std::max<size_t>(1, remaining / open.size());
    for (const int c : open) {
      const size_t n = std::min({share, buckets[size_t(c)].size() - taken[size_t(c)], remaining});
      taken[size_t(c)] += n;
      remaining -= n;
      if (remaining == 0) break;
    }
  }
  std::vector<size_t> out;
  for (int c = 0; c < kSurfaceCategoryCount; ++c) out.insert(out.end(), buckets[size_t(c)].begin(), buckets[size_t(c)].begin() + std::ptrdiff_t(taken[size_t(c)]));
  std::sort(out.begin(), out.end());
  return out;
}

// The block baked: the 3 x 3 sectors around the centre of the geometry unless asked otherwise,
// clipped to the world's sectors.
Result<raytrace::SectorRange> sweepBlock(const worlds::World& world, const std::string& where, const AccuracyOptions& options) {
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
  return block;
}

// The reference at every (hour, point), and its noise and mean into `report`.
Truth referenceTruth(const ReferenceScene& scene, const worlds::World& world, const std::vector<Point>& points,
                     const AccuracyOptions& options, AccuracyReport& report) {
  const auto t_ref = Clock::now();
  Truth truth;
  ReferenceSettings rs;
  rs.samples = options.reference_samples;
  rs.seed = options.seed;
  for (double hour : options.hours) {
    std::vector<ReferenceQuery> q;
    for (size_t i = 0; i < points.size(); ++i) q.push_back({points[i].position, points[i].normal, uint64_t(i)});
    const ReferenceLighting lighting{world.sky, hour, world.lights};
    for (const ReferenceIrradiance& r : referenceIrradiance(scene, lighting, q, rs, options.threads)) {
      truth.mean.push_back(r.ambient.mean);
      truth.std_error.push_back(r.ambient.std_error);
      for (int k = 0; k < 4; ++k) truth.parts[size_t(k)].push_back(r.parts[size_t(k)].mean);
    }
  }
  report.reference_s = since(t_ref);
  double se = 0, sum = 0;
  for (size_t i = 0; i < truth.mean.size(); ++i)
    for (int c = 0; c < 3; ++c) se += truth.std_error[i][c], sum += truth.mean[i][c];
  report.reference_noise = se / std::max(sum, 3.0 * double(truth.mean.size()) * kAmbientErrorFloor);
  for (const glm::vec3& m : truth.mean) report.reference_mean += glm::dvec3(m);
  report.reference_mean /= double(truth.mean.size());
  return truth;
}

// Evaluates rows of the table against one reference: prepares (or re-parameterises) the row's
// technique, shades the points at every hour, times its update and compares (the one comparison:
// the whole ambient, or one term as a share of the whole).
class RowEvaluator {
 public:
  RowEvaluator(const worlds::World& world, const std::string& where, raytrace::SectorRange block, const AccuracyOptions& options,
               const InMemoryBake& base, const std::vector<Point>& points, const Truth& truth,
               std::vector<SurfaceCategory> categories, AccuracyReport& report)
      : world_(world), where_(where), block_(block), options_(options), base_(base), truth_(truth),
        categories_(std::move(categories)), report_(report) {
    camera_ = points.front().position;
    for (const Point& p : points) surface_.push_back({p.position, p.normal});
    for (const glm::vec3& m : truth.mean) total_ += double(m.r) + m.g + m.b;
    terms_ = 3.0 * double(truth.mean.size());
    total_floored_ = total_ < terms_ * kAmbientErrorFloor;
    total_ = std::max(total_, terms_ * kAmbientErrorFloor);
  }

  // Appends the row to the report; returns the values it compared.
  Result<Values> evaluate(const RowSpec& spec) {
    progress(spec.knob + "=" + spec.value);
    auto t = techniqueFor(spec);
    if (!t) return std::unexpected(t.error());
    Values v;
    v.reserve(options_.hours.size() * surface_.size());
    for (double hour : options_.hours) {
      if (auto r = (*t)->setLighting(hour, world_.lights); !r) return std::unexpected(r.error());
      auto e = (*t)->evaluate(surface_);
      if (!e) return std::unexpected(e.error());
      v.insert(v.end(), e->begin(), e->end());
    }
    // Update time: a relight and full fill, alternating between two times far enough apart that
    // the lighting changes (median of timing_repeats).
    std::vector<double> ms;
    for (int r = 0; r < options_.timing_repeats; ++r) {
      if (auto l = (*t)->setLighting(options_.hours.front() + (r % 2 ? 0.0 : 3.0), world_.lights); !l) return std::unexpected(l.error());
      if (auto u = (*t)->update(camera_); !u) return std::unexpected(u.error());
      ms.push_back((*t)->costs().update_ms);
    }
    // NaN: the technique does nothing per frame (probe-reference).
    const bool timed = !ms.empty() && std::none_of(ms.begin(), ms.end(), [](double x) { return std::isnan(x); });
    if (timed) std::sort(ms.begin(), ms.end());
    const TechniqueCosts c = (*t)->costs();
    AccuracyRow row{spec.knob, spec.value, spec.is_default, 0, 0, c.prepare_s, timed ? ms[ms.size() / 2] : std::nan(""),
                    c.stored_bytes, c.runtime_bytes, spec.note, 0};
    row.by_category = spec.by_category;
    if (spec.part < 0) {
      const ErrorStats e = compare(v, truth_);
      row.rel_error = e.rel, row.bias = e.bias, row.abs_error = e.abs;
      row.note = flooredNote(row.note, e.floored);
    } else {
      // One term against the reference's same term, as a share of the whole reference ambient
      // (so that the part rows' biases add up to the total's).
      const std::vector<glm::vec3>& target = truth_.parts[size_t(spec.part)];
      double rel = 0, bias = 0, share = 0;
      for (size_t i = 0; i < v.size(); ++i)
        for (int ch = 0; ch < 3; ++ch) {
          rel += std::abs(double(v[i][ch]) - target[i][ch]);
          bias += double(v[i][ch]) - target[i][ch];
          share += target[i][ch];
        }
      row.abs_error = rel / std::max(terms_, 1.0);
      row.rel_error = rel / total_, row.bias = bias / total_;
      if (spec.knob.starts_with("part")) {
        char note[160];
        std::snprintf(note, sizeof note,
                      "this term alone vs the reference's, as a share of the total ambient (the reference's term: %.1f%% of it)",
                      100.0 * share / total_);
        row.note = note;
      }
      row.note = flooredNote(row.note, total_floored_);
    }
    row.categories = byCategory(v, spec.part < 0 ? truth_.mean : truth_.parts[size_t(spec.part)]);
    report_.rows.push_back(std::move(row));
    return v;
  }

 private:
  void progress(const std::string& line) const {
    if (options_.progress) options_.progress(line);
  }

  // The row's error restricted to each category's points: against `target` (the whole ambient or
  // one term), relative to the category's whole reference ambient (floored as every row's).
  std::array<CategoryError, kSurfaceCategoryCount> byCategory(const Values& v, const std::vector<glm::vec3>& target) const {
    std::array<CategoryError, kSurfaceCategoryCount> out{};
    std::array<double, kSurfaceCategoryCount> ref{};
    const size_t P = categories_.size();
    for (size_t i = 0; i < P; ++i) ++out[categories_[i]].points;
    for (size_t i = 0; i < v.size(); ++i) {
      const int c = categories_[i % P];
      for (int ch = 0; ch < 3; ++ch) {
        const double d = double(v[i][ch]) - target[i][ch];
        out[size_t(c)].rel += std::abs(d);
        out[size_t(c)].bias += d;
        ref[size_t(c)] += truth_.mean[i][ch];
      }
    }
    for (int c = 0; c < kSurfaceCategoryCount; ++c) {
      CategoryError& e = out[size_t(c)];
      const double terms = 3.0 * double(e.points * options_.hours.size());
      if (terms == 0) continue;
      e.floored = ref[size_t(c)] < terms * kAmbientErrorFloor;
      const double den = std::max(ref[size_t(c)], terms * kAmbientErrorFloor);
      e.abs = e.rel / terms;
      e.rel /= den;
      e.bias /= den;
    }
    return out;
  }

  // A prepared technique of the row's name that takes its parameters without preparing again, or
  // a new one, prepared (with the default bake lent). Kept: the first (the default DRTV) and the last.
  Result<Technique*> techniqueFor(const RowSpec& spec) {
    for (auto& t : prepared_) {
      const std::string d = t->describe();
      if (d.rfind(spec.technique, 0) == 0 && (d.size() == spec.technique.size() || d[spec.technique.size()] == ' '))
        if (t->setParams(spec.params)) return t.get();
    }
    auto t = makeTechnique(spec.technique, spec.params);
    if (!t) return std::unexpected(t.error());
    progress("prepare " + (*t)->describe());
    if (auto r = (*t)->prepare({world_, where_, block_, options_.seed, options_.threads, &base_}); !r) return std::unexpected(r.error());
    if (prepared_.size() > 1) prepared_.pop_back();
    prepared_.push_back(std::move(*t));
    return prepared_.back().get();
  }

  const worlds::World& world_;
  const std::string& where_;
  raytrace::SectorRange block_;
  const AccuracyOptions& options_;
  const InMemoryBake& base_;
  const Truth& truth_;
  std::vector<SurfaceCategory> categories_;  // per point
  AccuracyReport& report_;
  glm::dvec3 camera_{0.0};
  std::vector<SurfacePoint> surface_;
  double total_ = 0, terms_ = 0;
  bool total_floored_ = false;
  std::vector<std::unique_ptr<Technique>> prepared_;
};

}  // namespace

Result<void> checkKnobs(const std::vector<std::string>& names) {
  std::string with;
  const std::vector<TechniqueInfo> techniques = registeredTechniques();
  for (const TechniqueInfo& info : techniques)
    if (info.knobs) with += (with.empty() ? "" : ", ") + info.name;
  for (const std::string& name : names) {
    const auto it = std::find_if(techniques.begin(), techniques.end(), [&](const TechniqueInfo& t) { return t.name == name; });
    if (it == techniques.end()) return fail("--knobs: unknown technique '" + name + "' (with knob rows: " + with + ")");
    if (!it->knobs) return fail("--knobs: technique '" + name + "' declares no knob rows (with knob rows: " + with + ")");
  }
  return {};
}

Result<AccuracyReport> measureAccuracy(const worlds::World& world, const std::string& where, const AccuracyOptions& options) {
  const auto t_start = Clock::now();
  if (options.hours.empty()) return fail("accuracy: no hours to evaluate");
  for (double h : options.hours)
    if (!std::isfinite(h)) return fail("accuracy: hour " + fmt(h) + " is not finite");
  if (options.points < 1) return fail("accuracy: --points must be >= 1");
  if (options.reference_samples < 2 || options.probe_samples < 2) return fail("accuracy: --samples must be >= 2");
  if (auto k = checkKnobs(options.knobs); !k) return std::unexpected(k.error());
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

  auto block = sweepBlock(world, where, options);
  if (!block) return std::unexpected(block.error());
  report.sectors = *block;
  const raytrace::SectorRange region = innerRange(*block);

  const BakeSettings base_settings = BakeSettings::forQuality(Quality::kDefault, options.seed);
  progress("bake default");
  auto base = bakeInMemory(world, where, base_settings, *block, options.threads);
  if (!base) return std::unexpected(base.error());
  if (base->probes == 0) return fail(where + ": the sector block has no probes");

  auto scene = ReferenceScene::build(world, where);
  if (!scene) return std::unexpected(scene.error());
  report.notes = scene->notes();

  // Sample points.
  std::vector<Point> dyn = dynamicPoints(world, *scene, region, int(std::lround(kDynamicShare * options.points)), options.seed);
  const int static_count = options.points - int(dyn.size());
  std::vector<Point> points;
  std::vector<SurfaceCategory> categories;  // with stratify, chosen with the points
  if (options.stratify) {
    const std::vector<Point> candidates = staticPoints(*scene, *base, region, kStratifyCandidates * static_count, options.seed);
    const std::vector<SurfaceCategory> of = categorise(*scene, candidates, options.seed);
    for (const size_t i : stratifiedPick(of, static_count)) {
      points.push_back(candidates[i]);
      categories.push_back(of[i]);
    }
    for (size_t i = 0; i < dyn.size(); ++i) categories.push_back(kOnDynamic);
    report.notes.push_back("stratified: each surface category found gets an equal share of the static points (the totals weigh "
                           "the categories equally, not by area)");
  } else {
    points = staticPoints(*scene, *base, region, static_count, options.seed);
  }
  report.stratified = options.stratify;
  report.dynamic_points = dyn.size();
  points.insert(points.end(), dyn.begin(), dyn.end());
  if (points.empty()) return fail(where + ": no sample point found in sectors " + toString(SectorKey{region.x0, region.y0}) + ".." +
                                  toString(SectorKey{region.x1, region.y1}));
  report.points = points.size();

  // The reference at every (hour, point).
  progress("reference at " + std::to_string(points.size()) + " points");
  const Truth truth = referenceTruth(*scene, world, points, options, report);

  // The table: (technique, parameters) rows, each evaluated by one RowEvaluator through the
  // technique interface against the one reference above. DRTV's knobs move one at a time around
  // its defaults; then every registered technique at its own defaults.
  if (!options.stratify) categories = categorise(*scene, points, options.seed);
  for (const SurfaceCategory c : categories) ++report.category_points[size_t(c)];
  const std::vector<SurfaceCategory> point_categories = categories;
  RowEvaluator rows(world, where, *block, options, *base, points, truth, std::move(categories), report);
  Values default_values;  // the default DRTV row's, for the storage emulation check
  // DRTV's knob rows always (the table's subject: the default bake, the storage emulation check),
  // then those of the techniques asked for (AccuracyOptions::knobs), in registration order.
  const KnobContext knob_context{base_settings, base->manifest.effects, world, options.probe_samples};
  const std::vector<TechniqueInfo> techniques = registeredTechniques();
  auto rowsOf = [&](const std::string& name) {
    for (const TechniqueInfo& info : techniques)
      if (info.name == name && info.knobs) return info.knobs(knob_context);
    return std::vector<RowSpec>{};
  };
  const std::vector<RowSpec> specs = rowsOf("drtv");
  for (const RowSpec& spec : specs) {
    auto v = rows.evaluate(spec);
    if (!v) return std::unexpected(v.error());
    if (spec.knob == "rays_per_basis" && spec.is_default) {
      default_values = *v;
      for (size_t h = 0; h < options.hours.size(); ++h)
        for (size_t i = 0; i < points.size(); ++i) {
          const size_t k = h * points.size() + i;
          report.point_values.push_back({points[i].position, points[i].normal, point_categories[i], options.hours[h], truth.mean[k], (*v)[k]});
        }
    }
    if (spec.knob == "storage" && spec.value == "8-bit") {
      double d = 0, sum = 0;
      for (size_t i = 0; i < v->size(); ++i)
        for (int c = 0; c < 3; ++c) d += std::abs((*v)[i][c] - default_values[i][c]), sum += default_values[i][c];
      report.emulation_check = d / std::max(sum, 3.0 * double(v->size()) * kAmbientErrorFloor);
    }
  }
  if (!((base->manifest.effects & kEffectLocalLights) && !world.lights.empty()))
    report.skipped.push_back("lprt_sources: the world has no point lights (no LPRT baked)");

  for (const TechniqueInfo& info : techniques) {
    if (info.name == "drtv" || std::find(options.knobs.begin(), options.knobs.end(), info.name) == options.knobs.end()) continue;
    for (const RowSpec& spec : rowsOf(info.name))
      if (auto v = rows.evaluate(spec); !v) return std::unexpected(v.error());
  }

  // technique: each registered technique (or those asked for) at its own defaults.
  for (const TechniqueInfo& info : techniques) {
    if (!options.techniques.empty() &&
        std::find(options.techniques.begin(), options.techniques.end(), info.name) == options.techniques.end())
      continue;
    if (auto v = rows.evaluate({"technique", info.name, info.name == "drtv", info.name, {}, info.description, -1}); !v)
      return std::unexpected(v.error());
  }
  report.wall_s = since(t_start);
  return report;
}

const char* surfaceCategoryName(SurfaceCategory c) {
  switch (c) {
    case kOpenGround: return "open";
    case kWallOrFacade: return "wall";
    case kEnclosed: return "enclosed";
    case kOnDynamic: return "dynamic";
    case kSurfaceCategoryCount: break;
  }
  return "?";
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
