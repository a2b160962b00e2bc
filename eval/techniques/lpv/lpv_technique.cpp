// lpv (technique.h): Crytek's cascaded light propagation volumes (drtv/lpv/lpv.h, seed 003) fed
// with reflective shadow maps that drtv renders by ray casting the world (an engine rasterises
// them on the GPU; the library takes texels from anywhere). No bake: prepare() only builds the ray
// scene; every update re-renders the RSMs of the cascades whose lighting or placement changed,
// injects, propagates.
//
// What is lit (the same parts the reference's ambient has, reference.h):
//  - sun bounce: an orthographic RSM along the sun per cascade (rsm x rsm texels over the
//    cascade's box); a texel on a front face inside the box is a VPL of flux albedo x E_sun x
//    texel area (the cosine cancels against the texel's footprint);
//  - sky bounce (sky_bounce=1): a top-down orthographic RSM per cascade; a texel is a VPL of flux
//    albedo x (the LPV's own visible-sky irradiance there) x its footprint on the surface;
//  - local lights: a cube RSM per point light (rsm_point^2 texels per face) by ray casting; a
//    texel is a VPL of flux albedo x I x its solid angle, injected into every cascade holding it;
//  - direct sky: the LPV's sky term (lpv.h), the visible sky marched through the geometry volume.
// Occlusion (occlusion=geometry, the default): the geometry volume of each cascade from the
// world's static triangles, sampled by rays along the three axes through the box (2 per cell
// side): each crossing is a surfel of area spacing^2 |n.axis| (summed over the three axes that is
// the triangle's area in expectation, with no division by a grazing cosine). occlusion=rsm takes
// the RSM texels only (what an engine without the world's triangles has); occlusion=off none.
//
// Parameters: cascades, cells, cell_m, iterations, sky_steps, lookup_offset (cells; lpv.h's
// LpvOptions::lookup_offset_cells), occlusion
// (geometry|rsm|off), rsm (sun and sky RSM side, texels), rsm_point (cube face side, texels),
// sky_bounce (0|1). The world given to prepare() must outlive the technique.
#include <algorithm>
#include <sstream>
#include <chrono>
#include <cmath>
#include <limits>
#include <thread>
#include <vector>

#include "drtv/lpv/lpv.h"
#include "drtv/reference/reference.h"
#include "techniques.h"

namespace drtv::eval {
namespace {

enum class Occlusion { kGeometry, kRsm, kOff };

struct Params {
  lpv::LpvOptions lpv;
  Occlusion occlusion = Occlusion::kGeometry;
  int rsm = 256;
  int rsm_point = 32;
  bool sky_bounce = true;
};

std::string text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// An orthonormal pair perpendicular to unit `d`.
void perpendicular(const glm::vec3& d, glm::vec3& u, glm::vec3& v) {
  u = glm::normalize(std::abs(d.z) < 0.9f ? glm::cross(d, glm::vec3(0, 0, 1)) : glm::cross(d, glm::vec3(1, 0, 0)));
  v = glm::cross(d, u);
}

class LpvTechnique final : public Technique {
 public:
  using Params = drtv::eval::Params;
  LpvTechnique(TechniqueMade made, Params p)
      : Technique(std::move(made), {.prepares_from_world = true}), params_(std::move(p)) {}

  // LpvOptions' ranges are lpv::validate's; the others' here.
  static Params read(ParamReader& r) {
    Params out;
    r.integer("cascades", out.lpv.cascades, 1, 8)
        .integer("cells", out.lpv.cells, 4, 128)
        .real("cell_m", out.lpv.cell_m, 0, 1e4, true)
        .integer("iterations", out.lpv.iterations, 0, 256)
        .integer("sky_steps", out.lpv.sky_steps, 0, 128)
        .real("lookup_offset", out.lpv.lookup_offset_cells, 0, 2)
        .flag("damping", out.lpv.damping)
        .oneOf("occlusion", out.occlusion, {{"geometry", Occlusion::kGeometry}, {"rsm", Occlusion::kRsm}, {"off", Occlusion::kOff}})
        .integer("rsm", out.rsm, 1, 4096)
        .integer("rsm_point", out.rsm_point, 1, 1024)
        .flag("sky_bounce", out.sky_bounce);
    out.lpv.occlusion = out.occlusion != Occlusion::kOff;
    if (r.ok())
      if (auto e = lpv::validate(out.lpv); !e) r.reject(e.error().message);
    return out;
  }

  static std::vector<TechniqueInfo> variants() {
    return {{"lpv", "Cascaded Light Propagation Volumes (Kaplanyan & Dachsbacher 2010): ray-cast RSMs, no bake", {}, &knobs}};
  }

  // LPV's knobs, one at a time around its defaults: each re-renders its RSMs at every camera move,
  // minutes per row on the island.
  static std::vector<KnobRow> knobs(const KnobContext&) {
    const Params d;
    std::vector<KnobRow> rows;
    auto add = [&](const char* knob, std::vector<std::string> values, const std::string& def, const std::string& note) {
      for (KnobRow& row : knobAround("lpv", std::string("lpv_") + knob, knob, values, def, note)) rows.push_back(std::move(row));
    };
    add("cells", {"16", "32", "64"}, text(d.lpv.cells), "cells per axis of each cascade");
    add("cascades", {"1", "2", "3", "4"}, text(d.lpv.cascades), "nested grids, cell 1 m x 2^c");
    add("iterations", {"4", "8", "16"}, text(d.lpv.iterations), "propagation steps");
    add("rsm", {"128", "256", "512"}, text(d.rsm), "sun and sky RSM side, texels");
    add("occlusion", {"geometry", "rsm", "off"},
        d.occlusion == Occlusion::kGeometry ? "geometry" : d.occlusion == Occlusion::kRsm ? "rsm" : "off",
        "the geometry volume's source");
    add("sky_bounce", {"0", "1"}, text(d.sky_bounce), "the top-down sky-lit RSM");
    add("lookup_offset", {"0", "0.25", "0.5", "1"}, text(d.lpv.lookup_offset_cells), "the lookup's shift along the normal, cells");
    add("damping", {"0", "1"}, text(d.lpv.damping), "self-bleeding damped by the light's direction against the normal");
    return rows;
  }

 protected:
  Result<void> onPrepare(const PrepareInput& in) override {
    auto scene = reference::ReferenceScene::build(in.world, in.where);
    if (!scene) return std::unexpected(scene.error());
    scene_ = std::make_unique<reference::ReferenceScene>(std::move(*scene));
    z_top_ = scene_->topZ();
    world_ = &in.world;
    // The propagation's threads: the same bits on any count (lpv.h).
    params_.lpv.threads = std::clamp(in.threads > 0 ? in.threads : int(std::thread::hardware_concurrency()), 1, 64);
    auto lpv = lpv::CascadedLpv::create(params_.lpv);
    if (!lpv) return std::unexpected(lpv.error());
    lpv_ = std::make_unique<lpv::CascadedLpv>(std::move(*lpv));
    placed_ = false;
    lit_ = false;
    costs_.stored_bytes = 0;  // nothing baked
    costs_.runtime_bytes = lpv_->bytes();
    return {};
  }

  Result<void> onSetParams(const TechniqueParams& params) override {
    auto p = readParams<Params>(params, &read);
    if (!p) return std::unexpected(p.error());
    p->lpv.threads = params_.lpv.threads;
    if (lpv_) {
      auto lpv = lpv::CascadedLpv::create(p->lpv);
      if (!lpv) return std::unexpected(lpv.error());
      lpv_ = std::make_unique<lpv::CascadedLpv>(std::move(*lpv));
      placed_ = false;
      costs_.runtime_bytes = lpv_->bytes();
    }
    params_ = std::move(*p);
    return {};
  }

  Result<void> onSetLighting(double hour, const std::vector<PointLight>& lights) override {
    if (auto e = validateLighting(world_->sky, lights, {}); !e) return fail(e.error().message);
    const bool same = lit_ && hour == hour_ && lights.size() == lights_.size() &&
                      std::equal(lights.begin(), lights.end(), lights_.begin(), [](const PointLight& a, const PointLight& b) {
                        return a.position == b.position && a.intensity == b.intensity;
                      });
    if (same) return {};
    hour_ = hour;
    lights_ = lights;
    lit_ = true;
    light_dirty_ = ~0u;
    sky_dirty_ = ~0u;
    return {};
  }

  Result<void> onUpdate(const glm::dvec3& camera) override {
    const uint32_t moved = lpv_->setCamera(camera);
    placed_ = true;
    light_dirty_ |= moved;
    sky_dirty_ |= moved;
    // The RSMs of every cascade to relight, then one relight() for all of them (the same bits as
    // clearLight, injectLight and propagate per cascade, with one wake-up of the workers).
    std::vector<std::vector<lpv::Surfel>> rsms;
    std::vector<int> owner;
    rsms.reserve(size_t(lpv_->cascadeCount()) * (2 + lights_.size()));
    for (int c = 0; c < lpv_->cascadeCount(); ++c) {
      const uint32_t bit = 1u << c;
      if (moved & bit) {
        lpv_->clearGeometry(c);
        if (params_.occlusion == Occlusion::kGeometry) lpv_->injectGeometry(c, geometrySurfels(c));
        if (params_.occlusion != Occlusion::kRsm) lpv_->computeOcclusion(c);
      }
      if (!((light_dirty_ | sky_dirty_) & bit)) continue;
      std::vector<lpv::Surfel> sun = sunRsm(c);
      if (params_.occlusion == Occlusion::kRsm) {
        lpv_->clearGeometry(c);
        lpv_->injectGeometry(c, sun);
        lpv_->injectGeometry(c, topDown(c, false));
        lpv_->computeOcclusion(c);
      }
      lpv_->computeSky(c, [&](const glm::vec3& w) { return world_->sky.skyRadiance(glm::dvec3(w), hour_); });
      rsms.push_back(std::move(sun));
      owner.push_back(c);
      if (params_.sky_bounce) {
        rsms.push_back(topDown(c, true));
        owner.push_back(c);
      }
      for (const PointLight& l : lights_) {
        rsms.push_back(pointRsm(c, l));
        owner.push_back(c);
      }
    }
    if (!owner.empty()) {
      std::vector<lpv::VplList> lists(rsms.size());
      for (size_t i = 0; i < rsms.size(); ++i) lists[i] = {owner[i], rsms[i]};
      lpv_->relight(lists);
    }
    light_dirty_ = sky_dirty_ = 0;
    return {};
  }

  glm::vec3 onAmbient(const glm::dvec3& position, const glm::vec3& normal) const override {
    if (!placed_) return glm::vec3(0.f);
    return lpv_->indirect(position, normal) + lpv_->sky(position, normal);
  }

  // A frame shades pixels near its camera: the camera moves only when a point leaves the middle
  // half of the finest cascade (so every point is read deep inside it), and the points are
  // visited in a spatial order so that it moves rarely.
  Result<std::vector<glm::vec3>> onEvaluate(std::span<const SurfacePoint> points) override {
    std::vector<size_t> order(points.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    const double tile = params_.lpv.cell_m * params_.lpv.cells / 2;
    auto key = [&](size_t i) {
      const glm::dvec3 q = glm::floor(points[i].position / tile);
      return std::array<double, 3>{q.x, q.y, q.z};
    };
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return key(a) < key(b); });
    std::vector<glm::vec3> out(points.size());
    const double reach = tile / 2;
    bool have = false;
    glm::dvec3 cam(0.0);
    for (size_t i : order) {
      const glm::dvec3 p = points[i].position;
      if (!have || glm::any(glm::greaterThan(glm::abs(p - cam), glm::dvec3(reach)))) {
        if (auto r = update(p); !r) return std::unexpected(r.error());
        cam = p;
        have = true;
      }
      out[i] = ambient(p, points[i].normal);
    }
    return out;
  }

 private:
  // The static geometry's crossings of axis-parallel rays through cascade c's box (the header).
  std::vector<lpv::Surfel> geometrySurfels(int c) const {
    const lpv::CascadeBox& b = lpv_->box(c);
    const int per_side = 2 * b.cells;
    const double spacing = b.cell_m / 2;
    const float area = float(spacing * spacing);
    std::vector<lpv::Surfel> out;
    const raytrace::RayScene& rays = scene_->rays();
    std::vector<raytrace::Ray> batch;
    for (int axis = 0; axis < 3; ++axis) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      glm::vec3 dir(0.f);
      dir[axis] = 1.f;
      for (int j = 0; j < per_side; ++j)
        for (int i = 0; i < per_side; ++i) {
          glm::dvec3 o = b.min;
          o[u] += (i + 0.5) * spacing;
          o[v] += (j + 0.5) * spacing;
          const float length = float(b.cell_m * b.cells);
          raytrace::Ray r;
          r.origin = scene_->toLocal(o);
          r.dir = dir;
          r.t_near = 0.f;
          r.t_far = length;
          // Every crossing along the segment, nearest first.
          for (int guard = 0; guard < 4096; ++guard) {
            const raytrace::Hit h = rays.intersect(r);
            if (!h.hit()) break;
            const glm::vec3 n = rays.normal(h.prim);
            lpv::Surfel s;
            s.position = scene_->toWorld(r.origin + h.t * dir);
            s.normal = n;
            s.area_m2 = area * std::abs(n[axis]);
            out.push_back(s);
            r.t_near = std::nextafter(h.t, std::numeric_limits<float>::infinity()) + 1e-4f;
            if (r.t_near >= r.t_far) break;
          }
        }
    }
    return out;
  }

  // The orthographic RSM along the sun over cascade c's box: VPLs of the sun's first bounce.
  std::vector<lpv::Surfel> sunRsm(int c) const {
    std::vector<lpv::Surfel> out;
    const glm::vec3 sun = glm::vec3(world_->sky.sunDirection(hour_));
    const glm::vec3 E = world_->sky.sun_irradiance.at(hour_);
    if (!(sun.z > 0.f) || glm::all(glm::equal(E, glm::vec3(0.f)))) return out;
    const lpv::CascadeBox& b = lpv_->box(c);
    const glm::dvec3 centre = b.min + glm::dvec3(0.5 * b.cell_m * b.cells);
    const double half = 0.5 * std::sqrt(3.0) * b.cell_m * b.cells;  // half the box's diagonal
    glm::vec3 u, v;
    perpendicular(sun, u, v);
    const int res = params_.rsm;
    const double texel = 2 * half / res;
    // Start above everything that could shadow the box: the world's top along the sun.
    const double back = std::min(1e5, half + std::max(0.0, (z_top_ - centre.z)) / std::max(double(sun.z), 1e-3) + 1.0);
    std::vector<raytrace::Ray> rays(size_t(res) * size_t(res));
    for (int j = 0; j < res; ++j)
      for (int i = 0; i < res; ++i) {
        const glm::dvec3 o = centre + double(back) * glm::dvec3(sun) + (-half + (i + 0.5) * texel) * glm::dvec3(u) +
                             (-half + (j + 0.5) * texel) * glm::dvec3(v);
        raytrace::Ray& r = rays[size_t(j) * size_t(res) + size_t(i)];
        r.origin = scene_->toLocal(o);
        r.dir = -sun;
        r.t_near = 0.f;
        r.t_far = float(back + half);
      }
    std::vector<raytrace::Hit> hits(rays.size());
    scene_->rays().intersect(rays, hits);
    const float pixel = float(texel * texel);
    for (size_t k = 0; k < rays.size(); ++k) {
      if (!hits[k].hit()) continue;
      const glm::vec3 n = scene_->rays().facingNormal(rays[k], hits[k].prim);
      const float cosine = glm::dot(n, sun);
      if (cosine <= 0.f) continue;  // a back face: inside geometry, unlit
      const glm::dvec3 p = scene_->toWorld(rays[k].origin + hits[k].t * rays[k].dir);
      if (!b.contains(p)) continue;
      out.push_back({p, n, scene_->albedo(hits[k].prim) * E * pixel, pixel / std::max(cosine, 0.05f)});
    }
    return out;
  }

  // The top-down RSM over cascade c's box: with `lit`, VPLs of the sky's first bounce (their
  // irradiance the LPV's visible sky, computed before); without, occluders only (occlusion=rsm).
  std::vector<lpv::Surfel> topDown(int c, bool lit) const {
    std::vector<lpv::Surfel> out;
    const lpv::CascadeBox& b = lpv_->box(c);
    const int res = params_.rsm;
    const double side = b.cell_m * b.cells;
    const double texel = side / res;
    const double top = std::max(b.max().z, z_top_ + 1.0);
    std::vector<raytrace::Ray> rays(size_t(res) * size_t(res));
    for (int j = 0; j < res; ++j)
      for (int i = 0; i < res; ++i) {
        const glm::dvec3 o(b.min.x + (i + 0.5) * texel, b.min.y + (j + 0.5) * texel, top);
        raytrace::Ray& r = rays[size_t(j) * size_t(res) + size_t(i)];
        r.origin = scene_->toLocal(o);
        r.dir = glm::vec3(0, 0, -1);
        r.t_near = 0.f;
        r.t_far = float(top - b.min.z);
      }
    std::vector<raytrace::Hit> hits(rays.size());
    scene_->rays().intersect(rays, hits);
    const float pixel = float(texel * texel);
    for (size_t k = 0; k < rays.size(); ++k) {
      if (!hits[k].hit()) continue;
      const glm::vec3 n = scene_->rays().facingNormal(rays[k], hits[k].prim);
      if (n.z < 0.05f) continue;
      const glm::dvec3 p = scene_->toWorld(rays[k].origin + hits[k].t * rays[k].dir);
      if (!b.contains(p)) continue;
      const float area = pixel / n.z;
      glm::vec3 flux(0.f);
      if (lit) flux = scene_->albedo(hits[k].prim) * lpv_->skyIn(c, p, n) * area;
      out.push_back({p, n, flux, area});
    }
    return out;
  }

  // A cube RSM around point light `l`: the VPLs of its first bounce inside cascade c.
  std::vector<lpv::Surfel> pointRsm(int c, const PointLight& l) const {
    std::vector<lpv::Surfel> out;
    if (glm::all(glm::equal(l.intensity, glm::vec3(0.f)))) return out;
    const lpv::CascadeBox& b = lpv_->box(c);
    // A light whose nearest hit could not be in the box within the box's size is skipped.
    const glm::dvec3 nearest = glm::clamp(l.position, b.min, b.max());
    if (glm::length(nearest - l.position) > 4.0 * b.cell_m * b.cells) return out;
    const int res = params_.rsm_point;
    std::vector<raytrace::Ray> rays;
    std::vector<float> solid_angle;
    rays.reserve(size_t(6) * size_t(res) * size_t(res));
    const glm::vec3 origin = scene_->toLocal(l.position);
    for (int face = 0; face < 6; ++face) {
      const int axis = face / 2;
      const float sign = face % 2 ? -1.f : 1.f;
      for (int j = 0; j < res; ++j)
        for (int i = 0; i < res; ++i) {
          const float a = -1.f + (2.f * i + 1.f) / res, bb = -1.f + (2.f * j + 1.f) / res;
          glm::vec3 d(0.f);
          d[axis] = sign;
          d[(axis + 1) % 3] = a;
          d[(axis + 2) % 3] = bb;
          const float len2 = glm::dot(d, d);
          raytrace::Ray r;
          r.origin = origin;
          r.dir = d / std::sqrt(len2);
          r.t_near = 1e-3f;
          rays.push_back(r);
          solid_angle.push_back((2.f / res) * (2.f / res) / (len2 * std::sqrt(len2)));
        }
    }
    std::vector<raytrace::Hit> hits(rays.size());
    scene_->rays().intersect(rays, hits);
    for (size_t k = 0; k < rays.size(); ++k) {
      if (!hits[k].hit()) continue;
      const glm::vec3 n = scene_->rays().facingNormal(rays[k], hits[k].prim);
      const float cosine = -glm::dot(n, rays[k].dir);
      if (cosine <= 0.f) continue;
      const glm::dvec3 p = scene_->toWorld(rays[k].origin + hits[k].t * rays[k].dir);
      if (!b.contains(p)) continue;
      const float d2 = std::max(hits[k].t * hits[k].t, reference::kMinLightDistance2);
      out.push_back({p, n, scene_->albedo(hits[k].prim) * l.intensity * solid_angle[k], solid_angle[k] * d2 / std::max(cosine, 0.05f)});
    }
    return out;
  }

  Params params_;
  const worlds::World* world_ = nullptr;
  std::unique_ptr<reference::ReferenceScene> scene_;
  std::unique_ptr<lpv::CascadedLpv> lpv_;
  double z_top_ = 0;
  double hour_ = 12;
  std::vector<PointLight> lights_;
  bool lit_ = false, placed_ = false;
  uint32_t light_dirty_ = ~0u, sky_dirty_ = ~0u;
};

}  // namespace

Result<void> registerLpvTechnique() { return registerTechnique<LpvTechnique>(); }

}  // namespace drtv::eval
