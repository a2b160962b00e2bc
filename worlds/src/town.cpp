// town.cpp — procedural town of multi-storey buildings (see drtv/worlds/town.h).
//
// Each building is laid out in its own (u, v, z) frame: u along its long axis from 0 to L, v
// across it from the street side (v = 0) to the back (v = D), z up in world metres. The frame
// maps (u, v) onto world (x, y) with two axis vectors, so the same code builds wings facing any
// of the four streets; every part is an axis-aligned box in the world (the axes are ±x, ±y)
// except the stair flights, whose winding follows the frame's handedness.
#include "town_detail.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "drtv/formats/memory_limit.h"
#include "noise.h"
#include "primitives.h"

namespace drtv::worlds {
namespace {

enum Stream : uint64_t { kTerrain = 101, kBlocks, kBuildings, kLamps };

constexpr double kFacadeM = 0.3;      // outer wall thickness
constexpr double kInnerM = 0.15;      // corridor walls and partitions
constexpr double kSlabM = 0.25;       // floor / ceiling slab
constexpr double kBayM = 4.0;         // nominal window bay
constexpr double kCorridorHalfM = 1.0;
constexpr double kArcadeM = 2.5;      // depth of an arcade behind its pillars
constexpr double kPillarM = 0.5;
constexpr double kWindowHalfM = 0.7, kSillM = 0.9, kHeadM = 2.3;
constexpr double kStreetDoorHalfM = 0.6, kDoorHalfM = 0.45, kDoorHeadM = 2.1;
constexpr double kLampBelowCeilingM = 0.4;
constexpr float kLampRadiusM = 8.f;
constexpr double kTownBytesPerTriangle = 100;  // loaded (positions, indices) and the bake's copy

// An opening in a wall: [r0, r1] along the wall's run, [z0, z1] in height (world z).
struct Opening {
  double r0, r1, z0, z1;
};

struct Frame {
  glm::dvec2 o, eu, ev;
  glm::dvec2 at(double u, double v) const { return o + u * eu + v * ev; }
  bool mirrored() const { return eu.x * ev.y - eu.y * ev.x < 0; }
};

// Appends a box given in the frame (u, v ranges, world z range) to `mesh`.
void box(Mesh& mesh, const Frame& f, double u0, double u1, double v0, double v1, double z0, double z1) {
  if (u1 - u0 < 1e-3 || v1 - v0 < 1e-3 || z1 - z0 < 1e-3) return;
  const glm::dvec2 a = f.at(u0, v0), b = f.at(u1, v1);
  appendBox(mesh, glm::vec3(glm::dvec3(glm::min(a, b), z0)), glm::vec3(glm::dvec3(glm::max(a, b), z1)));
}

// Appends a hexahedron whose corner k is c[k] with bit 0 = +u, bit 1 = +v, bit 2 = top (the
// layout of appendBox), outward-facing in a right-handed frame, flipped when `mirrored`.
void hexahedron(Mesh& mesh, const glm::vec3 (&c)[8], bool mirrored) {
  static constexpr int kFaces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {3, 2, 6, 7}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& face : kFaces) {
    const auto base = static_cast<uint32_t>(mesh.positions.size());
    for (int k = 0; k < 4; ++k) mesh.positions.push_back(c[face[k]]);
    if (mirrored)
      mesh.indices.insert(mesh.indices.end(), {base, base + 2, base + 1, base, base + 3, base + 2});
    else
      mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
}

// A wall of thickness [a0, a1] across its run, running over [r0, r1], from z0 to z1, with
// openings (not overlapping along the run). `along_u`: the run is u (a facade or corridor
// wall); otherwise v (an end wall or partition). Full-length strips below and above every
// opening, then piers between them and the pieces under and over each opening.
void wall(Mesh& mesh, const Frame& f, bool along_u, double a0, double a1, double r0, double r1, double z0, double z1,
          std::vector<Opening> openings) {
  auto piece = [&](double q0, double q1, double h0, double h1) {
    if (along_u)
      box(mesh, f, q0, q1, a0, a1, h0, h1);
    else
      box(mesh, f, a0, a1, q0, q1, h0, h1);
  };
  for (auto& o : openings) {
    o.r0 = std::max(o.r0, r0), o.r1 = std::min(o.r1, r1);
    o.z0 = std::max(o.z0, z0), o.z1 = std::min(o.z1, z1);
  }
  std::erase_if(openings, [](const Opening& o) { return o.r1 <= o.r0 || o.z1 <= o.z0; });
  if (openings.empty()) return piece(r0, r1, z0, z1);
  std::sort(openings.begin(), openings.end(), [](const Opening& a, const Opening& b) { return a.r0 < b.r0; });
  double lo = z1, hi = z0;
  for (const auto& o : openings) lo = std::min(lo, o.z0), hi = std::max(hi, o.z1);
  piece(r0, r1, z0, lo);
  piece(r0, r1, hi, z1);
  double cursor = r0;
  for (const auto& o : openings) {
    piece(cursor, o.r0, lo, hi);
    piece(o.r0, o.r1, lo, o.z0);
    piece(o.r0, o.r1, o.z1, hi);
    cursor = std::max(cursor, o.r1);
  }
  piece(cursor, r1, lo, hi);
}

struct Building {
  Frame f;
  double L = 0, D = 0;      // along u, along v
  uint32_t storeys = 2;
  double h = 3.0;           // floor to floor
  double zg = 0, zmin = 0;  // ground floor level; bottom of the plinth
  bool arcade = false;
  bool gate = false;        // a gateway through the ground floor's middle bay (street to yard)
  glm::vec3 facade{0.7f};
  uint64_t id = 0;
};

constexpr glm::vec3 kFacadeColours[] = {
    {0.75f, 0.70f, 0.60f},  // cream render
    {0.62f, 0.30f, 0.22f},  // brick
    {0.55f, 0.55f, 0.57f},  // concrete
    {0.78f, 0.66f, 0.42f},  // ochre
    {0.70f, 0.16f, 0.12f},  // red render
};

struct Generator {
  const TownOptions& o;
  World& world;
  Heightfield hf;
  size_t buildings = 0, storeys = 0, rooms = 0;

  double u01(uint64_t stream, uint64_t a, uint64_t b) const { return noise::uniform01(o.seed, stream, a, b); }

  void run() {
    hf = noiseHeightfield(o.size_m, o.grid_spacing_m, o.terrain_height_m, 250.0, noise::hash(o.seed, kTerrain));
    Mesh ground = heightfieldMesh(hf, "town ground", glm::vec3(0.36f, 0.33f, 0.29f));
    world.meshes.push_back(std::move(ground));
    world.instances.push_back(Instance{0, glm::translate(glm::dmat4(1.0), glm::dvec3(hf.origin, 0.0)), InstanceClass::kTerrain, "terrain"});

    const auto n = static_cast<int64_t>(std::floor(o.size_m / o.block_m));
    const double start = -0.5 * double(n) * o.block_m;
    for (int64_t j = 0; j < n; ++j)
      for (int64_t i = 0; i < n; ++i) block(uint64_t(j * n + i), start + double(i) * o.block_m, start + double(j) * o.block_m);
  }

  void block(uint64_t k, double bx, double by) {
    const double half_street = 0.5 * o.street_m;
    const double X0 = bx + half_street, Y0 = by + half_street, X1 = bx + o.block_m - half_street, Y1 = by + o.block_m - half_street;
    const double B = X1 - X0;
    const double r = u01(kBlocks, k, 0);
    const double h = std::round(10.0 * (o.min_storey_m + (o.max_storey_m - o.min_storey_m) * u01(kBlocks, k, 1))) / 10.0;
    const double d = std::min(10.0 + 4.0 * u01(kBlocks, k, 2), 0.5 * B - 4.0);
    const glm::vec3 colour = kFacadeColours[size_t(u01(kBlocks, k, 3) * std::size(kFacadeColours))];
    auto wing = [&](uint64_t w, glm::dvec2 origin, glm::dvec2 eu, glm::dvec2 ev, double L, bool gate) {
      Building b;
      b.f = Frame{origin, eu, ev};
      b.L = L, b.D = d, b.h = h, b.gate = gate;
      b.id = k * 8 + w;
      const double span = double(o.max_storeys - o.min_storeys + 1);
      b.storeys = o.min_storeys + std::min(o.max_storeys - o.min_storeys, uint32_t(u01(kBuildings, b.id, 0) * span));
      b.arcade = !gate && u01(kBuildings, b.id, 1) < o.arcade_fraction;
      b.facade = u01(kBuildings, b.id, 2) < 0.7 ? colour : kFacadeColours[size_t(u01(kBuildings, b.id, 3) * std::size(kFacadeColours))];
      build(b);
    };
    const double cf = o.courtyard_fraction, pf = cf + o.pair_fraction, sf = pf + o.square_fraction;
    if (r < pf && d >= 10.0 - 1e-9 && B >= 2 * d + 12) {
      wing(0, {X0, Y0}, {1, 0}, {0, 1}, B, r < cf);   // south, front at y = Y0
      wing(1, {X0, Y1}, {1, 0}, {0, -1}, B, false);  // north, front at y = Y1
      if (r < cf) {
        wing(2, {X0, Y0 + d}, {0, 1}, {1, 0}, B - 2 * d, false);   // west, front at x = X0
        wing(3, {X1, Y0 + d}, {0, 1}, {-1, 0}, B - 2 * d, false);  // east, front at x = X1
      }
    } else if (r >= sf) {
      const double L = std::max(2 * d, B * (0.5 + 0.5 * u01(kBlocks, k, 4)));
      const double cx = 0.5 * (X0 + X1), cy = 0.5 * (Y0 + Y1);
      if (u01(kBlocks, k, 5) < 0.5)
        wing(4, {cx - 0.5 * L, cy - 0.5 * d}, {1, 0}, {0, 1}, L, false);
      else
        wing(4, {cx - 0.5 * d, cy - 0.5 * L}, {0, 1}, {1, 0}, L, false);
    }
  }

  void build(Building& b) {
    // Ground under the footprint: the floor sits above its highest point, the plinth reaches
    // below its lowest.
    double zlo = 1e30, zhi = -1e30;
    for (double su : {0.0, 0.5, 1.0})
      for (double sv : {0.0, 0.5, 1.0}) {
        const glm::dvec2 p = b.f.at(su * b.L, sv * b.D);
        const double z = hf.heightAt(p.x, p.y);
        zlo = std::min(zlo, z), zhi = std::max(zhi, z);
      }
    b.zg = zhi + 0.15, b.zmin = zlo - 0.5;

    const std::string name = "building " + std::to_string(buildings);
    Mesh facade, slabs, inner;
    facade.name = name + " facade", facade.albedo = b.facade;
    slabs.name = name + " slabs", slabs.albedo = glm::vec3(0.55f, 0.54f, 0.52f);
    inner.name = name + " inner walls", inner.albedo = glm::vec3(0.80f, 0.78f, 0.74f);

    const double L = b.L, D = b.D, w = kFacadeM, vc = 0.5 * D;
    const auto nb = static_cast<int>(std::max(2.0, std::round((L - 2 * w) / kBayM)));
    const double bw = (L - 2 * w) / nb;
    auto bay0 = [&](int k) { return w + k * bw; };
    const int gate_bay = b.gate ? nb / 2 : -1;
    const int door_bay = gate_bay >= 0 ? -1 : nb / 2;
    // Rooms along the corridor: bays [first, end); bay 0 is the stairwell, a gateway bay is its own.
    std::vector<std::pair<int, int>> rooms_u;
    const int per_room = nb >= 6 ? 2 : 1;
    for (int k = 1; k < nb;) {
      int e = std::min(nb, k + per_room);
      if (gate_bay == k) e = k + 1;
      else if (gate_bay > k && gate_bay < e) e = gate_bay;
      rooms_u.push_back({k, e});
      k = e;
    }
    const double front_in = b.arcade ? kArcadeM + w : w;  // the ground floor's front rooms start here

    for (uint32_t s = 0; s < b.storeys; ++s) {
      const double zf = b.zg + s * b.h, zc = zf + b.h - kSlabM;
      const bool ground = s == 0, arcade = ground && b.arcade;
      // Floor: the plinth under the ground floor; a slab with the stairwell's hole above.
      if (ground) {
        box(slabs, b.f, 0, L, 0, D, b.zmin, zf);
      } else {
        const double z0 = zf - kSlabM;
        box(slabs, b.f, 0, L, vc - kCorridorHalfM, D, z0, zf);
        box(slabs, b.f, bay0(1), L, 0, vc - kCorridorHalfM, z0, zf);
        box(slabs, b.f, 0, w, 0, vc - kCorridorHalfM, z0, zf);
        box(slabs, b.f, w, bay0(1), 0, w, z0, zf);
      }
      // Windows in every bay; the street door and the gateway on the ground floor.
      auto facade_openings = [&](bool street) {
        std::vector<Opening> out;
        for (int k = 0; k < nb; ++k) {
          const double m = bay0(k) + 0.5 * bw;
          if (ground && k == gate_bay) out.push_back({bay0(k), bay0(k + 1), zf, zc});
          else if (ground && street && k == door_bay) out.push_back({m - kStreetDoorHalfM, m + kStreetDoorHalfM, zf, zf + kHeadM});
          else out.push_back({m - kWindowHalfM, m + kWindowHalfM, zf + kSillM, zf + kHeadM});
        }
        return out;
      };
      if (arcade) {
        for (int k = 0; k <= nb; ++k) {
          const double c = std::clamp(bay0(k), 0.5 * kPillarM, L - 0.5 * kPillarM);
          box(facade, b.f, c - 0.5 * kPillarM, c + 0.5 * kPillarM, 0, kPillarM, zf, zc);
        }
        wall(facade, b.f, true, kArcadeM, kArcadeM + w, w, L - w, zf, zc, facade_openings(true));
      } else {
        wall(facade, b.f, true, 0, w, 0, L, zf, zc, facade_openings(true));
      }
      wall(facade, b.f, true, D - w, D, 0, L, zf, zc, facade_openings(false));
      // End walls: a window in each half.
      for (const double a : {0.0, L - w}) {
        std::vector<Opening> ends;
        const double f0 = 0.5 * (front_in + vc - kCorridorHalfM), b0 = 0.5 * (vc + kCorridorHalfM + D - w);
        if (vc - kCorridorHalfM - front_in > 2.0) ends.push_back({f0 - kWindowHalfM, f0 + kWindowHalfM, zf + kSillM, zf + kHeadM});
        ends.push_back({b0 - kWindowHalfM, b0 + kWindowHalfM, zf + kSillM, zf + kHeadM});
        wall(facade, b.f, false, a, a + w, arcade ? kArcadeM : w, D - w, zf, zc, ends);
      }
      // Corridor walls with a door into every room (none on an arcade's ground floor: its rooms
      // run from the arcade to the back wall, a door in each partition).
      if (!arcade) {
        std::vector<Opening> doors;
        for (const auto& [k0, k1] : rooms_u) {
          if (ground && k0 == gate_bay) {
            doors.push_back({bay0(k0), bay0(k1), zf, zc});
            continue;
          }
          const double m = 0.5 * (bay0(k0) + bay0(k1));
          doors.push_back({m - kDoorHalfM, m + kDoorHalfM, zf, zf + kDoorHeadM});
        }
        wall(inner, b.f, true, vc - kCorridorHalfM - kInnerM, vc - kCorridorHalfM, bay0(1), L - w, zf, zc, doors);
        wall(inner, b.f, true, vc + kCorridorHalfM, vc + kCorridorHalfM + kInnerM, bay0(1), L - w, zf, zc, doors);
      }
      // Partitions at the start of every room (the first one closes the stairwell off).
      for (const auto& [k0, k1] : rooms_u) {
        const double c = bay0(k0), a0 = c - 0.5 * kInnerM, a1 = c + 0.5 * kInnerM;
        if (arcade) {
          const double m = 0.5 * (front_in + D - w);
          wall(inner, b.f, false, a0, a1, front_in, D - w, zf, zc, {{m - kDoorHalfM, m + kDoorHalfM, zf, zf + kDoorHeadM}});
        } else {
          wall(inner, b.f, false, a0, a1, front_in, vc - kCorridorHalfM - kInnerM, zf, zc, {});
          wall(inner, b.f, false, a0, a1, vc + kCorridorHalfM + kInnerM, D - w, zf, zc, {});
        }
        if (ground && (k0 == gate_bay || k0 == gate_bay + 1) && gate_bay >= 0) continue;  // the gateway has no lamp
        lamps(b, s, zc, c, bay0(k1), arcade);
      }
      // A flight up to the next floor through the hole in its slab.
      if (s + 1 < b.storeys) {
        const double u0 = w + 0.2, u1 = bay0(1) - 0.2, v0 = w + 0.1, v1 = vc - kCorridorHalfM - 0.1;
        glm::vec3 c[8];
        for (int i = 0; i < 8; ++i) {
          const double u = (i & 1) ? u1 : u0, v = (i & 2) ? v1 : v0;
          const double top = (i & 1) ? zf + b.h : zf;
          const glm::dvec2 p = b.f.at(u, v);
          c[i] = glm::vec3(glm::dvec3(p, (i & 4) ? top : top - 0.25));
        }
        hexahedron(inner, c, b.f.mirrored());
      }
      ++storeys;
    }
    box(slabs, b.f, 0, L, 0, D, b.zg + b.storeys * b.h - kSlabM, b.zg + b.storeys * b.h);  // roof

    for (Mesh* m : {&facade, &slabs, &inner}) {
      if (m->indices.empty()) continue;
      world.meshes.push_back(std::move(*m));
      world.instances.push_back(Instance{uint32_t(world.meshes.size() - 1), glm::dmat4(1.0), InstanceClass::kStatic, world.meshes.back().name});
    }
    ++buildings;
  }

  // A lamp under the ceiling of the room between u0 and u1, on each side of the corridor.
  void lamps(const Building& b, uint32_t s, double zc, double u0, double u1, bool arcade) {
    const double vc = 0.5 * b.D;
    std::vector<std::pair<double, double>> sides;
    if (arcade) sides.push_back({kArcadeM + kFacadeM, b.D - kFacadeM});
    else sides = {{kFacadeM, vc - kCorridorHalfM - kInnerM}, {vc + kCorridorHalfM + kInnerM, b.D - kFacadeM}};
    for (size_t side = 0; side < sides.size(); ++side) {
      ++rooms;
      if (u01(kLamps, b.id * 64 + s, uint64_t(u0 * 16) * 4 + side) >= o.lit_room_fraction) continue;
      const glm::dvec2 p = b.f.at(0.5 * (u0 + u1), 0.5 * (sides[side].first + sides[side].second));
      PointLight light;
      light.name = "lamp " + std::to_string(world.lights.size()) + " (building " + std::to_string(buildings) + ", storey " + std::to_string(s) + ")";
      light.position = glm::dvec3(p, zc - kLampBelowCeilingM);
      light.intensity = o.lamp_intensity * glm::vec3(1.0f, 0.85f, 0.65f);
      light.radius_m = kLampRadiusM;
      world.lights.push_back(light);
    }
  }
};

}  // namespace

Result<World> generateTownWithHeightfield(const TownOptions& o, Heightfield* heightfield) {
  auto bad = [](const char* key, const std::string& why) { return fail(std::string("town: key '") + key + "': " + why); };
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (!in(o.size_m, 64, 8192)) return bad("size_m", "must be in [64, 8192]");
  if (!in(o.block_m, 40, 400)) return bad("block_m", "must be in [40, 400]");
  if (!in(o.street_m, 4, o.block_m - 28)) return bad("street_m", "must be in [4, block_m - 28]");
  if (o.min_storeys < 1 || o.min_storeys > 16) return bad("min_storeys", "must be in [1, 16]");
  if (o.max_storeys < o.min_storeys || o.max_storeys > 16) return bad("max_storeys", "must be in [min_storeys, 16]");
  if (!in(o.min_storey_m, 2.5, 4)) return bad("min_storey_m", "must be in [2.5, 4]");
  if (!in(o.max_storey_m, o.min_storey_m, 4)) return bad("max_storey_m", "must be in [min_storey_m, 4]");
  const std::pair<const char*, double> fractions[] = {{"courtyard_fraction", o.courtyard_fraction},
                                                      {"pair_fraction", o.pair_fraction},
                                                      {"square_fraction", o.square_fraction},
                                                      {"arcade_fraction", o.arcade_fraction},
                                                      {"lit_room_fraction", o.lit_room_fraction}};
  for (const auto& [key, v] : fractions)
    if (!in(v, 0, 1)) return bad(key, "must be in [0, 1]");
  if (o.courtyard_fraction + o.pair_fraction + o.square_fraction > 1 + 1e-9)
    return bad("square_fraction", "courtyard_fraction + pair_fraction + square_fraction must be at most 1");
  if (!(std::isfinite(o.lamp_intensity) && o.lamp_intensity > 0 && o.lamp_intensity <= 1e4)) return bad("lamp_intensity", "must be in (0, 10000]");
  if (!in(o.terrain_height_m, 0, 100)) return bad("terrain_height_m", "must be in [0, 100]");
  if (!in(o.grid_spacing_m, 1, 64)) return bad("grid_spacing_m", "must be in [1, 64]");
  if (o.size_m / o.grid_spacing_m > 8192) return bad("grid_spacing_m", "too fine for this size (more than 8192 cells a side)");

  // Memory, up front: a bound on the triangles (four wings of max_storeys storeys a block, each
  // storey at most 14 boxes a bay plus 25, 12 triangles a box) at ~100 B a triangle loaded and
  // copied into the bake's geometry; the terrain as the JSON terrain counts it.
  const double blocks = std::pow(std::floor(o.size_m / o.block_m), 2.0);
  const double bays = (o.block_m - o.street_m) / kBayM;
  const double triangles = blocks * 4.0 * o.max_storeys * 12.0 * (14.0 * bays + 25.0);
  const double cells = std::round(o.size_m / o.grid_spacing_m);
  const double bytes = triangles * kTownBytesPerTriangle + (cells + 1) * (cells + 1) * 44.0;
  if (auto ok = checkMemory(uint64_t(bytes), "town: key 'size_m'", "a town of " + std::to_string(int64_t(blocks)) + " blocks of up to " +
                                                         std::to_string(o.max_storeys) + " storeys");
      !ok)
    return std::unexpected(ok.error());

  World world;
  world.name = "town (" + std::to_string(int64_t(o.size_m)) + " m, seed " + std::to_string(o.seed) + ")";
  Generator g{o, world, {}};
  g.run();
  world.notes.push_back("town: " + std::to_string(g.buildings) + " buildings, " + std::to_string(g.storeys) + " storeys, " +
                        std::to_string(g.rooms) + " rooms, " + std::to_string(world.lights.size()) + " lamps");
  world.effects = defaultEffects(world);
  if (heightfield) *heightfield = std::move(g.hf);
  return world;
}

Result<World> generateTown(const TownOptions& options) { return generateTownWithHeightfield(options, nullptr); }

}  // namespace drtv::worlds
