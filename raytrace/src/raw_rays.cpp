// Raw Embree throughput on the bake's scenes (see raw_rays.h).
#include "drtv/raytrace/raw_rays.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <ctime>
#include <cmath>
#include <vector>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/sampling.h"

namespace drtv::raytrace {

double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

Result<RawRayFigures> measureRawRays(const WorldGeometry& geometry, std::span<const SectorKey> keys, uint64_t rays,
                                     double halo_m, uint64_t seed) {
  constexpr size_t kBatch = 256;
  RawRayFigures f;
  if (keys.empty()) return f;
  double t_single = 0, t_stream = 0, t_occluded = 0, c_single = 0, c_stream = 0, c_occluded = 0;
  const size_t points = std::max<size_t>(1, size_t(rays / keys.size() / kBatch));
  for (const SectorKey key : keys) {
    const SectorGeometry g = geometry.gather(key, halo_m);
    auto scene = RayScene::build(g.vertices);
    if (!scene) return std::unexpected(scene.error());
    f.triangles += g.triangleCount();
    // Probe-like origins: 1.5 m above the first surface under random points of the sector.
    std::vector<Ray> all(points * kBatch);
    for (size_t p = 0; p < points; ++p) {
      const uint64_t k = hashKey(seed, uint64_t(uint32_t(key.ix)), uint64_t(uint32_t(key.iy)), p);
      const glm::vec3 top(unitFloat(hashKey(k, 1)) * 64.f, unitFloat(hashKey(k, 2)) * 64.f, g.z_max + 10.f);
      const Hit h = scene->intersect(Ray{top, 0.f, glm::vec3(0, 0, -1), INFINITY});
      const glm::vec3 origin = h.hit() ? top - glm::vec3(0, 0, h.t - 1.5f) : glm::vec3(top.x, top.y, 1.5f);
      const glm::vec2 shift(unitFloat(hashKey(k, 3)), unitFloat(hashKey(k, 4)));
      for (size_t i = 0; i < kBatch; ++i) all[p * kBatch + i] = Ray{origin, 0.f, uniformSphere(r2Point(uint32_t(i), shift)), INFINITY};
    }
    std::vector<Hit> hits(all.size());
    std::vector<uint8_t> blocked(all.size());
    using Clock = std::chrono::steady_clock;
    auto t0 = Clock::now();
    double c0 = processCpuSeconds();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, all.size(), kBatch), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i < r.end(); ++i) hits[i] = scene->intersect(all[i]);
    });
    t_single += std::chrono::duration<double>(Clock::now() - t0).count();
    c_single += processCpuSeconds() - c0;
    t0 = Clock::now();
    c0 = processCpuSeconds();
    tbb::parallel_for(size_t(0), points, [&](size_t p) {
      scene->intersect(std::span(all).subspan(p * kBatch, kBatch), std::span(hits).subspan(p * kBatch, kBatch));
    });
    t_stream += std::chrono::duration<double>(Clock::now() - t0).count();
    c_stream += processCpuSeconds() - c0;
    t0 = Clock::now();
    c0 = processCpuSeconds();
    tbb::parallel_for(size_t(0), points, [&](size_t p) {
      scene->occluded(std::span(all).subspan(p * kBatch, kBatch), std::span(blocked).subspan(p * kBatch, kBatch));
    });
    t_occluded += std::chrono::duration<double>(Clock::now() - t0).count();
    c_occluded += processCpuSeconds() - c0;
    f.rays += all.size();
  }
  f.triangles /= keys.size();
  f.single_rays_per_s = double(f.rays) / t_single;
  f.stream_rays_per_s = double(f.rays) / t_stream;
  f.occluded_stream_rays_per_s = double(f.rays) / t_occluded;
  f.single_rays_per_cpu_s = double(f.rays) / c_single;
  f.stream_rays_per_cpu_s = double(f.rays) / c_stream;
  f.occluded_stream_rays_per_cpu_s = double(f.rays) / c_occluded;
  return f;
}

ReplayFigures replayRays(const RayScene& scene, const RayLog& log, int repeat) {
  ReplayFigures f;
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  const double c0 = processCpuSeconds();
  for (int k = 0; k < repeat; ++k)
    tbb::parallel_for(tbb::blocked_range<size_t>(0, log.calls.size()), [&](const tbb::blocked_range<size_t>& r) {
      std::vector<Hit> hits;
      std::vector<uint8_t> blocked;
      for (size_t c = r.begin(); c < r.end(); ++c) {
        const RayLog::Call& call = log.calls[c];
        const std::span<const Ray> rays(log.rays.data() + call.first, call.count);
        switch (call.kind) {
          case RayLog::Kind::kIntersect1:
            for (const Ray& ray : rays) (void)scene.intersect(ray);
            break;
          case RayLog::Kind::kIntersectM:
            hits.resize(rays.size());
            scene.intersect(rays, hits);
            break;
          case RayLog::Kind::kOccluded1:
            for (const Ray& ray : rays) (void)scene.occluded(ray);
            break;
          case RayLog::Kind::kOccludedM:
            blocked.resize(rays.size());
            scene.occluded(rays, blocked);
            break;
        }
      }
    });
  f.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  f.cpu_s = processCpuSeconds() - c0;
  f.rays = uint64_t(log.rays.size()) * uint64_t(repeat);
  return f;
}

}  // namespace drtv::raytrace
