// RayScene: the Embree 3 adapter. Embree's errors become Error values here.
#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/ray_log.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cstdlib>
#include <atomic>
#include <mutex>
#include <string>
#include <vector>

namespace drtv::raytrace {
namespace {

// The message of the last Embree error on this thread, set by the device's error callback.
thread_local std::string t_embree_error;

void onEmbreeError(void*, RTCError code, const char* str) {
  t_embree_error = "embree: error " + std::to_string(int(code)) + ": " + (str ? str : "");
}

// One device per process: Embree devices are heavy and thread-safe.
RTCDevice sharedDevice() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice(std::getenv("DRTV_EMBREE_CONFIG"));
    if (d) rtcSetDeviceErrorFunction(d, onEmbreeError, nullptr);
    return d;
  }();
  return device;
}

// Rays per rtcIntersect1M / rtcOccluded1M call: one probe basis' worth, on the stack.
constexpr size_t kStreamChunk = 256;

void toRtc(const Ray& r, RTCRay& o) {
  o.org_x = r.origin.x;
  o.org_y = r.origin.y;
  o.org_z = r.origin.z;
  o.tnear = r.t_near;
  o.dir_x = r.dir.x;
  o.dir_y = r.dir.y;
  o.dir_z = r.dir.z;
  o.time = 0.f;
  o.tfar = r.t_far;
  o.mask = 0xffffffffu;
  o.id = 0;
  o.flags = 0;
}

std::atomic<RayLog*> g_log{nullptr};

void logCall(RayLog::Kind kind, std::span<const Ray> rays) {
  RayLog* log = g_log.load(std::memory_order_relaxed);
  if (!log) return;
  std::lock_guard lock(log->mutex);
  log->calls.push_back({kind, uint32_t(log->rays.size()), uint32_t(rays.size())});
  log->rays.insert(log->rays.end(), rays.begin(), rays.end());
}

}  // namespace

void setRayLog(RayLog* log) { g_log.store(log); }

struct RayScene::Impl {
  RTCScene scene = nullptr;
  std::vector<glm::vec3> normals;
  std::vector<uint8_t> two_sided;  // per triangle, or empty: none
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
  }
};

RayScene::RayScene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
RayScene::RayScene(RayScene&&) noexcept = default;
RayScene& RayScene::operator=(RayScene&&) noexcept = default;
RayScene::~RayScene() = default;

Result<RayScene> RayScene::build(std::span<const glm::vec3> vertices, std::span<const uint8_t> two_sided) {
  DRTV_CHECK_EQ(vertices.size() % 3, size_t(0));
  DRTV_CHECK(two_sided.empty() || two_sided.size() == vertices.size() / 3);
  RTCDevice device = sharedDevice();
  if (!device) return fail("embree: could not create a device");
  t_embree_error.clear();
  auto impl = std::make_unique<Impl>();
  const size_t tris = vertices.size() / 3;
  impl->normals.resize(tris);
  if (std::find(two_sided.begin(), two_sided.end(), uint8_t(1)) != two_sided.end())
    impl->two_sided.assign(two_sided.begin(), two_sided.end());
  for (size_t i = 0; i < tris; ++i) {
    const glm::vec3 n = glm::cross(vertices[3 * i + 1] - vertices[3 * i], vertices[3 * i + 2] - vertices[3 * i]);
    const float len = glm::length(n);
    impl->normals[i] = len > 0.f ? n / len : glm::vec3(0.f, 0.f, 1.f);
  }
  impl->scene = rtcNewScene(device);
  if (!impl->scene) return fail(t_embree_error.empty() ? "embree: rtcNewScene failed" : t_embree_error);
  // MEDIUM quality: HIGH cost 3x to build and traced no faster on terrain (DESIGN.md).
  rtcSetSceneBuildQuality(impl->scene, RTC_BUILD_QUALITY_MEDIUM);
  if (tris > 0) {
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!geom) return fail(t_embree_error.empty() ? "embree: rtcNewGeometry failed" : t_embree_error);
    auto* vb = static_cast<float*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertices.size()));
    auto* ib = static_cast<uint32_t*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), tris));
    if (!vb || !ib) {
      rtcReleaseGeometry(geom);
      return fail(t_embree_error.empty() ? "embree: out of memory for " + std::to_string(tris) + " triangles" : t_embree_error);
    }
    for (size_t v = 0; v < vertices.size(); ++v) {
      vb[3 * v] = vertices[v].x;
      vb[3 * v + 1] = vertices[v].y;
      vb[3 * v + 2] = vertices[v].z;
      ib[v] = uint32_t(v);
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(impl->scene, geom, 0);
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(impl->scene);
  if (!t_embree_error.empty()) return fail(t_embree_error);
  return RayScene(std::move(impl));
}

size_t RayScene::triangleCount() const { return impl_->normals.size(); }
const glm::vec3& RayScene::normal(uint32_t prim) const { return impl_->normals[prim]; }
bool RayScene::twoSided(uint32_t prim) const { return !impl_->two_sided.empty() && impl_->two_sided[prim] != 0; }

Hit RayScene::intersect(const Ray& ray) const {
  logCall(RayLog::Kind::kIntersect1, std::span(&ray, 1));
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  toRtc(ray, rh.ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &ctx, &rh);
  Hit h;
  if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
    h.t = rh.ray.tfar;
    h.prim = rh.hit.primID;
  }
  return h;
}

void RayScene::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  DRTV_CHECK_EQ(rays.size(), hits.size());
  logCall(RayLog::Kind::kIntersectM, rays);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit buf[kStreamChunk];
  for (size_t start = 0; start < rays.size(); start += kStreamChunk) {
    const size_t n = std::min(kStreamChunk, rays.size() - start);
    for (size_t i = 0; i < n; ++i) {
      toRtc(rays[start + i], buf[i].ray);
      buf[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
      buf[i].hit.primID = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect1M(impl_->scene, &ctx, buf, unsigned(n), sizeof(RTCRayHit));
    for (size_t i = 0; i < n; ++i) {
      Hit& h = hits[start + i];
      if (buf[i].hit.geomID != RTC_INVALID_GEOMETRY_ID) {
        h.t = buf[i].ray.tfar;
        h.prim = buf[i].hit.primID;
      } else {
        h = Hit{};
      }
    }
  }
}

bool RayScene::occluded(const Ray& ray) const {
  logCall(RayLog::Kind::kOccluded1, std::span(&ray, 1));
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  toRtc(ray, r);
  rtcOccluded1(impl_->scene, &ctx, &r);
  return r.tfar < 0.f;  // Embree sets tfar = -inf on a hit
}

void RayScene::occluded(std::span<const Ray> rays, std::span<uint8_t> blocked) const {
  DRTV_CHECK_EQ(rays.size(), blocked.size());
  logCall(RayLog::Kind::kOccludedM, rays);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay buf[kStreamChunk];
  for (size_t start = 0; start < rays.size(); start += kStreamChunk) {
    const size_t n = std::min(kStreamChunk, rays.size() - start);
    for (size_t i = 0; i < n; ++i) toRtc(rays[start + i], buf[i]);
    rtcOccluded1M(impl_->scene, &ctx, buf, unsigned(n), sizeof(RTCRay));
    for (size_t i = 0; i < n; ++i) blocked[start + i] = buf[i].tfar < 0.f ? 1 : 0;
  }
}

}  // namespace drtv::raytrace
