// emissive.cpp — emissive surfaces as point lights (see emissiveLights in drtv/worlds/world.h).
//
// References:
//  [1] Pharr, Jakob, Humphreys, "Physically Based Rendering", 4th ed., sec. 4.1 (radiometry:
//      the flux of a Lambertian emitter of radiance L and area A is pi L A) and 12.1 (point
//      lights: an isotropic light of intensity I emits 4 pi I).
//  [2] Khronos, glTF 2.0 specification 2.0.1, 3.9.3 (emissive), KHR_materials_emissive_strength.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <numeric>
#include <string>
#include <vector>

#include "drtv/worlds/world.h"

namespace drtv::worlds {
namespace {

// A triangle is cut in four (midpoints) until it is below this share of its emitter's area, so
// that a quad of two triangles can still be split into kMaxLightsPerEmitter patches; at most
// kMaxSubdivision times (4^5 = 1024 pieces a triangle).
constexpr double kPieceShare = 1.0 / (4.0 * double(kMaxLightsPerEmitter));
constexpr int kMaxSubdivision = 5;
constexpr size_t kMaxLightNameBytes = 256;

// One small flat piece of an emitter, world metres.
struct Piece {
  glm::dvec3 centroid;
  glm::dvec3 normal;  // unit, front side
  double area;
};

void subdivide(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& n, double max_area,
               int depth, std::vector<Piece>& out) {
  const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
  if (area <= max_area || depth >= kMaxSubdivision) {
    out.push_back({(a + b + c) / 3.0, n, area});
    return;
  }
  const glm::dvec3 ab = 0.5 * (a + b), bc = 0.5 * (b + c), ca = 0.5 * (c + a);
  subdivide(a, ab, ca, n, max_area, depth + 1, out);
  subdivide(ab, b, bc, n, max_area, depth + 1, out);
  subdivide(ca, bc, c, n, max_area, depth + 1, out);
  subdivide(ab, bc, ca, n, max_area, depth + 1, out);
}

struct Patch {
  glm::dvec3 position;  // on the surface, before the offset
  glm::dvec3 normal;    // unit
  double area;
};

// Area-balanced bisection of pieces[lo, hi) into at most `budget` flat patches (world.h).
void split(std::vector<Piece>& pieces, size_t lo, size_t hi, size_t budget, std::vector<Patch>& out) {
  double area = 0.0;
  glm::dvec3 na(0.0), ca(0.0), bmin(1e300), bmax(-1e300);
  for (size_t i = lo; i < hi; ++i) {
    area += pieces[i].area;
    na += pieces[i].normal * pieces[i].area;
    ca += pieces[i].centroid * pieces[i].area;
    bmin = glm::min(bmin, pieces[i].centroid);
    bmax = glm::max(bmax, pieces[i].centroid);
  }
  const bool flat = glm::length(na) >= kEmitterFlatness * area;
  if (budget <= 1 || hi - lo <= 1 || (area <= kEmitterPatchAreaM2 && flat)) {
    // The piece nearest the area-weighted centroid carries the light: the centroid of a bent
    // patch may lie inside its emitter (a sphere's), a piece's plane never does.
    const glm::dvec3 c = ca / area;
    size_t best = lo;
    double best_d2 = 1e300;
    for (size_t i = lo; i < hi; ++i) {
      const glm::dvec3 d = pieces[i].centroid - c;
      if (glm::dot(d, d) < best_d2) best_d2 = glm::dot(d, d), best = i;
    }
    const Piece& p = pieces[best];
    out.push_back({c + glm::dot(p.centroid - c, p.normal) * p.normal, p.normal, area});
    return;
  }
  const glm::dvec3 ext = bmax - bmin;
  const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : ext.y >= ext.z ? 1 : 2;
  // Sorted by the axis, ties by position then original order (stable): deterministic.
  std::stable_sort(pieces.begin() + std::ptrdiff_t(lo), pieces.begin() + std::ptrdiff_t(hi),
                   [axis](const Piece& a, const Piece& b) { return a.centroid[axis] < b.centroid[axis]; });
  const size_t left_budget = budget / 2;
  const double target = area * double(left_budget) / double(budget);
  size_t mid = lo;
  double acc = 0.0;
  while (mid < hi - 1 && acc + 0.5 * pieces[mid].area < target) acc += pieces[mid++].area;
  mid = std::clamp(mid, lo + 1, hi - 1);
  split(pieces, lo, mid, left_budget, out);
  split(pieces, mid, hi, budget - left_budget, out);
}

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

}  // namespace

void emissiveLights(World& world) {
  const bool with_paths = !world.light_paths.empty();
  for (size_t m = 0; m < world.meshes.size(); ++m) {
    const Mesh& mesh = world.meshes[m];
    const glm::dvec3 le(mesh.emission);
    if (!(le.r > 0.0 || le.g > 0.0 || le.b > 0.0)) continue;
    size_t instances = 0, lights = 0, not_converted = 0, dynamic = 0;
    double area_sum = 0.0;
    glm::dvec3 intensity_sum(0.0);
    for (const Instance& inst : world.instances) {
      if (inst.mesh != m) continue;
      if (inst.cls == InstanceClass::kDynamic) {
        ++dynamic;
        continue;
      }
      // Full already: no work for an instance that cannot be converted (a file may place
      // thousands).
      if (world.materials.emissive_lights >= kMaxEmissiveLights) {
        ++not_converted;
        continue;
      }
      // World-space pieces, front side as the ray tracer stores it (a mirroring transform
      // reverses the winding, world_geometry.cpp).
      const bool mirrored = glm::determinant(glm::dmat3(inst.transform)) < 0.0;
      std::vector<std::array<glm::dvec3, 3>> tris;
      double area = 0.0;
      for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        std::array<glm::dvec3, 3> w;
        bool ok = true;
        for (int k = 0; k < 3; ++k) {
          const uint32_t i = mesh.indices[t + size_t(k)];
          if (i >= mesh.positions.size()) { ok = false; break; }
          w[size_t(k)] = glm::dvec3(inst.transform * glm::dvec4(glm::dvec3(mesh.positions[i]), 1.0));
        }
        if (!ok) continue;
        if (mirrored) std::swap(w[1], w[2]);
        const double a = 0.5 * glm::length(glm::cross(w[1] - w[0], w[2] - w[0]));
        if (!(a > 0.0) || !std::isfinite(a)) continue;
        tris.push_back(w);
        area += a;
      }
      if (!(area > 0.0)) continue;
      std::vector<Piece> pieces;
      for (const auto& w : tris) {
        const glm::dvec3 n = glm::normalize(glm::cross(w[1] - w[0], w[2] - w[0]));
        subdivide(w[0], w[1], w[2], n, area * kPieceShare, 0, pieces);
      }
      std::vector<Patch> patches;
      split(pieces, 0, pieces.size(), kMaxLightsPerEmitter, patches);
      bool fits = world.materials.emissive_lights + patches.size() <= kMaxEmissiveLights;
      for (const Patch& p : patches) {
        const glm::dvec3 i = 0.5 * le * p.area;  // I = Le A / 2 (world.h)
        fits = fits && i.r <= kMaxColourValue && i.g <= kMaxColourValue && i.b <= kMaxColourValue;
      }
      if (!fits) {
        ++not_converted;
        continue;
      }
      ++instances;
      area_sum += area;
      for (size_t k = 0; k < patches.size(); ++k) {
        PointLight l;
        // Bounded: names travel into the archive's manifest (16-bit lengths), and a file's node
        // names may be any length.
        l.name = inst.name.substr(0, kMaxLightNameBytes) + ": emissive " + std::to_string(k);
        l.position = patches[k].position + kEmitterLightOffsetM * patches[k].normal;
        l.intensity = glm::vec3(0.5 * le * patches[k].area);
        intensity_sum += glm::dvec3(l.intensity);
        world.lights.push_back(std::move(l));
        if (with_paths) world.light_paths.emplace_back();
        ++lights;
        ++world.materials.emissive_lights;
      }
    }
    world.materials.emissive_instances_not_converted += not_converted + dynamic;
    std::string line = "emissive: " + mesh.name + ": " + std::to_string(instances) + " instance" + (instances == 1 ? "" : "s") +
                       ", " + num(area_sum) + " m^2 of Le (" + num(le.r) + ", " + num(le.g) + ", " + num(le.b) + ") -> " +
                       std::to_string(lights) + " point lights of I = Le A / 2, (" + num(intensity_sum.r) + ", " +
                       num(intensity_sum.g) + ", " + num(intensity_sum.b) + ") W/sr in all (flux " +
                       num(std::numbers::pi * le.g * area_sum) + " W in green)";
    if (not_converted)
      line += "; " + std::to_string(not_converted) + " instances not converted (more than " + std::to_string(kMaxEmissiveLights) +
              " emissive lights, or an intensity above " + num(kMaxColourValue) + ")";
    if (dynamic) line += "; " + std::to_string(dynamic) + " dynamic instances not converted (dynamic objects cast no light)";
    world.notes.push_back(line);
  }
}

}  // namespace drtv::worlds
