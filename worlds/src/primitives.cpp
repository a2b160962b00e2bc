// primitives.cpp — built-in unit meshes (see primitives.h).
#include "primitives.h"

#include <cmath>
#include <numbers>

namespace drtv::worlds {

Mesh makePlane(std::string name, glm::vec3 albedo) {
  Mesh m;
  m.name = std::move(name);
  m.albedo = albedo;
  m.positions = {{-0.5f, -0.5f, 0.f}, {0.5f, -0.5f, 0.f}, {0.5f, 0.5f, 0.f}, {-0.5f, 0.5f, 0.f}};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

void appendBox(Mesh& mesh, glm::vec3 lo, glm::vec3 hi) {
  // Each face: an outward normal axis and the 4 corners counter-clockwise seen from outside.
  const glm::vec3 c[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z},
                          {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}};
  static constexpr int kFaces[6][4] = {
      {0, 3, 2, 1},  // -Z
      {4, 5, 6, 7},  // +Z
      {0, 1, 5, 4},  // -Y
      {2, 3, 7, 6},  // +Y
      {0, 4, 7, 3},  // -X
      {1, 2, 6, 5},  // +X
  };
  for (const auto& f : kFaces) {
    const auto base = static_cast<uint32_t>(mesh.positions.size());
    for (int k = 0; k < 4; ++k) mesh.positions.push_back(c[f[k]]);
    mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
}

Mesh makeBox(std::string name, glm::vec3 albedo) {
  Mesh m;
  m.name = std::move(name);
  m.albedo = albedo;
  appendBox(m, glm::vec3(-0.5f), glm::vec3(0.5f));
  return m;
}

void appendSphere(Mesh& mesh, glm::vec3 centre, glm::vec3 r, int segments, int rings) {
  const auto base = static_cast<uint32_t>(mesh.positions.size());
  // Poles are single vertices so that no zero-area triangles are produced.
  mesh.positions.push_back(centre + glm::vec3(0, 0, -r.z));
  for (int i = 1; i < rings; ++i) {
    const double theta = std::numbers::pi * i / rings;  // from the south pole
    for (int j = 0; j < segments; ++j) {
      const double phi = 2.0 * std::numbers::pi * j / segments;
      const glm::dvec3 d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), -std::cos(theta));
      mesh.positions.push_back(centre + glm::vec3(d) * r);
    }
  }
  mesh.positions.push_back(centre + glm::vec3(0, 0, r.z));
  const auto s = static_cast<uint32_t>(segments);
  auto ring = [&](int i, int j) { return base + 1 + static_cast<uint32_t>(i - 1) * s + static_cast<uint32_t>(j % segments); };
  const uint32_t top = base + 1 + static_cast<uint32_t>(rings - 1) * s;
  for (int j = 0; j < segments; ++j) mesh.indices.insert(mesh.indices.end(), {base, ring(1, j + 1), ring(1, j)});
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j)
      mesh.indices.insert(mesh.indices.end(),
                          {ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)});
  for (int j = 0; j < segments; ++j) mesh.indices.insert(mesh.indices.end(), {top, ring(rings - 1, j), ring(rings - 1, j + 1)});
}

Mesh makeSphere(std::string name, glm::vec3 albedo, int segments, int rings) {
  Mesh m;
  m.name = std::move(name);
  m.albedo = albedo;
  appendSphere(m, glm::vec3(0.f), glm::vec3(0.5f), segments, rings);
  return m;
}

}  // namespace drtv::worlds
