// drtv/raytrace/ray_scene.h — the ray tracer of the baker and the path tracer: a triangle soup behind Embree 3.
//
// Embree stays in src/ (STYLE.md): this header names none of its types. Embree's errors are
// translated here into Error values (rtcSetDeviceErrorFunction), never printed or thrown.
//
// Conventions: coordinates are the caller's local frame in metres (the baker uses the sector's
// min corner, so that float precision does not depend on where the world sits). Triangles are
// counter-clockwise when seen from their front side; normal(prim) is that front side.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"

namespace drtv::raytrace {

inline constexpr uint32_t kNoPrim = std::numeric_limits<uint32_t>::max();

// A ray segment origin + t dir, t in [t_near, t_far]. `dir` need not be unit length (t scales).
struct Ray {
  glm::vec3 origin{0.f};
  float t_near = 0.f;
  glm::vec3 dir{0.f, 0.f, 1.f};
  float t_far = std::numeric_limits<float>::infinity();
};

// The closest hit of a ray, or prim == kNoPrim.
struct Hit {
  float t = std::numeric_limits<float>::infinity();
  uint32_t prim = kNoPrim;  // triangle index in the soup given to build()
  bool hit() const { return prim != kNoPrim; }
};

// An immutable acceleration structure over a triangle soup. Move-only.
// Thread-safety: build() may run concurrently for different scenes; after build every query is
// const and may run from any number of threads at once.
class RayScene {
 public:
  // Builds over `vertices` (3 per triangle; finite, non-degenerate — the caller filters, see
  // world_geometry.h). An empty soup gives a scene every ray misses. Fails with Embree's
  // translated message ("embree: out of memory ...") if Embree fails.
  // `two_sided`: empty (every triangle one-sided) or one flag per triangle; a two-sided
  // triangle (a double-sided material, docs/world-format.md "Materials") is a surface from both
  // sides: frontFace() is true whichever side a ray hits, facingNormal() faces the ray.
  static Result<RayScene> build(std::span<const glm::vec3> vertices, std::span<const uint8_t> two_sided = {});
  RayScene(RayScene&&) noexcept;
  RayScene& operator=(RayScene&&) noexcept;
  ~RayScene();

  size_t triangleCount() const;
  // Unit front-face normal of triangle `prim` (cross(v1 - v0, v2 - v0), normalised).
  const glm::vec3& normal(uint32_t prim) const;
  // Whether triangle `prim` is two-sided (see build).
  bool twoSided(uint32_t prim) const;
  // True when `ray` hits triangle `prim` from its front side, or `prim` is two-sided: the hit is a
  // surface, not the inside of geometry.
  bool frontFace(const Ray& ray, uint32_t prim) const { return twoSided(prim) || glm::dot(ray.dir, normal(prim)) < 0.f; }
  // True when `ray` hits two-sided triangle `prim` from behind its winding. frontFace() accepts
  // such a hit as a surface; a point that every direction shows such hits is closed in by the
  // inside of a double-sided solid (placement's inside test, the accuracy's buried points).
  bool behindTwoSided(const Ray& ray, uint32_t prim) const { return twoSided(prim) && glm::dot(ray.dir, normal(prim)) > 0.f; }
  // The unit normal of the side `ray` hits, for a hit frontFace() accepts: normal(prim), flipped
  // towards the ray's origin for a two-sided triangle hit from behind.
  glm::vec3 facingNormal(const Ray& ray, uint32_t prim) const {
    const glm::vec3& n = normal(prim);
    return twoSided(prim) && glm::dot(ray.dir, n) > 0.f ? -n : n;
  }

  // Closest hit of one ray (rtcIntersect1).
  Hit intersect(const Ray& ray) const;
  // Closest hits of many rays (rtcIntersect1M in chunks: about 2x single rays for one probe's
  // rays on this machine, see docs/baker.md). hits.size() == rays.size().
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const;
  // Whether anything blocks the segment (rtcOccluded1).
  bool occluded(const Ray& ray) const;
  // Many occlusion queries (rtcOccluded1M): blocked[i] = 1 if ray i is blocked.
  void occluded(std::span<const Ray> rays, std::span<uint8_t> blocked) const;

 private:
  struct Impl;
  explicit RayScene(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace drtv::raytrace
