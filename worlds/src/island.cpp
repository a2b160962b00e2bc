// island.cpp — procedural island (see drtv/worlds/island.h).
//
// References:
//  [1] Musgrave, Kolb, Mace, "The synthesis and rendering of eroded fractal terrains",
//      SIGGRAPH 1989 (fBm terrain; here value noise, noise.h).
//  [2] "Deferred Radiance Transfer Volumes", GDC 2012, slides 15-16 and 55 (vegetation boxes,
//      interiors with a designated probe) — the content the generator provides for the baker.
#include "island_detail.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <unordered_set>

#include <glm/gtc/matrix_transform.hpp>

#include "noise.h"
#include "primitives.h"

namespace drtv::worlds {
namespace {

// Streams of random numbers, one per kind of object, so that changing a density does not
// reshuffle the other kinds.
enum Stream : uint64_t { kTerrainShape = 1, kTerrainDetail, kClusters, kTrees, kRocks, kBuildings, kWalls, kCoast };

constexpr double kSeaFloorM = -6.0;    // terrain depth at the square's edges
constexpr double kMinLandM = 1.0;      // objects stand only on ground at least this high
constexpr double kMaxSlope = 0.45;     // rise over run; steeper ground gets no objects
constexpr double kOccupancyCellM = 8.0;  // grid that keeps trees and rocks out of buildings

double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

glm::dmat4 placement(glm::dvec3 t, double yaw_rad, glm::dvec3 s) {
  glm::dmat4 m = glm::translate(glm::dmat4(1.0), t);
  m = glm::rotate(m, yaw_rad, glm::dvec3(0, 0, 1));
  return glm::scale(m, s);
}

struct Generator {
  const IslandOptions& o;
  World& world;
  Heightfield hf;
  double half_m = 0;
  std::unordered_set<uint64_t> occupied;  // occupancy cells covered by buildings and walls

  uint64_t cellKey(double x, double y) const {
    const auto i = static_cast<int64_t>(std::floor(x / kOccupancyCellM)), j = static_cast<int64_t>(std::floor(y / kOccupancyCellM));
    return (static_cast<uint64_t>(i) << 32) ^ static_cast<uint32_t>(j);
  }
  void occupy(double x0, double y0, double x1, double y1) {
    for (double y = std::floor(y0 / kOccupancyCellM) * kOccupancyCellM; y <= y1; y += kOccupancyCellM)
      for (double x = std::floor(x0 / kOccupancyCellM) * kOccupancyCellM; x <= x1; x += kOccupancyCellM)
        occupied.insert(cellKey(x + 0.5 * kOccupancyCellM, y + 0.5 * kOccupancyCellM));
  }
  bool isFree(double x0, double y0, double x1, double y1) const {
    for (double y = std::floor(y0 / kOccupancyCellM) * kOccupancyCellM; y <= y1; y += kOccupancyCellM)
      for (double x = std::floor(x0 / kOccupancyCellM) * kOccupancyCellM; x <= x1; x += kOccupancyCellM)
        if (occupied.count(cellKey(x + 0.5 * kOccupancyCellM, y + 0.5 * kOccupancyCellM))) return false;
    return true;
  }

  double terrainHeight(double x, double y) const {
    // Island mask: 1 inland, 0 at sea; its radius wobbles with low-frequency noise.
    const double r = std::hypot(x, y) / half_m;
    const double wobble = 0.12 * noise::fbm2(noise::hash(o.seed, kCoast), x / 300.0, y / 300.0, 3);
    const double mask = smoothstep(0.92, 0.55, r + wobble);
    const double hills = 0.5 * (1 + noise::fbm2(noise::hash(o.seed, kTerrainShape), x / 400.0, y / 400.0, 4));
    const double detail = noise::fbm2(noise::hash(o.seed, kTerrainDetail), x / 40.0, y / 40.0, 3);
    const double land = 2.0 + o.max_height_m * hills * hills + 1.5 * detail;
    return kSeaFloorM + (land - kSeaFloorM) * mask;
  }

  // True when (x, y) is dry, gentle ground; `z` gets the ground height.
  bool buildable(double x, double y, double& z) const {
    if (!hf.contains(x, y)) return false;
    z = hf.heightAt(x, y);
    if (z < kMinLandM) return false;
    const double d = 2.0;
    const double sx = (hf.heightAt(x + d, y) - hf.heightAt(x - d, y)) / (2 * d);
    const double sy = (hf.heightAt(x, y + d) - hf.heightAt(x, y - d)) / (2 * d);
    return std::hypot(sx, sy) <= kMaxSlope;
  }

  uint32_t addMesh(Mesh m) {
    world.meshes.push_back(std::move(m));
    return uint32_t(world.meshes.size() - 1);
  }
  void addInstance(uint32_t mesh, const glm::dmat4& t, InstanceClass cls, std::string name) {
    world.instances.push_back(Instance{mesh, t, cls, std::move(name)});
  }

  size_t countFor(double per_km2) const { return static_cast<size_t>(std::llround(per_km2 * o.size_km2)); }

  void run() {
    const double side_m = std::sqrt(o.size_km2) * 1000.0;
    half_m = 0.5 * side_m;
    const auto cells = static_cast<uint32_t>(std::max(2.0, std::round(side_m / o.grid_spacing_m)));
    hf.nx = hf.ny = cells + 1;
    hf.spacing_m = side_m / cells;
    hf.origin = glm::dvec2(-half_m);
    hf.heights_m.resize(size_t(hf.nx) * hf.ny);
    for (uint32_t j = 0; j < hf.ny; ++j)
      for (uint32_t i = 0; i < hf.nx; ++i)
        hf.heights_m[size_t(j) * hf.nx + i] = float(terrainHeight(hf.origin.x + i * hf.spacing_m, hf.origin.y + j * hf.spacing_m));
    const uint32_t terrain = addMesh(heightfieldMesh(hf, "island terrain", glm::vec3(0.25f, 0.42f, 0.16f)));
    addInstance(terrain, glm::translate(glm::dmat4(1.0), glm::dvec3(hf.origin, 0.0)), InstanceClass::kTerrain, "terrain");

    const uint32_t box_building = addMesh(makeBox("building (unit box)", glm::vec3(0.72f, 0.66f, 0.56f)));
    const uint32_t box_roof = addMesh(makeBox("roof (unit box)", glm::vec3(0.45f, 0.22f, 0.15f)));
    const uint32_t box_wall = addMesh(makeBox("wall (unit box)", glm::vec3(0.55f, 0.52f, 0.47f)));
    buildings(box_building, box_roof);
    walls(box_wall);

    Mesh rock = makeSphere("rock", glm::vec3(0.42f, 0.41f, 0.39f), 10, 6);
    for (size_t v = 0; v < rock.positions.size(); ++v)  // lumpy, the same for every rock
      rock.positions[v] *= float(1.0 + 0.25 * (noise::uniform01(o.seed, kRocks, 1u << 20, v) - 0.5));
    const uint32_t rock_mesh = addMesh(std::move(rock));
    rocks(rock_mesh);

    Mesh trunk = makeBox("tree trunk", glm::vec3(0.35f, 0.25f, 0.15f));
    for (auto& p : trunk.positions) p = glm::vec3(p.x * 0.5f, p.y * 0.5f, (p.z + 0.5f) * 4.5f);  // 0.5 x 0.5 x 4.5 m
    Mesh crown;
    crown.name = "tree crown";
    crown.albedo = glm::vec3(0.12f, 0.35f, 0.08f);
    appendSphere(crown, glm::vec3(0, 0, 5.5f), glm::vec3(2.6f, 2.6f, 2.0f), 8, 5);
    const uint32_t trunk_mesh = addMesh(std::move(trunk)), crown_mesh = addMesh(std::move(crown));
    trees(trunk_mesh, crown_mesh);
  }

  void buildings(uint32_t box, uint32_t roof) {
    const size_t n = countFor(o.buildings_per_km2);
    size_t placed = 0;
    for (size_t k = 0; k < n * 4 && placed < n; ++k) {  // up to 4 tries per building
      auto u = [&](uint64_t f, double lo, double hi) { return noise::uniform(o.seed, kBuildings, k, f, lo, hi); };
      const double x = u(0, -half_m, half_m), y = u(1, -half_m, half_m);
      const double w = u(2, 8, 16), d = u(3, 6, 12), h = u(4, 3.5, 7.5);
      const double yaw = std::floor(u(5, 0, 4)) * 0.5 * std::numbers::pi;  // axis-aligned footprints
      const bool hollow = noise::uniform01(o.seed, kBuildings, k, 6) < o.interior_fraction;
      const double ex = (std::fmod(yaw, std::numbers::pi) < 0.1 ? w : d) * 0.5, ey = (std::fmod(yaw, std::numbers::pi) < 0.1 ? d : w) * 0.5;
      double z = 0, z_min = 1e9;
      bool ok = true;
      for (int c = 0; c < 4 && ok; ++c) {
        double zc = 0;
        ok = buildable(x + ((c & 1) ? ex : -ex), y + ((c & 2) ? ey : -ey), zc);
        z_min = std::min(z_min, zc);
      }
      if (!ok || !buildable(x, y, z) || !isFree(x - ex - 4, y - ey - 4, x + ex + 4, y + ey + 4)) continue;
      occupy(x - ex - 2, y - ey - 2, x + ex + 2, y + ey + 2);
      const std::string name = "building " + std::to_string(placed);
      const double base = z_min - 0.5;  // the footing reaches below the lowest corner
      const double top = std::max(z, z_min) + h;
      const glm::dmat4 frame = placement(glm::dvec3(x, y, 0), yaw, glm::dvec3(1));
      auto part = [&](uint32_t mesh, glm::dvec3 lo, glm::dvec3 hi, const std::string& what) {
        addInstance(mesh, frame * glm::translate(glm::dmat4(1.0), 0.5 * (lo + hi)) * glm::scale(glm::dmat4(1.0), hi - lo),
                    InstanceClass::kStatic, name + " " + what);
      };
      const double hw = w * 0.5, hd = d * 0.5;
      if (!hollow) {
        part(box, {-hw, -hd, base}, {hw, hd, top}, "block");
        ++placed;
        continue;
      }
      constexpr double kWallM = 0.4, kDoorHalfM = 0.7, kDoorHeightM = 2.2;
      const double floor_z = std::max(z, z_min) + 0.1;
      part(box, {-hw, -hd, base}, {hw, hd, floor_z}, "floor");
      part(box, {-hw, hd - kWallM, floor_z}, {hw, hd, top}, "north wall");
      part(box, {-hw, -hd + kWallM, floor_z}, {-hw + kWallM, hd - kWallM, top}, "west wall");
      part(box, {hw - kWallM, -hd + kWallM, floor_z}, {hw, hd - kWallM, top}, "east wall");
      // South wall with a door gap in the middle: two pieces and a lintel.
      part(box, {-hw, -hd, floor_z}, {-kDoorHalfM, -hd + kWallM, top}, "south wall left");
      part(box, {kDoorHalfM, -hd, floor_z}, {hw, -hd + kWallM, top}, "south wall right");
      if (top - floor_z > kDoorHeightM + 0.2)
        part(box, {-kDoorHalfM, -hd, floor_z + kDoorHeightM}, {kDoorHalfM, -hd + kWallM, top}, "lintel");
      part(roof, {-hw - 0.3, -hd - 0.3, top}, {hw + 0.3, hd + 0.3, top + 0.3}, "roof");
      // Interior: the room's inside in world space (yaw is a multiple of 90 deg, so the
      // rotated box is still axis-aligned).
      const glm::dvec3 a = glm::dvec3(frame * glm::dvec4(-hw + kWallM, -hd + kWallM, floor_z, 1));
      const glm::dvec3 b = glm::dvec3(frame * glm::dvec4(hw - kWallM, hd - kWallM, top, 1));
      InteriorVolume iv;
      iv.name = name + " interior";
      iv.min = glm::min(a, b);
      iv.max = glm::max(a, b);
      iv.probe_position = glm::dvec3(x, y, floor_z + std::min(1.5, 0.5 * (top - floor_z)));
      iv.blend_distance_m = 0.5f;
      world.interiors.push_back(iv);
      ++placed;
    }
  }

  void walls(uint32_t box) {
    const size_t n = countFor(o.walls_per_km2);
    size_t placed = 0;
    for (size_t k = 0; k < n * 3 && placed < n; ++k) {
      auto u = [&](uint64_t f, double lo, double hi) { return noise::uniform(o.seed, kWalls, k, f, lo, hi); };
      const double x = u(0, -half_m, half_m), y = u(1, -half_m, half_m), len = u(2, 8, 30), h = u(3, 1.2, 2.5);
      const bool along_x = u(4, 0, 1) < 0.5;
      const double ex = along_x ? 0.5 * len : 0.3, ey = along_x ? 0.3 : 0.5 * len;
      double z0 = 0, z1 = 0, zc = 0;
      if (!buildable(x - ex, y - ey, z0) || !buildable(x + ex, y + ey, z1) || !buildable(x, y, zc) ||
          !isFree(x - ex, y - ey, x + ex, y + ey))
        continue;
      occupy(x - ex, y - ey, x + ex, y + ey);
      const double base = std::min({z0, z1, zc}) - 0.5, top = std::max({z0, z1, zc}) + h;
      addInstance(box, placement(glm::dvec3(x, y, 0.5 * (base + top)), 0, glm::dvec3(2 * ex, 2 * ey, top - base)),
                  InstanceClass::kStatic, "wall " + std::to_string(placed));
      ++placed;
    }
  }

  void rocks(uint32_t mesh) {
    const size_t n = countFor(o.rocks_per_km2);
    for (size_t k = 0; k < n; ++k) {
      auto u = [&](uint64_t f, double lo, double hi) { return noise::uniform(o.seed, kRocks, k, f, lo, hi); };
      const double x = u(0, -half_m, half_m), y = u(1, -half_m, half_m);
      double z = 0;
      if (!buildable(x, y, z) || !isFree(x, y, x, y)) continue;
      const double s = u(2, 0.6, 3.0);
      const glm::dvec3 scale(s * u(3, 0.8, 1.6), s * u(4, 0.8, 1.6), s * u(5, 0.5, 1.0));
      addInstance(mesh, placement(glm::dvec3(x, y, z + 0.15 * scale.z), u(6, 0, 2 * std::numbers::pi), scale),
                  InstanceClass::kStatic, "rock " + std::to_string(k));
    }
  }

  void trees(uint32_t trunk, uint32_t crown) {
    const size_t n_trees = countFor(o.trees_per_km2);
    const size_t n_clusters = std::max<size_t>(1, static_cast<size_t>(std::llround(double(n_trees) / std::max(1.0, o.trees_per_cluster))));
    const size_t per_cluster = n_trees / n_clusters;
    if (n_trees == 0) return;
    for (size_t c = 0; c < n_clusters; ++c) {
      const double cx = noise::uniform(o.seed, kClusters, c, 0, -half_m, half_m);
      const double cy = noise::uniform(o.seed, kClusters, c, 1, -half_m, half_m);
      const double radius = noise::uniform(o.seed, kClusters, c, 2, 10, 30);
      for (size_t t = 0; t < per_cluster; ++t) {
        const uint64_t id = c * 1024 + t;
        auto u = [&](uint64_t f, double lo, double hi) { return noise::uniform(o.seed, kTrees, id, f, lo, hi); };
        const double r = radius * std::sqrt(u(0, 0, 1)), a = u(1, 0, 2 * std::numbers::pi);
        const double x = cx + r * std::cos(a), y = cy + r * std::sin(a);
        double z = 0;
        if (!buildable(x, y, z) || !isFree(x, y, x, y)) continue;
        const double s = u(2, 0.7, 1.3);
        const glm::dmat4 m = placement(glm::dvec3(x, y, z - 0.2), u(3, 0, 2 * std::numbers::pi), glm::dvec3(s));
        const std::string name = "tree " + std::to_string(c) + "." + std::to_string(t);
        addInstance(trunk, m, InstanceClass::kVegetation, name + " trunk");
        addInstance(crown, m, InstanceClass::kVegetation, name + " crown");
      }
    }
  }
};

}  // namespace

Result<World> generateIslandWithHeightfield(const IslandOptions& o, Heightfield* heightfield) {
  auto bad = [](const char* key, const std::string& why) { return fail(std::string("island: key '") + key + "': " + why); };
  if (!std::isfinite(o.size_km2) || !(o.size_km2 > 0) || o.size_km2 > 256) return bad("size_km2", "must be in (0, 256]");
  if (!std::isfinite(o.grid_spacing_m) || o.grid_spacing_m < 0.5 || o.grid_spacing_m > 64)
    return bad("grid_spacing_m", "must be in [0.5, 64]");
  if (std::sqrt(o.size_km2) * 1000.0 / o.grid_spacing_m > 8192) return bad("grid_spacing_m", "too fine for this size (more than 8192 cells a side)");
  if (!std::isfinite(o.max_height_m) || o.max_height_m < 0 || o.max_height_m > 2000) return bad("max_height_m", "must be in [0, 2000]");
  const std::pair<const char*, double> densities[] = {{"trees_per_km2", o.trees_per_km2},
                                                      {"rocks_per_km2", o.rocks_per_km2},
                                                      {"buildings_per_km2", o.buildings_per_km2},
                                                      {"walls_per_km2", o.walls_per_km2}};
  for (const auto& [key, v] : densities)
    if (!std::isfinite(v) || v < 0 || v > 1e5) return bad(key, "must be in [0, 100000]");
  if (!std::isfinite(o.trees_per_cluster) || o.trees_per_cluster < 1 || o.trees_per_cluster > 1000)
    return bad("trees_per_cluster", "must be in [1, 1000]");
  if (!(o.interior_fraction >= 0 && o.interior_fraction <= 1)) return bad("interior_fraction", "must be in [0, 1]");

  World world;
  world.name = "island (" + std::to_string(o.size_km2) + " km2, seed " + std::to_string(o.seed) + ")";
  Generator g{o, world, {}, 0, {}};
  g.run();
  world.effects = defaultEffects(world);
  if (heightfield) *heightfield = std::move(g.hf);
  return world;
}

Result<World> generateIsland(const IslandOptions& options) { return generateIslandWithHeightfield(options, nullptr); }

}  // namespace drtv::worlds
