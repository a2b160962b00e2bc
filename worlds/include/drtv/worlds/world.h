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
#include "drtv/formats/error.h"
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
  // Emitted radiance of the front faces, linear RGB, W m^-2 sr^-1 in the lighting's units
  // (>= 0, finite; 0 = no emission). Not light by itself: emissiveLights() turns it into point
  // lights, which both the bake and the path tracer see (docs/world-format.md, "Materials").
  glm::vec3 emission{0.f};
  // The source material is double-sided (glTF doubleSided): its triangles are surfaces from both
  // sides for the bake and the path tracer (raytrace::RayScene two-sided triangles); a one-sided
  // triangle's back face is the inside of geometry (docs/world-format.md, "Materials").
  bool double_sided = false;

  size_t triangleCount() const { return indices.size() / 3; }
};

// What the loaders did with each class of material, counted per material of a source file (a
// material used by several primitives counts once); World::notes says which one and how.
struct MaterialCounts {
  size_t materials = 0;          // materials read (glTF materials; the default material once)
  size_t opaque = 0;             // alphaMode OPAQUE (or none given)
  size_t mask_kept = 0;          // alphaMode MASK, baseColorFactor alpha >= alphaCutoff: opaque
  size_t mask_skipped = 0;       // alphaMode MASK, factor alpha below the cutoff: its primitives skipped
  size_t blend_kept = 0;         // alphaMode BLEND with mean alpha >= 0.5: opaque
  size_t blend_skipped = 0;      // alphaMode BLEND with mean alpha < 0.5: its primitives skipped
  size_t metallic = 0;           // metallic > 0: diffuse albedo = base colour x (1 - metallic)
  size_t emissive = 0;           // emission > 0: point lights, albedo 0
  size_t double_sided = 0;       // doubleSided: surfaces from both sides
  size_t emissive_lights = 0;    // point lights emissiveLights() made
  size_t emissive_instances_not_converted = 0;  // past kMaxEmissiveLights, or dynamic

  MaterialCounts& operator+=(const MaterialCounts& o);
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
  MaterialCounts materials;

  // A world built in code is input like a file: an error naming the first instance whose mesh
  // index is out of range, of any class. The loaders' worlds always pass; the functions below
  // and the baker's geometry (raytrace::WorldGeometry) take only worlds that pass, and the
  // geometry calls this itself.
  Result<void> validate() const;

  // World-space bounds of all instances (dynamic ones too). A world that validate() refuses is a
  // caller's bug here (DRTV_CHECK).
  Bounds bounds() const;
  // Sum over instances of their mesh's triangle count (validate() first, as for bounds()).
  size_t triangleCount() const;
  // Instances per class, indexed by InstanceClass.
  std::array<size_t, 4> instancesByClass() const;
};

// The effects a world calls for when it names none: sun and sky bounce, direct sky, distant
// occlusion always; local lights only when it has point lights; interiors only when it has
// interior volumes; volume blur when it has vegetation.
uint32_t defaultEffects(const World& world);

// Emissive surfaces as point lights (docs/world-format.md, "Materials: emission"). drtv's local
// lights are isotropic points (LPRT; the path tracer's next-event estimation), so every
// non-dynamic instance of a mesh with emission > 0 becomes point lights on its front faces:
//  - A Lambertian emitter of radiance Le and area A sends the flux Phi = pi Le A into the
//    hemisphere its front faces look at. An isotropic light of intensity I sends 2 pi I into each
//    half-space; placed kEmitterLightOffsetM in front of its emitter, whose albedo the loader
//    sets to 0, the back half lands on the emitter and is absorbed. So I = Le A / 2 carries the
//    emitter's flux exactly. What it cannot carry is the cosine: straight below a small emitter
//    it gives half the true irradiance, at 60 degrees off its normal the same, beyond more.
//  - The surface (world space, after the instance's transform, so scales change A) is cut into
//    up to kMaxLightsPerEmitter patches by area-balanced bisection of its triangles' centroids
//    along the widest axis, a patch being cut again while it exceeds kEmitterPatchAreaM2 or
//    bends (its area-weighted normals' mean shorter than kEmitterFlatness). Each patch is one
//    light of I = Le A_patch / 2 at the patch triangle nearest its area-weighted centroid,
//    moved kEmitterLightOffsetM along that triangle's normal, radius_m = PointLight's default.
//  - At most kMaxEmissiveLights in all; instances past that, and dynamic ones, are not
//    converted (a note says how many).
// Appends the lights (with an empty LightPath each when light_paths is in use), one note per
// emissive mesh ("emissive: <mesh>: 2 instances, 5.46 m^2 -> 6 point lights, 273 W/sr in all")
// and the counts in world.materials. Pure function of the world; not thread-safe on `world`.
inline constexpr size_t kMaxLightsPerEmitter = 16;
inline constexpr size_t kMaxEmissiveLights = 1024;
inline constexpr double kEmitterPatchAreaM2 = 1.0;
inline constexpr double kEmitterFlatness = 0.9;
inline constexpr double kEmitterLightOffsetM = 0.01;
void emissiveLights(World& world);

}  // namespace drtv::worlds
