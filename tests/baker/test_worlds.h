// Small worlds built in code for the baker's tests.
#pragma once

#include <glm/gtc/matrix_transform.hpp>

#include "drtv/worlds/world.h"

namespace drtv::baker::test {

// A square of half-size `half` m at height z, facing +Z.
inline worlds::Mesh plane(double half, float z, glm::vec3 albedo, const std::string& name = "plane") {
  worlds::Mesh m;
  m.name = name;
  const float h = float(half);
  m.positions = {{-h, -h, z}, {h, -h, z}, {h, h, z}, {-h, h, z}};
  m.indices = {0, 1, 2, 0, 2, 3};
  m.albedo = albedo;
  return m;
}

// An axis-aligned box [lo, hi] with outward counter-clockwise faces.
inline worlds::Mesh box(glm::vec3 lo, glm::vec3 hi, glm::vec3 albedo, const std::string& name = "box") {
  worlds::Mesh m;
  m.name = name;
  for (int i = 0; i < 8; ++i) m.positions.push_back({(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z});
  // Quads as (a, b, c, d) counter-clockwise seen from outside.
  const uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) m.indices.insert(m.indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
  m.albedo = albedo;
  return m;
}

inline void add(worlds::World& w, worlds::Mesh mesh, worlds::InstanceClass cls, glm::dmat4 transform = glm::dmat4(1.0)) {
  w.instances.push_back({uint32_t(w.meshes.size()), transform, cls, mesh.name});
  w.meshes.push_back(std::move(mesh));
}

inline constexpr uint32_t kPrtEffects = kEffectSunBounce | kEffectSkyBounce | kEffectDirectSky | kEffectDistantOcclusion;

// A flat ground of half-size `half` m and albedo rho.
inline worlds::World planeWorld(double half, glm::vec3 rho) {
  worlds::World w;
  w.name = "plane";
  add(w, plane(half, 0.f, rho, "ground"), worlds::InstanceClass::kTerrain);
  w.effects = kPrtEffects;
  return w;
}

// A hollow house (walls 0.4 m, a door on its south side, a roof) with its room spanning
// [x0+0.4, x0+9.6] x [y0+0.4, y0+7.6] x [0, 3], on a ground of half-size `half`.
inline void addHouse(worlds::World& w, glm::vec3 c) {
  const glm::vec3 lo = c - glm::vec3(5, 4, 0), hi = c + glm::vec3(5, 4, 3);
  const glm::vec3 a(0.7f, 0.65f, 0.55f);
  add(w, box({lo.x, lo.y, lo.z}, {lo.x + 0.4f, hi.y, hi.z}, a, "west wall"), worlds::InstanceClass::kStatic);
  add(w, box({hi.x - 0.4f, lo.y, lo.z}, {hi.x, hi.y, hi.z}, a, "east wall"), worlds::InstanceClass::kStatic);
  add(w, box({lo.x + 0.4f, hi.y - 0.4f, lo.z}, {hi.x - 0.4f, hi.y, hi.z}, a, "north wall"), worlds::InstanceClass::kStatic);
  add(w, box({lo.x + 0.4f, lo.y, lo.z}, {c.x - 0.7f, lo.y + 0.4f, hi.z}, a, "south wall left"), worlds::InstanceClass::kStatic);
  add(w, box({c.x + 0.7f, lo.y, lo.z}, {hi.x - 0.4f, lo.y + 0.4f, hi.z}, a, "south wall right"), worlds::InstanceClass::kStatic);
  add(w, box({lo.x - 0.3f, lo.y - 0.3f, hi.z}, {hi.x + 0.3f, hi.y + 0.3f, hi.z + 0.3f}, {0.4f, 0.2f, 0.1f}, "roof"),
      worlds::InstanceClass::kStatic);
}

// A closed room on the ground: walls `t` thick from 0 to `h` inside the outer footprint [lo, hi]
// (west and east the whole depth, south and north between them) and a roof `roof_t` thick on
// them. Without `south` the south wall is the caller's (a window, a door).
inline void addWalledRoom(worlds::World& w, glm::vec2 lo, glm::vec2 hi, float h, float t, float roof_t, glm::vec3 a, bool south = true) {
  const auto k = worlds::InstanceClass::kStatic;
  add(w, box({lo.x, lo.y, 0}, {lo.x + t, hi.y, h}, a, "west wall"), k);
  add(w, box({hi.x - t, lo.y, 0}, {hi.x, hi.y, h}, a, "east wall"), k);
  if (south) add(w, box({lo.x + t, lo.y, 0}, {hi.x - t, lo.y + t, h}, a, "south wall"), k);
  add(w, box({lo.x + t, hi.y - t, 0}, {hi.x - t, hi.y, h}, a, "north wall"), k);
  add(w, box({lo.x, lo.y, h}, {hi.x, hi.y, h + roof_t}, a, "roof"), k);
}

// The bake tests' world: 4 sectors of ground with a house, a rock, a tree and a dynamic sphere.
inline worlds::World smallWorld() {
  worlds::World w = planeWorld(64.0, {0.3f, 0.45f, 0.2f});
  w.name = "small";
  addHouse(w, {20.f, 20.f, 0.f});
  add(w, box({-20, -20, -0.5f}, {-17, -17, 1.2f}, {0.4f, 0.4f, 0.4f}, "rock"), worlds::InstanceClass::kStatic);
  add(w, box({-30.3f, 10.f, 0.f}, {-29.7f, 10.6f, 4.5f}, {0.35f, 0.25f, 0.15f}, "trunk"), worlds::InstanceClass::kVegetation);
  add(w, box({-32.f, 8.f, 3.5f}, {-28.f, 12.6f, 7.5f}, {0.12f, 0.35f, 0.08f}, "crown"), worlds::InstanceClass::kVegetation);
  add(w, box({5, 5, 0}, {7, 7, 2}, {1, 1, 1}, "dynamic crate"), worlds::InstanceClass::kDynamic);
  return w;
}

}  // namespace drtv::baker::test
