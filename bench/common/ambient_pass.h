// The production ambient shaders (runtime/shaders/ambient.{glsl,hlsl}) as a Vulkan compute pass
// over a list of points, for the shader tests and the shader benchmark. Test code only.
//
// A pass compiles the production file with its compute entry point (bench/common/shaders/
// ambient_compute.{comp,hlsl}: the GLSL one linked as a second compilation unit, the HLSL one
// #including the file), uploads a Volume's three RGBA8 textures and its VolumeConstants (the
// uniform block both shaders declare, std140 / cbuffer packing: 80 bytes, drawn below), and runs
// drtvAmbient(position, normalize(normal)) for each point.
//
// Thread-safety: none (like VulkanCompute).
#pragma once

#include <cstddef>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"
#include "drtv/runtime/volume.h"
#include "vulkan_compute.h"

namespace drtv::testing {

enum class ShaderLanguage { kGlsl, kHlsl };
const char* shaderLanguageName(ShaderLanguage language);  // "GLSL", "HLSL"

// VolumeConstants as both shaders lay it out (std140 for GLSL, cbuffer packing for HLSL give the
// same offsets; HLSL names the padding):
//   offset  0  SnappedCamera (vec3)   12 HdrScale
//          16  UVScale (vec3)         28 OffsetLength
//          32  VolumeWrapOffset       44 (pad)
//          48  UVRemapScale           60 (pad)
//          64  UVRemapBias            76 (pad)
struct VolumeConstantsBlock {
  float snapped_camera[3];
  float hdr_scale;
  float uv_scale[3];
  float offset_length;
  float wrap_offset[3];
  float pad0;
  float uv_remap_scale[3];
  float pad1;
  float uv_remap_bias[3];
  float pad2;
};
static_assert(sizeof(VolumeConstantsBlock) == 80);

// The block for `k` with the sampling offset `offset_length_m` (RuntimeOptions::normal_offset_m).
// SnappedCamera is given in world metres (the engine's origin at the world's).
VolumeConstantsBlock makeConstantsBlock(const runtime::VolumeShaderConstants& k, float offset_length_m);

// One point of the pass, as the compute entry points read it (std430, 32 bytes).
struct AmbientPoint {
  glm::vec4 position{0.f};  // xyz: world metres, w unused
  glm::vec4 normal{0.f};    // xyz: surface normal (normalised by the shader), w unused
};
static_assert(sizeof(AmbientPoint) == 32);

// A pass's point buffers (points in, one vec4 per point out, in device memory, copied through one
// staging buffer) for up to max_points points rounded up to whole workgroups of `workgroup`.
struct PointBuffers {
  int points = -1, results = -1, staging = -1;
  size_t max_points = 0;
};
Result<PointBuffers> addPointBuffers(VulkanCompute& vk, size_t max_points, uint32_t workgroup);
// Uploads `points` (the padding up to a whole workgroup repeats the last one), dispatches
// `pipeline` and reads the results back; the dispatch's device time goes to `seconds` if given.
// Error if there are more points than the buffers hold (`what` names the pass).
Result<std::vector<glm::vec4>> runPoints(VulkanCompute& vk, int pipeline, const PointBuffers& buffers, uint32_t workgroup,
                                         std::span<const AmbientPoint> points, const char* what, double* seconds = nullptr);

class AmbientPass {
 public:
  static constexpr uint32_t kWorkgroupSize = 64;  // local_size_x / numthreads of both entry points

  // Compiles `language`'s shader (sources under `source_dir`, the checkout), uploads the textures
  // of `volume` and `constants`, and sizes the point buffers for up to `max_points` points.
  // Errors: glslang's messages, Vulkan failures.
  static Result<std::unique_ptr<AmbientPass>> create(VulkanCompute& vk, const std::string& source_dir, ShaderLanguage language,
                                                     const runtime::Volume& volume, const VolumeConstantsBlock& constants,
                                                     size_t max_points);

  // Runs the pass over `points` (at most max_points) and returns the ambient of each. The device
  // time of the dispatch (VulkanCompute::dispatch) goes to `seconds` if given.
  Result<std::vector<glm::vec3>> run(std::span<const AmbientPoint> points, double* seconds = nullptr);

 private:
  AmbientPass(VulkanCompute& vk) : vk_(vk) {}
  VulkanCompute& vk_;
  int pipeline_ = -1;
  PointBuffers buffers_;
};

}  // namespace drtv::testing
