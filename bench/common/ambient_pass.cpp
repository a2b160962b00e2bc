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
  // Whole workgroups: the entry points do not test the index against a count. Points and results
  // live in device memory, copied through one staging buffer (points are the larger).
  pass->max_points_ = (max_points + kWorkgroupSize - 1) / kWorkgroupSize * kWorkgroupSize;
  auto points = vk.addBuffer(pass->max_points_ * sizeof(AmbientPoint), BufferKind::kDeviceStorage);
  if (!points) return std::unexpected(points.error());
  auto results = vk.addBuffer(pass->max_points_ * sizeof(glm::vec4), BufferKind::kDeviceStorage);
  if (!results) return std::unexpected(results.error());
  auto staging = vk.addBuffer(pass->max_points_ * sizeof(AmbientPoint), BufferKind::kStaging);
  if (!staging) return std::unexpected(staging.error());
  pass->points_ = *points;
  pass->results_ = *results;
  pass->staging_ = *staging;

  std::vector<PipelineBinding> bindings;
  const BindingKind texture = language == ShaderLanguage::kGlsl ? BindingKind::kTextureAndSampler : BindingKind::kTexture;
  for (int c = 0; c < 3; ++c) bindings.push_back({uint32_t(c), texture, textures[c]});
  bindings.push_back({3, BindingKind::kUniformBuffer, *ubo});
  bindings.push_back({4, BindingKind::kStorageBuffer, *points});
  bindings.push_back({5, BindingKind::kStorageBuffer, *results});
  if (language == ShaderLanguage::kHlsl) bindings.push_back({6, BindingKind::kSampler, -1});
  auto pipeline = vk.addPipeline(*spirv, language == ShaderLanguage::kGlsl ? "main" : "computeMain", bindings);
  if (!pipeline) return std::unexpected(pipeline.error());
  pass->pipeline_ = *pipeline;
  return pass;
}

Result<std::vector<glm::vec3>> AmbientPass::run(std::span<const AmbientPoint> points, double* seconds) {
  if (points.empty()) return std::vector<glm::vec3>{};
  if (points.size() > max_points_) return fail("ambient pass: " + std::to_string(points.size()) + " points, room for " + std::to_string(max_points_));
  const std::span<std::byte> staging = vk_.bufferMemory(staging_);
  std::memcpy(staging.data(), points.data(), points.size_bytes());
  // The padding up to a whole workgroup repeats the last point (a finite lookup).
  const size_t groups = (points.size() + kWorkgroupSize - 1) / kWorkgroupSize, padded = groups * kWorkgroupSize;
  for (size_t i = points.size(); i < padded; ++i)
    std::memcpy(staging.data() + i * sizeof(AmbientPoint), &points.back(), sizeof(AmbientPoint));
  if (auto r = vk_.copyBuffer(staging_, points_, padded * sizeof(AmbientPoint)); !r) return std::unexpected(r.error());
  auto t = vk_.dispatch(pipeline_, uint32_t(groups));
  if (!t) return std::unexpected(t.error());
  if (seconds) *seconds = *t;
  if (auto r = vk_.copyBuffer(results_, staging_, padded * sizeof(glm::vec4)); !r) return std::unexpected(r.error());
  const std::span<const std::byte> out = staging;
  std::vector<glm::vec3> ambient(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    glm::vec4 r;
    std::memcpy(&r, out.data() + i * sizeof(glm::vec4), sizeof r);
    ambient[i] = glm::vec3(r);
  }
  return ambient;
}

}  // namespace drtv::testing
