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

#include "drtv/formats/effects.h"

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

// A piecewise-linear gradient over the 24 h day, keyed by hour in [0,24); it wraps at midnight.
struct ColorKey {
  float hour = 0;        // [0, 24)
  glm::vec3 value{0.f};  // linear RGB, >= 0
};
struct Gradient {
  std::vector<ColorKey> keys;  // sorted by hour, at least one
  // Value at `hour` (any real; taken modulo 24), linear between keys, wrapping midnight.
  glm::vec3 at(double hour) const;
};

// Sun and sky over the day (talk slide 25: artist gradients driven by the time of day).
struct Sky {
  // Sun path: a standard solar-position model. Hour angle h = (hour - 12) * 15 deg; elevation
  // asin(sin(lat)sin(dec) + cos(lat)cos(dec)cos(h)). Azimuth 0 = +Y (north), 90 deg = +X (east);
  // `north_rad` rotates the whole path about Z.
  double latitude_rad = 0.3;      // ~17 deg N, a tropical island
  double declination_rad = 0.2;   // ~11.5 deg: a late-spring day
  double north_rad = 0.0;         // rotation of north away from +Y, counter-clockwise about Z
  Gradient sun_irradiance;        // irradiance at normal incidence (linear RGB, W/m^2-like units)
  Gradient sky_zenith;            // sky radiance straight up (per sr)
  Gradient sky_horizon;           // sky radiance at the horizon (per sr); the sky blends between
                                  // the two with elevation (see sunDirection/skyRadiance)
  float ground_radiance_scale = 0.0f;  // radiance below the horizon as a fraction of the horizon

  // Unit vector towards the sun at `hour` (Z up). Below-horizon directions are returned as they
  // are (z < 0): callers decide what a set sun means.
  glm::dvec3 sunDirection(double hour) const;
  // Sky radiance seen in unit direction `dir` at `hour`: horizon colour at z = 0 blended to the
  // zenith colour as sqrt(z) (z >= 0); below the horizon ground_radiance_scale * horizon.
  glm::vec3 skyRadiance(const glm::dvec3& dir, double hour) const;
  // The default tropical day used when a world says nothing about its sky.
  static Sky tropicalDefault();
};

// A dynamic point light (talk slides 11-12; LPRT). Positions in world metres.
struct PointLight {
  std::string name;
  glm::dvec3 position{0.0};
  glm::vec3 intensity{1.f};  // radiant intensity, linear RGB per sr (>= 0)
  float radius_m = 10.f;     // range of influence, > 0
};

// An artist volume whose inside takes ambient from one designated probe (talk slide 55).
struct InteriorVolume {
  std::string name;
  glm::dvec3 min{0.0}, max{0.0};      // world-space axis-aligned box, min < max
  glm::dvec3 probe_position{0.0};     // the designated probe, inside the box
  float blend_distance_m = 1.f;       // soft transition width at the box faces, >= 0
};

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
  std::vector<InteriorVolume> interiors;
  uint32_t effects = 0;            // drtv::Effect mask in force (see defaultEffects)
  bool effects_explicit = false;   // true when the source named them, false when derived

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
