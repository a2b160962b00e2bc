// drtv/baker/reference.h — the path-traced ground truth that every approximation of drtv is
// measured against: irradiance at a point and normal for the world's sun, sky and point lights,
// any number of diffuse bounces, split into the parts `drtv query` reports, each with its
// standard error.
//
//  [1] Pharr, Jakob, Humphreys, "Physically Based Rendering", 4th ed. (pbrt-v4), 2023:
//      sec. 2.1.4 (Monte Carlo estimator and its variance), sec. 13.1 (the path integral),
//      sec. 13.2 / 13.3 (path tracing with next-event estimation of delta lights), sec. 14.5
//      (Russian roulette), sec. A.5 (cosine-weighted hemisphere sampling, pdf cos/pi).
//  [2] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slides 5, 7-9, 28-31:
//      ambient = sun/sky bounce + direct sky (+ local-light bounce on PC); direct sun is the
//      deferred renderer's, not the ambient's.
//  [3] DESIGN.md, "What a probe holds and how it is relit": the four relighting terms.
//
// The physical model (the same world the probes are baked from, bake.h / transfer.h):
//  - Surfaces: Lambertian, albedo rho per triangle (the world's materials), ONE-SIDED unless their
//    material is double-sided (worlds::Mesh::double_sided). A ray that hits a one-sided triangle
//    from behind has entered geometry; it carries no light (the baker counts the same hits in
//    backface_frac and drops them, transfer.h). A double-sided triangle is a surface from both
//    sides, its normal facing the ray (RayScene::facingNormal), as in the baker.
//  - Only terrain, static and vegetation instances take part. Dynamic instances never occlude and
//    never bounce: the probes' world has no dynamic geometry (talk [2] slide 7: the spheres
//    "receive global illumination but do not contribute to it"), so the reference answers the
//    question the probes answer. A query point may lie on a dynamic object; its own hemisphere is
//    then unoccluded by it (exact for convex objects such as the test box's spheres).
//  - Sun: a delta (directional) light of irradiance Sky::sun_irradiance.at(hour) at normal
//    incidence from Sky::sunDirection(hour). The runtime represents it as windowed SH
//    (lighting_sh.h); the reference keeps the true delta, so that the SH error is measured. A sun
//    at or below the geometric horizon (direction z <= 0) is set: the Earth blocks it. (The
//    runtime fades it between -0.83 and +2 degrees instead; the difference is part of what the
//    accuracy report measures at dawn and dusk.)
//  - Sky: radiance Sky::skyRadiance(dir, hour) for every ray that leaves the geometry, whatever
//    its direction (below the horizon: ground_radiance_scale x horizon colour).
//  - Point lights: isotropic, radiant intensity I [per sr], irradiance I cos / r^2 with a shadow
//    ray; r^2 is clamped at kMinLightDistance2 so that a light exactly on a surface stays finite.
//    radius_m is the runtime's range of influence, not physics: the reference ignores it.
//
// The parts (irradiance E = integral of L cos dw at the query point, linear RGB):
//  - sun bounce:   sun light after >= 1 diffuse bounce;
//  - sky bounce:   sky light after >= 1 diffuse bounce;
//  - direct sky:   sky seen directly from the point (no bounce);
//  - local lights: point-light light after >= 1 diffuse bounce (the LPRT term);
//  - direct sun, direct local: light reaching the point straight from the sun / the point lights.
//    NOT ambient: the renderer adds them with shadow rays (talk [2] slide 39). They are
//    deterministic (one shadow ray each), so their standard error is 0.
//  ambient = sun bounce + sky bounce + direct sky + local lights.
//
// Estimator [1]: N independent paths per query. Path k starts with a cosine-weighted direction
// about the query normal (pdf cos/pi, so each escaping ray contributes pi L); at every front-face
// hit x_j the path throughput beta_j = rho_1 ... rho_j collects beta_j E_sun(x_j) and
// beta_j E_lights(x_j) by next-event estimation (shadow rays) and continues with a cosine-weighted
// direction about the surface normal; a continuation that escapes collects beta_j pi L_sky.
// Russian roulette from bounce `roulette_after` on, with survival probability max(beta) (so
// albedo 1 never terminates early); paths stop after `max_bounces` hits (a truncation that only
// matters for albedos near 1 in closed rooms; tests bound it). Every part's mean and standard
// error sqrt(var / N) come from the per-path values; ambient's comes from the per-path sums, so
// the correlation between parts is accounted for.
//
// Determinism: the random number for dimension d of path k at query `point_id` is a pure function
// of (seed, point_id, k, d) (sampling.h), never of threads or time: the same query gives the same
// bits on 1 or N threads and in any order.
//
// Coordinates: worlds may sit far from the origin. A ReferenceScene keeps its triangles in a local
// float frame anchored at a double-precision world position (a sector corner, as the baker does),
// and every public function takes and returns world positions as doubles.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/formats/error.h"
#include "drtv/formats/lighting.h"
#include "drtv/worlds/world.h"

namespace drtv::reference {

// A point light's r^2 is clamped at (1 cm)^2: finite for a light exactly on a surface or on the
// query point, and far below any distance the probes can resolve (the LPRT bake clamps at 1 m,
// transfer.h, which is part of what the reference measures).
inline constexpr float kMinLightDistance2 = 1e-4f;

// Which geometry a ReferenceScene holds.
struct ReferenceRegion {
  // Take everything (the default), or only the geometry within `halo_m` (xy) of the 64 m sector
  // containing `centre` — the same gather the baker does per sector (world_geometry.h).
  bool whole_world = true;
  glm::dvec3 centre{0.0};  // world metres (only with whole_world = false)
  double halo_m = 64.0;    // metres, >= 0 (only with whole_world = false)
  // Also build the camera's view: the static triangles plus every dynamic instance's (what a
  // camera sees, and what casts the preview's direct shadows). Dynamic meshes are checked here
  // (bad indices, non-finite or zero-area triangles are skipped and noted), never aborted on.
  bool camera_view = false;
};

// The static world as the reference and the preview renderer see it. Move-only, immutable after
// build; every const member may run from any number of threads at once.
class ReferenceScene {
 public:
  // Gathers the world's terrain, static and vegetation triangles (world_geometry.h: degenerate and
  // non-finite triangles are skipped and listed in notes()) and builds an Embree scene over them.
  // `where` prefixes error messages (the world file). Errors: those of WorldGeometry::build
  // ("nothing to bake", bad mesh indices, a world wider than kMaxWorldExtentM) and of Embree.
  static Result<ReferenceScene> build(const worlds::World& world, const std::string& where,
                                      const ReferenceRegion& region = {});
  ReferenceScene(ReferenceScene&&) noexcept;
  ReferenceScene& operator=(ReferenceScene&&) noexcept;
  ~ReferenceScene();

  // World position (metres) of the local frame's origin: local = world - origin().
  glm::dvec3 origin() const;
  glm::vec3 toLocal(const glm::dvec3& world) const { return glm::vec3(world - origin()); }
  glm::dvec3 toWorld(const glm::vec3& local) const { return origin() + glm::dvec3(local); }

  // The ray tracer over the local-frame triangles (prim indices index albedo()).
  const raytrace::RayScene& rays() const;
  // Diffuse albedo (linear RGB in [0, 1]) of triangle `prim`. Precondition: prim < triangleCount().
  glm::vec3 albedo(uint32_t prim) const;
  size_t triangleCount() const;
  // The highest z (world metres) of the triangles rays() holds (0 with none): where a ray from
  // above must start to miss nothing (the LPV technique's RSMs).
  double topZ() const;
  // Skips and repairs, one line each (world_geometry.h's, then the camera view's).
  const std::vector<std::string>& notes() const;

  // The camera's view (static then dynamic triangles, same local frame). Precondition: built with
  // ReferenceRegion::camera_view (a bug otherwise); prim < viewRays().triangleCount().
  bool hasCameraView() const;
  const raytrace::RayScene& viewRays() const;
  glm::vec3 viewAlbedo(uint32_t prim) const;
  bool viewDynamic(uint32_t prim) const;

 private:
  struct Impl;
  explicit ReferenceScene(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The lighting at one time of day, resolved once for many queries. Value type.
struct ReferenceLighting {
  Sky sky = Sky::tropicalDefault();
  double hour = 12.0;                  // any finite real, modulo 24
  std::vector<PointLight> lights;      // world positions

  // Precondition for every query: validateLighting(sky, lights, {}) holds and hour is finite
  // (a bug otherwise; the command-line tools check and return errors first).
};

struct ReferenceSettings {
  int samples = 1024;        // paths per query, >= 2 (for a standard error)
  int max_bounces = 64;      // diffuse hits per path at most, >= 1 (truncation, see the header)
  int roulette_after = 3;    // Russian roulette from this many hits on, >= 1
  uint64_t seed = 1;         // keys every random number with the query's point_id
};

enum ReferencePart : int {
  kRefSunBounce = 0,
  kRefSkyBounce,
  kRefDirectSky,
  kRefLocalLights,
  kRefDirectSun,
  kRefDirectLocal,
  kRefPartCount,
};
// "sun_bounce", "sky_bounce", "direct_sky", "local_lights", "direct_sun", "direct_local".
const char* referencePartName(ReferencePart part);

// A Monte Carlo estimate: the mean and its standard error sqrt(sample variance / N), per channel.
struct Estimate {
  glm::vec3 mean{0.f};
  glm::vec3 std_error{0.f};
};

// Irradiance at one point and normal, linear RGB, in the lighting's units.
struct ReferenceIrradiance {
  std::array<Estimate, kRefPartCount> parts{};
  Estimate ambient;          // sun bounce + sky bounce + direct sky + local lights
  uint64_t rays = 0;         // rays traced (closest hit and shadow) for this query
};

// A query: world position, unit normal, and the id that keys its random numbers.
struct ReferenceQuery {
  glm::dvec3 position{0.0};  // world metres, finite
  glm::vec3 normal{0.f, 0.f, 1.f};  // normalised here; zero or non-finite reads as +Z
  uint64_t point_id = 0;
};

// The reference irradiance for one query (see the header for the model and estimator). Finite for
// finite input. Thread-safe; single-threaded inside.
ReferenceIrradiance referenceIrradiance(const ReferenceScene& scene, const ReferenceLighting& lighting,
                                        const ReferenceQuery& query, const ReferenceSettings& settings);

// Many queries on all TBB threads (`threads` > 0 limits them; 1 runs serially). The result is the
// same bits whatever the thread count (each query is keyed by its point_id). Thread-safe.
std::vector<ReferenceIrradiance> referenceIrradiance(const ReferenceScene& scene, const ReferenceLighting& lighting,
                                                     std::span<const ReferenceQuery> queries,
                                                     const ReferenceSettings& settings, int threads = 0);

// The direct irradiance a renderer adds on top of ambient, at world `position` for unit `normal`:
// the sun (a shadow ray along the sun direction) and every point light (a shadow ray to it), with
// the model above. `occluders` decides what casts shadows (the preview passes a scene that
// includes dynamic objects, so spheres shadow the ground; the reference's parts use the static
// scene). `origin` is occluders' local-frame origin. Deterministic, thread-safe.
struct DirectIrradiance {
  glm::vec3 sun{0.f};
  glm::vec3 lights{0.f};
};
DirectIrradiance directIrradiance(const raytrace::RayScene& occluders, const glm::dvec3& origin, const ReferenceLighting& lighting,
                                  const glm::dvec3& position, const glm::vec3& normal);

// The sun as the reference sees it: unit direction towards it and its irradiance at normal
// incidence (0 when it is at or below the horizon). Thread-safe.
struct ReferenceSun {
  glm::vec3 direction{0.f, 0.f, 1.f};
  glm::vec3 irradiance{0.f};
};
ReferenceSun referenceSun(const Sky& sky, double hour);

// How far a ray starts off a surface at local position `p` along its normal: 0.1 mm plus ~30 float
// ulps of |p| (so that a ray never re-hits the surface it leaves, at any distance from the frame's
// origin). Pure.
float rayOffset(const glm::vec3& p);

}  // namespace drtv::reference
