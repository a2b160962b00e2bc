// drtv/worlds/world.h — the scene the baker reads (DESIGN.md, "Data flow").
//
// Conventions: right-handed, Z up, metres; colours are linear RGB. Meshes are in their own local
// space; instances place them in the world with a double-precision transform so that worlds far
// from the origin keep millimetre precision. glTF's Y-up is converted on load (see gltf.h).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include <optional>

#include "drtv/formats/effects.h"
#include "drtv/formats/representation.h"
#include "drtv/formats/lighting.h"

namespace drtv::worlds {

// How an instance takes part in global illumination (talk slides 7, 15-16).
enum class InstanceClass : uint8_t {
  kTerrain,     // contributes bounce; probe placement rays hit it
  kStatic,      // contributes bounce; probe placement rays hit it
  kVegetation,  // contributes bounce; placement uses its bounding box, rays every 8 m
  kDynamic,     // receives GI, never contributes and never gets probes
};
const char* instanceClassName(InstanceClass c);  // "terrain", "static", "vegetation", "dynamic"

// An indexed triangle list in local space. Invariant once loaded: indices.size() % 3 == 0 and
// every index < positions.size(); positions are finite.
struct Mesh {
  std::string name;                  // for messages: "PalmTree.gltf: mesh 'Trunk' primitive 0"
  std::vector<glm::vec3> positions;  // metres, local space, Z up
  std::vector<uint32_t> indices;     // triangle list, counter-clockwise front faces
  glm::vec3 albedo{0.5f};            // diffuse reflectance in [0,1] per channel, linear RGB

  size_t triangleCount() const { return indices.size() / 3; }
};

// One placement of a mesh.
struct Instance {
  uint32_t mesh = 0;                   // index into World::meshes
  glm::dmat4 transform{1.0};           // local -> world, metres, Z up (column-major, glm)
  InstanceClass cls = InstanceClass::kStatic;
  std::string name;                    // for messages and reports
};

// The lighting description is shared with the archive and the runtime (formats/lighting.h).
using drtv::ColorKey;
using drtv::Gradient;
using drtv::InteriorVolume;
using drtv::PointLight;
using drtv::Sky;

struct Bounds {
  glm::dvec3 min{1e300}, max{-1e300};
  bool empty() const { return !(min.x <= max.x); }
  void extend(const glm::dvec3& p) { min = glm::min(min, p); max = glm::max(max, p); }
};

// Everything the baker reads. Value type; cheap to move. Not thread-safe to mutate while read.
struct World {
  std::string name;  // file or generator that made it, for reports
  std::vector<Mesh> meshes;
  std::vector<Instance> instances;
  Sky sky = Sky::tropicalDefault();
  std::vector<PointLight> lights;
  // How the lights move: light_paths[i] moves lights[i]; a light without an entry, or whose entry
  // has no keys, stays put.
  // The bake ignores them (LPRT's sources are probes, wherever the lights are); `drtv fly --world`
  // plays them (lightAt).
  std::vector<LightPath> light_paths;
  std::vector<InteriorVolume> interiors;
  uint32_t effects = 0;            // drtv::Effect mask in force (see defaultEffects)
  bool effects_explicit = false;   // true when the source named them, false when derived
  // The directional representation to bake in ("representation": "fc3" | "sh-l1" in a world
  // file); unset = the baker's default (TransferSettings: kShL1), unless `drtv bake --representation` says otherwise.
  std::optional<Representation> representation;
  // What the loaders skipped or repaired, one line each, for reports: "skipped: PalmTree.gltf:
  // mesh 'Leaves' primitive 1: mode 1 (lines)", "dropped: ...: 3 zero-area triangles".
  std::vector<std::string> notes;

  // World-space bounds of all instances (dynamic ones too).
  Bounds bounds() const;
  // Sum over instances of their mesh's triangle count.
  size_t triangleCount() const;
  // Instances per class, indexed by InstanceClass.
  std::array<size_t, 4> instancesByClass() const;
};

// The effects a world calls for when it names none: sun and sky bounce, direct sky, distant
// occlusion always; local lights only when it has point lights; interiors only when it has
// interior volumes; volume blur when it has vegetation.
uint32_t defaultEffects(const World& world);

}  // namespace drtv::worlds
