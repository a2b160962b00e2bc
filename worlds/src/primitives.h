// primitives.h (private) — built-in unit meshes: plane, box, sphere and the island's shapes.
//
// All are centred at the origin, unit-sized (a transform's scale gives their size), Z up, with
// counter-clockwise outward-facing triangles.
#pragma once

#include <string>

#include <glm/glm.hpp>

#include "drtv/worlds/world.h"

namespace drtv::worlds {

// 1 x 1 m square in the XY plane at z = 0, facing +Z: 4 vertices, 2 triangles.
Mesh makePlane(std::string name, glm::vec3 albedo);
// Axis-aligned cube with corners at +-0.5 m: 24 vertices (flat faces), 12 triangles.
Mesh makeBox(std::string name, glm::vec3 albedo);
// UV sphere of radius 0.5 m with `segments` (>= 3) around and `rings` (>= 2) pole to pole.
Mesh makeSphere(std::string name, glm::vec3 albedo, int segments = 16, int rings = 8);

// Appends a box spanning [lo, hi] to `mesh` (same layout as makeBox).
void appendBox(Mesh& mesh, glm::vec3 lo, glm::vec3 hi);
// Appends a UV sphere / ellipsoid with centre `c` and radii `r`.
void appendSphere(Mesh& mesh, glm::vec3 c, glm::vec3 r, int segments, int rings);

}  // namespace drtv::worlds
