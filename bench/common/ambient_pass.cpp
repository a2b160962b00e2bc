// The production ambient shaders as a Vulkan compute pass (ambient_pass.h).
#include "ambient_pass.h"

#include <cstring>

namespace drtv::testing {

const char* shaderLanguageName(ShaderLanguage language) { return language == ShaderLanguage::kGlsl ? "GLSL" : "HLSL"; }

VolumeConstantsBlock makeConstantsBlock(const runtime::VolumeShaderConstants& k, float offset_length_m) {
  VolumeConstantsBlock b{};
  for (int a = 0; a < 3; ++a) {
    b.snapped_camera[a] = float(k.snapped_camera[a]);
    b.uv_scale[a] = k.uv_scale[a];
    b.wrap_offset[a] = k.wrap_offset[a];
    b.uv_remap_scale[a] = k.uv_remap_scale[a];
    b.uv_remap_bias[a] = k.uv_remap_bias[a];
  }
  b.hdr_scale = k.hdr_scale;
  b.offset_length = offset_length_m;
  return b;
}

Result<std::unique_ptr<AmbientPass>> AmbientPass::create(VulkanCompute& vk, const std::string& source_dir, ShaderLanguage language,
                                                         const runtime::Volume& volume, const VolumeConstantsBlock& constants,
                                                         size_t max_points) {
  const std::string shaders = source_dir + "/runtime/shaders", wrappers = source_dir + "/bench/common/shaders";
  // Bindings 0-2 textures, 3 constants, 4 points, 5 results in both; HLSL's separate sampler at 6
  // (glslang maps register(tN/bN/sN/uN) to binding N plus the stage's shift for that class).
  // The representation is a compile-time choice of the shader (ambient.glsl, DRTV_SH_L1).
  const std::string define = volume.options().representation == Representation::kShL1 ? "-DDRTV_SH_L1 " : "";
  const std::string arguments =
      language == ShaderLanguage::kGlsl
          ? "-V -S comp -DDRTV_AMBIENT_NO_ENTRY " + define + shaders + "/ambient.glsl " + wrappers + "/ambient_compute.comp"
          : "-D -V -S comp -e computeMain " + define + "-I" + shaders + " --shift-cbuffer-binding 3 --shift-sampler-binding 6 " + wrappers +
                "/ambient_compute.hlsl";
  auto spirv = compileWithGlslang(arguments);
  if (!spirv) return std::unexpected(spirv.error());

  std::unique_ptr<AmbientPass> pass(new AmbientPass(vk));
  int textures[3];
  for (int c = 0; c < 3; ++c) {
    auto t = vk.addTexture3D(volume.size(), volume.texture(c));
    if (!t) return std::unexpected(t.error());
    textures[c] = *t;
  }
  auto ubo = vk.addBuffer(sizeof(VolumeConstantsBlock), BufferKind::kUniform);
  if (!ubo) return std::unexpected(ubo.error());
  std::memcpy(vk.bufferMemory(*ubo).data(), &constants, sizeof constants);
  // Whole workgroups: the entry points do not test the index against a count.
  auto buffers = addPointBuffers(vk, max_points, kWorkgroupSize);
  if (!buffers) return std::unexpected(buffers.error());
  pass->buffers_ = *buffers;

  std::vector<PipelineBinding> bindings;
  const BindingKind texture = language == ShaderLanguage::kGlsl ? BindingKind::kTextureAndSampler : BindingKind::kTexture;
  for (int c = 0; c < 3; ++c) bindings.push_back({uint32_t(c), texture, textures[c]});
  bindings.push_back({3, BindingKind::kUniformBuffer, *ubo});
  bindings.push_back({4, BindingKind::kStorageBuffer, pass->buffers_.points});
  bindings.push_back({5, BindingKind::kStorageBuffer, pass->buffers_.results});
  if (language == ShaderLanguage::kHlsl) bindings.push_back({6, BindingKind::kSampler, -1});
  auto pipeline = vk.addPipeline(*spirv, language == ShaderLanguage::kGlsl ? "main" : "computeMain", bindings);
  if (!pipeline) return std::unexpected(pipeline.error());
  pass->pipeline_ = *pipeline;
  return pass;
}

Result<PointBuffers> addPointBuffers(VulkanCompute& vk, size_t max_points, uint32_t workgroup) {
  PointBuffers b;
  b.max_points = (max_points + workgroup - 1) / workgroup * workgroup;
  auto points = vk.addBuffer(b.max_points * sizeof(AmbientPoint), BufferKind::kDeviceStorage);
  if (!points) return std::unexpected(points.error());
  auto results = vk.addBuffer(b.max_points * sizeof(glm::vec4), BufferKind::kDeviceStorage);
  if (!results) return std::unexpected(results.error());
  auto staging = vk.addBuffer(b.max_points * sizeof(AmbientPoint), BufferKind::kStaging);  // points are the larger
  if (!staging) return std::unexpected(staging.error());
  b.points = *points, b.results = *results, b.staging = *staging;
  return b;
}

Result<std::vector<glm::vec4>> runPoints(VulkanCompute& vk, int pipeline, const PointBuffers& b, uint32_t workgroup,
                                         std::span<const AmbientPoint> points, const char* what, double* seconds) {
  if (points.empty()) return std::vector<glm::vec4>{};
  if (points.size() > b.max_points)
    return fail(std::string(what) + ": " + std::to_string(points.size()) + " points, room for " + std::to_string(b.max_points));
  const std::span<std::byte> staging = vk.bufferMemory(b.staging);
  std::memcpy(staging.data(), points.data(), points.size_bytes());
  // The padding up to a whole workgroup repeats the last point (a finite lookup).
  const size_t groups = (points.size() + workgroup - 1) / workgroup, padded = groups * workgroup;
  for (size_t i = points.size(); i < padded; ++i)
    std::memcpy(staging.data() + i * sizeof(AmbientPoint), &points.back(), sizeof(AmbientPoint));
  if (auto r = vk.copyBuffer(b.staging, b.points, padded * sizeof(AmbientPoint)); !r) return std::unexpected(r.error());
  auto t = vk.dispatch(pipeline, uint32_t(groups));
  if (!t) return std::unexpected(t.error());
  if (seconds) *seconds = *t;
  if (auto r = vk.copyBuffer(b.results, b.staging, padded * sizeof(glm::vec4)); !r) return std::unexpected(r.error());
  std::vector<glm::vec4> out(points.size());
  std::memcpy(out.data(), staging.data(), points.size() * sizeof(glm::vec4));
  return out;
}

Result<std::vector<glm::vec3>> AmbientPass::run(std::span<const AmbientPoint> points, double* seconds) {
  auto r = runPoints(vk_, pipeline_, buffers_, kWorkgroupSize, points, "ambient pass", seconds);
  if (!r) return std::unexpected(r.error());
  std::vector<glm::vec3> ambient;
  ambient.reserve(r->size());
  for (const glm::vec4& v : *r) ambient.push_back(glm::vec3(v));
  return ambient;
}

}  // namespace drtv::testing
