// The production fine-level shaders as a Vulkan compute pass (fine_pass.h).
#include "fine_pass.h"

#include <algorithm>
#include <cstring>

namespace drtv::testing {
namespace {

// A device storage buffer holding `bytes` of `data` (at least 4 bytes: Vulkan has no empty
// buffer), filled through a staging buffer.
Result<int> deviceBuffer(VulkanCompute& vk, const void* data, size_t bytes) {
  const size_t size = std::max<size_t>(bytes, 16);
  auto staging = vk.addBuffer(size, BufferKind::kStaging);
  if (!staging) return std::unexpected(staging.error());
  if (bytes) std::memcpy(vk.bufferMemory(*staging).data(), data, bytes);
  auto buffer = vk.addBuffer(size, BufferKind::kDeviceStorage);
  if (!buffer) return std::unexpected(buffer.error());
  if (auto r = vk.copyBuffer(*staging, *buffer, size); !r) return std::unexpected(r.error());
  return *buffer;
}

}  // namespace

Result<std::unique_ptr<FinePass>> FinePass::create(VulkanCompute& vk, const std::string& source_dir, ShaderLanguage language,
                                                   Representation representation, const runtime::FineShaderData& level,
                                                   size_t max_points) {
  const std::string shaders = source_dir + "/runtime/shaders", wrappers = source_dir + "/bench/common/shaders";
  const std::string define = representation == Representation::kShL1 ? "-DDRTV_SH_L1 " : "";
  const std::string arguments =
      language == ShaderLanguage::kGlsl
          ? "-V -S comp -DDRTV_FINE_BINDING=2 " + define + shaders + "/fine.glsl " + wrappers + "/fine_compute.comp"
          : "-D -V -S comp -e computeMain " + define + "-I" + shaders + " --shift-cbuffer-binding 1 " + wrappers + "/fine_compute.hlsl";
  auto spirv = compileWithGlslang(arguments);
  if (!spirv) return std::unexpected(spirv.error());

  std::unique_ptr<FinePass> pass(new FinePass(vk));
  auto ubo = vk.addBuffer(sizeof(runtime::FineShaderConstants), BufferKind::kUniform);
  if (!ubo) return std::unexpected(ubo.error());
  std::memcpy(vk.bufferMemory(*ubo).data(), &level.constants, sizeof level.constants);
  auto probes = deviceBuffer(vk, level.probes.data(), level.probes.size() * sizeof(runtime::FineShaderProbe));
  if (!probes) return std::unexpected(probes.error());
  auto maps = deviceBuffer(vk, level.visibility.data(), level.visibility.size() * sizeof(uint32_t));
  if (!maps) return std::unexpected(maps.error());
  auto cells = deviceBuffer(vk, level.cells.data(), level.cells.size() * sizeof(uint32_t));
  if (!cells) return std::unexpected(cells.error());

  auto buffers = addPointBuffers(vk, max_points, kWorkgroupSize);
  if (!buffers) return std::unexpected(buffers.error());
  pass->buffers_ = *buffers;

  const std::vector<PipelineBinding> bindings = {
      {0, BindingKind::kStorageBuffer, pass->buffers_.points}, {1, BindingKind::kStorageBuffer, pass->buffers_.results}, {2, BindingKind::kUniformBuffer, *ubo},
      {3, BindingKind::kStorageBuffer, *probes}, {4, BindingKind::kStorageBuffer, *maps},    {5, BindingKind::kStorageBuffer, *cells}};
  auto pipeline = vk.addPipeline(*spirv, language == ShaderLanguage::kGlsl ? "main" : "computeMain", bindings);
  if (!pipeline) return std::unexpected(pipeline.error());
  pass->pipeline_ = *pipeline;
  return pass;
}

Result<std::vector<glm::vec4>> FinePass::run(std::span<const AmbientPoint> points) {
  return runPoints(vk_, pipeline_, buffers_, kWorkgroupSize, points, "fine pass");
}

}  // namespace drtv::testing
