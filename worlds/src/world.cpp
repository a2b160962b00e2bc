// world.cpp — the World's own functions (see world.h).
//
// The sky, sun path and gradients live in formats/src/lighting.cpp.
#include "drtv/worlds/world.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "drtv/formats/error.h"

namespace drtv::worlds {

const char* instanceClassName(InstanceClass c) {
  switch (c) {
    case InstanceClass::kTerrain: return "terrain";
    case InstanceClass::kStatic: return "static";
    case InstanceClass::kVegetation: return "vegetation";
    case InstanceClass::kDynamic: return "dynamic";
  }
  return "unknown";
}

namespace {
// Local-space bounding box of a mesh.
Bounds meshBounds(const Mesh& m) {
  Bounds b;
  for (const glm::vec3& p : m.positions) b.extend(glm::dvec3(p));
  return b;
}
}  // namespace

Result<void> World::validate() const {
  for (size_t i = 0; i < instances.size(); ++i) {
    const Instance& inst = instances[i];
    if (inst.mesh >= meshes.size())
      return fail("instance " + std::to_string(i) + " '" + inst.name + "': mesh index " + std::to_string(inst.mesh) +
                  " out of range (" + std::to_string(meshes.size()) + " meshes)");
  }
  return {};
}

Bounds World::bounds() const {
  std::vector<Bounds> local(meshes.size());
  for (size_t i = 0; i < meshes.size(); ++i) local[i] = meshBounds(meshes[i]);
  Bounds b;
  for (const Instance& inst : instances) {
    DRTV_CHECK_LT(inst.mesh, meshes.size());
    const Bounds& lb = local[inst.mesh];
    if (lb.empty()) continue;
    for (int c = 0; c < 8; ++c) {
      const glm::dvec3 p((c & 1) ? lb.max.x : lb.min.x, (c & 2) ? lb.max.y : lb.min.y, (c & 4) ? lb.max.z : lb.min.z);
      b.extend(glm::dvec3(inst.transform * glm::dvec4(p, 1.0)));
    }
  }
  return b;
}

size_t World::triangleCount() const {
  size_t n = 0;
  for (const Instance& inst : instances) {
    DRTV_CHECK_LT(inst.mesh, meshes.size());
    n += meshes[inst.mesh].triangleCount();
  }
  return n;
}

std::array<size_t, 4> World::instancesByClass() const {
  std::array<size_t, 4> n{};
  for (const Instance& inst : instances) ++n[static_cast<size_t>(inst.cls)];
  return n;
}

MaterialCounts& MaterialCounts::operator+=(const MaterialCounts& o) {
  materials += o.materials;
  opaque += o.opaque;
  mask_kept += o.mask_kept;
  mask_skipped += o.mask_skipped;
  blend_kept += o.blend_kept;
  blend_skipped += o.blend_skipped;
  metallic += o.metallic;
  emissive += o.emissive;
  double_sided += o.double_sided;
  emissive_lights += o.emissive_lights;
  emissive_instances_not_converted += o.emissive_instances_not_converted;
  return *this;
}

uint32_t defaultEffects(const World& world) {
  uint32_t e = kEffectSunBounce | kEffectSkyBounce | kEffectDirectSky | kEffectDistantOcclusion;
  if (!world.lights.empty()) e |= kEffectLocalLights;
  if (!world.interiors.empty()) e |= kEffectInteriors;
  if (world.instancesByClass()[static_cast<size_t>(InstanceClass::kVegetation)] > 0) e |= kEffectVolumeBlur;
  return e;
}

}  // namespace drtv::worlds
