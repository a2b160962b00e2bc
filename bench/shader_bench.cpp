// drtv_shader_bench — the production ambient shaders (GLSL, and HLSL through glslang) as one
// Vulkan compute pass over a 1920 x 1080 grid of surface points, on whatever Vulkan device the
// loader offers (ambient_pass.h). The talk's figure is under 0.5 ms on a console GPU; on a
// machine without a GPU the device is lavapipe, Mesa's CPU driver, and its time says nothing
// about a GPU. The device is printed as the benchmark's label.
// Time: device time between timestamps around the dispatch (manual time); the uploads, the point
// copies and the readback are outside it.
//   drtv_shader_bench --benchmark_min_time=1
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <memory>

#include "ambient_pass.h"
#include "drtv/runtime/runtime.h"
#include "runtime_world.h"
#include "vulkan_compute.h"

namespace drtv::testing {
namespace {

constexpr int kWidth = 1920, kHeight = 1080;

// The runtime the runtime benchmarks use: 51 synthetic sectors of 70 probes around the origin,
// noon, the volume on (0, 0, 12).
std::unique_ptr<runtime::Runtime> makeRuntime() {
  auto rt = std::make_unique<runtime::Runtime>();
  for (int y = -3; y <= 3; ++y)
    for (int x = -3; x <= 3; ++x)
      if (!rt->addSector(makeSector({x, y}, {.probes = 70}, 1))) std::abort();
  (void)rt->setTime(12.0);
  rt->update({0.0, 0.0, 12.0});
  return rt;
}

// A screen's worth of terrain points: a 1920 x 1080 grid over the volume's horizontal extent
// (+-90 m by +-50 m), on the synthetic terrain, normals from its slope, row by row as a G-buffer
// would be read.
std::vector<AmbientPoint> screenPoints() {
  std::vector<AmbientPoint> points;
  points.reserve(size_t(kWidth) * kHeight);
  for (int j = 0; j < kHeight; ++j)
    for (int i = 0; i < kWidth; ++i) {
      const double x = -90.0 + 180.0 * (i + 0.5) / kWidth, y = -50.0 + 100.0 * (j + 0.5) / kHeight;
      const double dzdx = (terrainZ(x + 0.1, y) - terrainZ(x - 0.1, y)) / 0.2, dzdy = (terrainZ(x, y + 0.1) - terrainZ(x, y - 0.1)) / 0.2;
      points.push_back({glm::vec4(float(x), float(y), terrainZ(x, y), 0.f),
                        glm::vec4(glm::normalize(glm::vec3(float(-dzdx), float(-dzdy), 1.f)), 0.f)});
    }
  return points;
}

void BM_AmbientPass1080p(benchmark::State& state, ShaderLanguage language) {
  auto vk = VulkanCompute::create();
  if (!vk) {
    state.SkipWithError(vk.error().message.c_str());
    return;
  }
  const std::unique_ptr<runtime::Runtime> rt = makeRuntime();
  const runtime::PublishedVolume::ReadView view = rt->volume().read();
  const std::vector<AmbientPoint> points = screenPoints();
  auto pass = AmbientPass::create(**vk, DRTV_SOURCE_DIR, language, view.volume(),
                                  makeConstantsBlock(view->shaderConstants(), rt->options().normal_offset_m), points.size());
  if (!pass) {
    state.SkipWithError(pass.error().message.c_str());
    return;
  }
  for (auto _ : state) {
    double seconds = 0.0;
    auto out = (*pass)->run(points, &seconds);
    if (!out) {
      state.SkipWithError(out.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(out->data());
    state.SetIterationTime(seconds);
  }
  state.SetItemsProcessed(state.iterations() * int64_t(points.size()));
  state.SetLabel((*vk)->deviceDescription() + ((*vk)->isCpuDevice() ? " (CPU driver, not a GPU figure)" : ""));
}
BENCHMARK_CAPTURE(BM_AmbientPass1080p, glsl, ShaderLanguage::kGlsl)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_AmbientPass1080p, hlsl, ShaderLanguage::kHlsl)->UseManualTime()->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace drtv::testing

BENCHMARK_MAIN();
