// Closed rooms found at bake time (rooms.h, issue 16; talk [1] slides 55-56).
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012.
//  [2] González, "Measurement of areas on a sphere using Fibonacci and latitude-longitude
//      lattices", Mathematical Geosciences 42, 2010: the Fibonacci sphere of the enclosure test.
#include "drtv/baker/rooms.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <tuple>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/worlds/world.h"
#include "static_rays.h"

namespace drtv::baker {
namespace {

// Rays start this far past the surface they leave (float noise of hits at sector-local metres).
constexpr float kStepM = 1e-3f;
// A test ray inside a solid sees back faces; more than this share of them is a seed inside one
// (placement.cpp's inside test uses the same fraction).
constexpr double kInsideBackFraction = 0.25;
// Boxes sharing more than this share of the smaller one's volume are one room (seen from two
// sectors, or from two seeds); rooms beside each other meet at the wall's middle and share none.
constexpr double kSameRoomOverlap = 0.1;
// A face of a room's box is a wall when at most this share of the rays aimed at it pass it: the
// room's window (2.4 of 30 m^2 in tests/reference/data/room.json's south wall: 2 of 25 rays pass)
// and a door pass; a face on the Cornell box's tall block, with the box's open side around it,
// does not (9 and 11 of 25 rays pass, tests/reference/data/cornell_world.json).
constexpr double kMaxOpenFaceShare = 0.2;
// How far past a face a ray aimed at it may hit and still count it closed: float noise on the
// plane, a wall seen at a grazing angle.
constexpr float kFaceSlack = 1.02f, kFaceSlackM = 0.05f;

struct LocalBox {
  glm::dvec3 min{0.0}, max{0.0};  // the grown box (world frame)
  glm::dvec3 probe{0.0};
  double blend_m = 0.0;
};

double overlapVolume(const glm::dvec3& amin, const glm::dvec3& amax, const glm::dvec3& bmin, const glm::dvec3& bmax) {
  const glm::dvec3 lo = glm::max(amin, bmin), hi = glm::min(amax, bmax);
  if (!(hi.x > lo.x && hi.y > lo.y && hi.z > lo.z)) return 0.0;
  return (hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z);
}

double volume(const glm::dvec3& lo, const glm::dvec3& hi) { return (hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z); }

// The sector's terrain and static triangles (vegetation and dynamic ones make no room).
struct RoomScene {
  std::optional<raytrace::RayScene> scene;
  size_t triangles = 0;
};

Result<RoomScene> buildRoomScene(const raytrace::SectorGeometry& g) {
  std::vector<glm::vec3> vertices;
  std::vector<uint8_t> two_sided;
  const std::vector<uint8_t> all_two_sided = g.twoSided();
  bool any_two_sided = false;
  for (size_t t = 0; t < g.triangleCount(); ++t) {
    const auto cls = worlds::InstanceClass(g.cls[t]);
    if (cls != worlds::InstanceClass::kTerrain && cls != worlds::InstanceClass::kStatic) continue;
    vertices.insert(vertices.end(), g.vertices.begin() + std::ptrdiff_t(3 * t), g.vertices.begin() + std::ptrdiff_t(3 * t + 3));
    const uint8_t ts = all_two_sided.empty() ? 0 : all_two_sided[t];
    any_two_sided |= ts != 0;
    two_sided.push_back(ts);
  }
  if (!any_two_sided) two_sided.clear();
  RoomScene out;
  out.triangles = vertices.size() / 3;
  auto scene = raytrace::RayScene::build(vertices, two_sided);
  if (!scene) return std::unexpected(scene.error());
  out.scene.emplace(std::move(*scene));
  return out;
}

class RoomFinder {
 public:
  RoomFinder(const raytrace::RayScene& scene, const raytrace::SectorGeometry& g, const RoomSettings& s)
      : scene_(scene), g_(g), s_(s) {
    // The Fibonacci sphere [2]: evenly spread, the same directions for every seed.
    for (int i = 0; i < s.test_rays; ++i) dirs_.push_back(detail::fibonacciDirection(i, s.test_rays));
  }

  // Covered-air seeds of the column at (x, y), top down.
  std::vector<glm::vec3> seeds(float x, float y) {
    std::vector<glm::vec3> out;
    const float top = g_.z_max + 1.f, bottom = g_.z_min - 1.f;
    raytrace::Ray ray{{x, y, top}, 0.f, {0.f, 0.f, -1.f}, top - bottom};
    float ceiling = NAN;  // height of the surface over the current gap, when it is a ceiling
    bool first = true;
    for (int guard = 0; guard < 4096; ++guard) {
      const raytrace::Hit h = scene_.intersect(ray);
      ++rays_;
      if (!h.hit()) break;
      const float z = top - h.t;
      const bool two_sided = scene_.twoSided(h.prim);
      const bool from_below = !two_sided && scene_.normal(h.prim).z < 0.f;  // leaving a solid downwards
      const bool floor = two_sided || scene_.normal(h.prim).z > 0.f;
      if (!first && std::isfinite(ceiling) && floor && ceiling - z >= float(s_.min_height_m))
        out.push_back({x, y, z + std::min(float(s_.seed_height_m), 0.5f * (ceiling - z))});
      ceiling = (two_sided || from_below) ? z : NAN;
      first = false;
      ray.t_near = h.t + kStepM;
    }
    return out;
  }

  // At most max_open_fraction of the test rays escape, at most a quarter hit a back face.
  bool enclosed(const glm::vec3& p) {
    const size_t n = dirs_.size();
    const size_t max_open = size_t(std::floor(s_.max_open_fraction * double(n)));
    const size_t max_back = size_t(std::floor(kInsideBackFraction * double(n)));
    size_t open = 0, back = 0;
    for (const glm::vec3& d : dirs_) {
      const raytrace::Ray ray{p, 0.f, d, float(s_.max_extent_m)};
      const raytrace::Hit h = scene_.intersect(ray);
      ++rays_;
      if (!h.hit()) {
        if (++open > max_open) return false;
      } else if (!scene_.frontFace(ray, h.prim) || scene_.behindTwoSided(ray, h.prim)) {
        // Inside a solid: behind one-sided faces, or behind a double-sided solid's winding (the
        // Cornell box's blocks; placement's inside test counts the first kind only, docs/accuracy.md).
        if (++back > max_back) return false;
      }
    }
    return true;
  }

  // The wall along axis direction a (0..5: +x, -x, +y, -y, +z, -z) from p: 3 x 3 parallel rays,
  // offset by up to `spread` along the two other axes, whose median hit is the wall (a ray
  // through a window or a door escapes, one beside a pillar hits it: the median is the wall
  // behind). The wall's thickness is where that ray leaves it (capped at 2 wall_margin_m).
  // nullopt when most of the rays escape or meet a back face.
  struct Wall {
    float distance_m, thickness_m;
  };
  std::optional<Wall> wall(const glm::vec3& p, int a, const glm::vec3& spread) {
    const int axis = a / 2, u = (axis + 1) % 3, v = (axis + 2) % 3;
    glm::vec3 d(0.f);
    d[axis] = (a % 2) ? -1.f : 1.f;
    std::array<std::pair<float, glm::vec3>, 9> hits;
    for (int k = 0; k < 9; ++k) {
      glm::vec3 o = p;
      o[u] += float(k % 3 - 1) * spread[u];
      o[v] += float(k / 3 - 1) * spread[v];
      const raytrace::Ray ray{o, 0.f, d, float(s_.max_extent_m)};
      const raytrace::Hit h = scene_.intersect(ray);
      ++rays_;
      hits[size_t(k)] = {h.hit() && scene_.frontFace(ray, h.prim) ? h.t : INFINITY, o};
    }
    // Ordered by distance, ties (misses) by origin: a strict weak order, the same on every run.
    std::sort(hits.begin(), hits.end(), [](const auto& x, const auto& y) {
      return std::tie(x.first, x.second.x, x.second.y, x.second.z) < std::tie(y.first, y.second.x, y.second.y, y.second.z);
    });
    const auto [t, o] = hits[4];
    if (!std::isfinite(t)) return std::nullopt;
    const float cap = 2.f * float(s_.wall_margin_m);
    const raytrace::Ray through{o, t + kStepM, d, t + cap};
    const raytrace::Hit exit = scene_.intersect(through);
    ++rays_;
    return Wall{t, exit.hit() ? exit.t - t : cap};
  }

  // Whether the box's face a (as wall()) is a wall: rays from the centre to a 5 x 5 grid over it
  // end at it (or before it: furniture), all but kMaxOpenFaceShare of them. A face the axis rays
  // found on a block standing in a larger space lets the rays beside the block through.
  bool faceClosed(const glm::vec3& centre, const glm::vec3& lo, const glm::vec3& hi, int a) {
    constexpr int kGrid = 5;
    const int axis = a / 2, u = (axis + 1) % 3, v = (axis + 2) % 3;
    int open = 0;
    for (int j = 0; j < kGrid; ++j)
      for (int i = 0; i < kGrid; ++i) {
        glm::vec3 target;
        target[axis] = (a % 2) ? lo[axis] : hi[axis];
        target[u] = lo[u] + (hi[u] - lo[u]) * (float(i) + 0.5f) / float(kGrid);
        target[v] = lo[v] + (hi[v] - lo[v]) * (float(j) + 0.5f) / float(kGrid);
        const glm::vec3 to = target - centre;
        const float d = glm::length(to);
        const raytrace::Ray ray{centre, 0.f, to / d, d * kFaceSlack + kFaceSlackM};
        ++rays_;
        if (!scene_.occluded(ray)) ++open;
      }
    return double(open) <= kMaxOpenFaceShare * kGrid * kGrid;
  }

  // The room around seed p, in the local frame, or nullopt.
  std::optional<LocalBox> room(const glm::vec3& p) {
    std::array<Wall, 6> w{};
    glm::vec3 centre = p;
    glm::vec3 spread(0.25f);  // first from the seed: close rays; then a quarter of the room's width
    for (int pass = 0; pass < 2; ++pass) {
      for (int a = 0; a < 6; ++a) {
        const auto found = wall(centre, a, spread);
        if (!found) return std::nullopt;
        w[size_t(a)] = *found;
      }
      if (pass == 0)
        for (int k = 0; k < 3; ++k) {
          centre[k] += 0.5f * (w[size_t(2 * k)].distance_m - w[size_t(2 * k + 1)].distance_m);
          spread[k] = 0.25f * (w[size_t(2 * k)].distance_m + w[size_t(2 * k + 1)].distance_m);
        }
    }
    const glm::vec3 lo(centre.x - w[1].distance_m, centre.y - w[3].distance_m, centre.z - w[5].distance_m);
    const glm::vec3 hi(centre.x + w[0].distance_m, centre.y + w[2].distance_m, centre.z + w[4].distance_m);
    if (hi.x - lo.x < s_.min_width_m || hi.y - lo.y < s_.min_width_m || hi.z - lo.z < s_.min_height_m) return std::nullopt;
    if (!enclosed(centre)) return std::nullopt;
    for (int a = 0; a < 6; ++a)
      if (!faceClosed(centre, lo, hi, a)) return std::nullopt;
    LocalBox b;
    double blend = s_.wall_margin_m;
    glm::dvec3 grow_lo(0.0), grow_hi(0.0);
    for (int k = 0; k < 3; ++k) {
      grow_hi[k] = std::min(s_.wall_margin_m, 0.5 * double(w[size_t(2 * k)].thickness_m));
      grow_lo[k] = std::min(s_.wall_margin_m, 0.5 * double(w[size_t(2 * k + 1)].thickness_m));
      blend = std::min({blend, grow_hi[k], grow_lo[k]});
    }
    b.min = glm::dvec3(lo) - grow_lo;
    b.max = glm::dvec3(hi) + grow_hi;
    b.probe = glm::dvec3(centre);
    b.blend_m = std::max(blend, 1e-3);
    return b;
  }

  size_t rays() const { return rays_; }

 private:
  const raytrace::RayScene& scene_;
  const raytrace::SectorGeometry& g_;
  const RoomSettings& s_;
  std::vector<glm::vec3> dirs_;
  size_t rays_ = 0;
};

struct SectorRooms {
  std::vector<LocalBox> boxes;  // world frame
  RoomStats stats;
  std::optional<Error> error;
};

SectorRooms sectorRooms(const raytrace::WorldGeometry& geometry, SectorKey key, const RoomSettings& s) {
  SectorRooms out;
  const raytrace::SectorGeometry g = geometry.gather(key, s.max_extent_m);
  if (g.triangleCount() == 0) return out;
  auto built = buildRoomScene(g);
  if (!built) {
    out.error = built.error().context("sector " + toString(key));
    return out;
  }
  if (built->triangles == 0) return out;
  RoomFinder finder(*built->scene, g, s);
  const glm::dvec3 origin(key.ix * kSectorSizeM, key.iy * kSectorSizeM, 0.0);
  std::vector<LocalBox> local;  // local frame, for the seeds' skip test
  const int columns = std::max(1, int(std::floor(kSectorSizeM / s.seed_spacing_m)));
  for (int j = 0; j < columns; ++j)
    for (int i = 0; i < columns; ++i) {
      const float x = float((i + 0.5) * s.seed_spacing_m), y = float((j + 0.5) * s.seed_spacing_m);
      for (const glm::vec3& seed : finder.seeds(x, y)) {
        const glm::dvec3 p(seed);
        if (std::any_of(local.begin(), local.end(), [&](const LocalBox& b) {
              return glm::all(glm::greaterThanEqual(p, b.min)) && glm::all(glm::lessThanEqual(p, b.max));
            }))
          continue;
        ++out.stats.seeds;
        if (!finder.enclosed(seed)) continue;
        ++out.stats.enclosed;
        const auto b = finder.room(seed);
        if (!b) continue;
        local.push_back(*b);
        LocalBox world = *b;
        world.min += origin;
        world.max += origin;
        world.probe += origin;
        out.boxes.push_back(world);
      }
    }
  out.stats.rays = finder.rays();
  return out;
}

}  // namespace

Result<void> validateRoomSettings(const RoomSettings& s) {
  auto in = [](double v, double lo, double hi) { return v >= lo && v <= hi; };
  if (!in(s.seed_spacing_m, 0.25, 64.0)) return fail("rooms: seed_spacing_m must be in [0.25, 64] m");
  if (!in(s.min_height_m, 0.1, 100.0) || !in(s.min_width_m, 0.1, 100.0)) return fail("rooms: least sizes must be in [0.1, 100] m");
  if (!in(s.seed_height_m, 0.0, 100.0)) return fail("rooms: seed_height_m must be in [0, 100] m");
  if (!in(s.max_extent_m, 1.0, 1024.0)) return fail("rooms: max_extent_m must be in [1, 1024] m");
  if (s.test_rays < 8 || s.test_rays > 4096) return fail("rooms: test_rays must be in [8, 4096]");
  if (!in(s.max_open_fraction, 0.0, 1.0)) return fail("rooms: max_open_fraction must be in [0, 1]");
  if (!in(s.wall_margin_m, 0.0, 10.0)) return fail("rooms: wall_margin_m must be in [0, 10] m");
  return {};
}

Result<std::vector<InteriorVolume>> findRooms(const raytrace::WorldGeometry& geometry, const raytrace::SectorRange& range,
                                              const std::vector<InteriorVolume>& artist, const RoomSettings& settings,
                                              RoomStats* stats) {
  DRTV_CHECK(validateRoomSettings(settings).has_value());
  std::vector<SectorKey> keys;
  for (int32_t x = range.x0; x <= range.x1; ++x)
    for (int32_t y = range.y0; y <= range.y1; ++y) keys.push_back({x, y});
  std::vector<SectorRooms> found(keys.size());
  tbb::parallel_for(size_t(0), keys.size(), [&](size_t i) { found[i] = sectorRooms(geometry, keys[i], settings); });

  RoomStats total;
  std::vector<InteriorVolume> out;
  for (SectorRooms& f : found) {
    if (f.error) return std::unexpected(*f.error);
    total.seeds += f.stats.seeds;
    total.enclosed += f.stats.enclosed;
    total.rays += f.stats.rays;
    for (const LocalBox& b : f.boxes) {
      const double v = volume(b.min, b.max);
      auto same = [&](const glm::dvec3& lo, const glm::dvec3& hi) {
        return overlapVolume(b.min, b.max, lo, hi) > kSameRoomOverlap * std::min(v, volume(lo, hi));
      };
      if (std::any_of(artist.begin(), artist.end(), [&](const InteriorVolume& a) { return overlapVolume(b.min, b.max, a.min, a.max) > 0.0; })) {
        ++total.dropped_artist;
        continue;
      }
      if (std::any_of(out.begin(), out.end(), [&](const InteriorVolume& k) { return same(k.min, k.max); })) {
        ++total.dropped_overlap;
        continue;
      }
      InteriorVolume iv;
      iv.name = "room " + std::to_string(out.size() + 1);
      iv.min = b.min;
      iv.max = b.max;
      iv.probe_position = b.probe;
      iv.blend_distance_m = float(b.blend_m);
      out.push_back(std::move(iv));
    }
  }
  total.rooms = out.size();
  if (stats) *stats = total;
  return out;
}

}  // namespace drtv::baker
