// A small Vulkan compute harness that runs drtv's shaders in the tests and the shader benchmark
// (the vulkan.h C API, no wrapper library). Test code only: drtv::runtime never links Vulkan.
//
// It holds one instance, one device (a GPU if the loader offers one, else a CPU device such as
// lavapipe, Mesa's LLVM-based Vulkan driver, which is what runs on machines without a GPU) and
// just what an ambient pass needs: 3D RGBA8 textures, one trilinear clamp-to-edge sampler,
// uniform, staging and device-local storage buffers, compute pipelines over descriptor set 0,
// and a dispatch timed with timestamp queries.
//
// Errors (no device, a failing driver call) come back as Error values naming the call and its
// VkResult, so that a test fails with the driver's words instead of crashing.
//
// Thread-safety: none; one thread uses a harness. Objects live until the harness is destroyed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"

namespace drtv::testing {

// How a pipeline sees one resource of descriptor set 0.
enum class BindingKind {
  kTextureAndSampler,  // combined image sampler (GLSL's sampler3D) with the harness's sampler
  kTexture,            // sampled image alone (HLSL's Texture3D)
  kSampler,            // the harness's sampler alone (HLSL's SamplerState)
  kUniformBuffer,      // uniform block / cbuffer
  kStorageBuffer,      // buffer block / (RW)StructuredBuffer
};

enum class BufferKind {
  kUniform,        // host-visible, coherent, mapped: a uniform block written by the host
  kStaging,        // host-visible, coherent, mapped: the host's side of copies
  kDeviceStorage,  // device-local storage buffer, filled and read back through kStaging copies
                   // (on a discrete GPU, a shader reading host memory would time the bus)
};

struct PipelineBinding {
  uint32_t binding = 0;  // the shader's binding number in set 0
  BindingKind kind = BindingKind::kUniformBuffer;
  int resource = -1;     // texture index (kTexture*) or buffer index (k*Buffer); unused for kSampler
};

class VulkanCompute {
 public:
  // Creates an instance and a device with a compute queue. Prefers a discrete, then an integrated
  // GPU, then anything else (a CPU driver). Error if the loader finds no device.
  static Result<std::unique_ptr<VulkanCompute>> create();
  ~VulkanCompute();
  VulkanCompute(const VulkanCompute&) = delete;
  VulkanCompute& operator=(const VulkanCompute&) = delete;

  // e.g. "llvmpipe (LLVM 15.0.6, 256 bits) [cpu, Mesa 22.3.6]".
  const std::string& deviceDescription() const { return description_; }
  bool isCpuDevice() const { return is_cpu_; }
  // The sampler's sub-texel precision (bits of the fractional filter weights; lavapipe: 8).
  uint32_t subTexelPrecisionBits() const { return sub_texel_bits_; }

  // Uploads a size.x x size.y x size.z texture of VK_FORMAT_R8G8B8A8_UNORM texels (texel (x, y, z)
  // at element x + size.x (y + size.y z); R in the low byte). Returns its index.
  Result<int> addTexture3D(glm::ivec3 size, std::span<const uint32_t> texels);
  // A buffer of `bytes` (kUniform and kStaging zeroed). Returns its index.
  Result<int> addBuffer(size_t bytes, BufferKind kind);
  // A host-visible buffer's mapped memory (valid for the harness's lifetime); empty for
  // kDeviceStorage. Write before, read after a dispatch or a copy.
  std::span<std::byte> bufferMemory(int buffer) const;
  // Copies the first `bytes` of buffer `src` to `dst` (kStaging <-> kDeviceStorage), and waits.
  Result<void> copyBuffer(int src, int dst, size_t bytes);

  // A compute pipeline from SPIR-V words with entry point `entry` and descriptor set 0 as
  // `bindings` (written once, here). Returns its index.
  Result<int> addPipeline(std::span<const uint32_t> spirv, const std::string& entry, const std::vector<PipelineBinding>& bindings);

  // Records `groups_x` workgroups of `pipeline`, submits and waits. Returns the device time
  // between timestamps around the dispatch in seconds (the host's wall time of submit + wait when
  // the queue has no timestamps).
  Result<double> dispatch(int pipeline, uint32_t groups_x);

 private:
  struct Impl;
  explicit VulkanCompute(std::unique_ptr<Impl> impl);

  std::unique_ptr<Impl> impl_;
  std::string description_;
  bool is_cpu_ = false;
  uint32_t sub_texel_bits_ = 0;
};

// Compiles a shader with glslangValidator (Debian's glslang-tools) to SPIR-V: `arguments` are
// passed as given (stage, entry point, defines, input files); the output goes to a temporary file
// that is read back and removed. Error: glslang's own messages.
Result<std::vector<uint32_t>> compileWithGlslang(const std::string& arguments);

}  // namespace drtv::testing
