// The production fine-level shaders (runtime/shaders/fine.{glsl,hlsl}) as a Vulkan compute pass
// over a list of points, for the shader tests. Test code only.
//
// A pass compiles the production file with its compute entry point (bench/common/shaders/
// fine_compute.{comp,hlsl}: the GLSL one linked as a second compilation unit, the HLSL one
// #including the file; bindings 0 points, 1 results, 2 the constants, 3-5 the probes, their maps
// and the cells), uploads a packed level (runtime/fine_shader.h) and runs drtvFine(position,
// normalize(normal)) for each point.
//
// Thread-safety: none (like VulkanCompute).
#pragma once

#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "ambient_pass.h"
#include "drtv/formats/error.h"
#include "drtv/formats/representation.h"
#include "drtv/runtime/fine_shader.h"
#include "vulkan_compute.h"

namespace drtv::testing {

class FinePass {
 public:
  static constexpr uint32_t kWorkgroupSize = 64;  // local_size_x / numthreads of both entry points

  // Compiles `language`'s shader for `representation` (sources under `source_dir`, the checkout),
  // uploads `level` and sizes the point buffers for up to `max_points` points. Errors: glslang's
  // messages, Vulkan failures.
  static Result<std::unique_ptr<FinePass>> create(VulkanCompute& vk, const std::string& source_dir, ShaderLanguage language,
                                                  Representation representation, const runtime::FineShaderData& level,
                                                  size_t max_points);

  // Runs the pass over `points` (at most max_points, AmbientPass's layout): per point the shaded
  // colours (xyz) and the weight (w).
  Result<std::vector<glm::vec4>> run(std::span<const AmbientPoint> points);

 private:
  FinePass(VulkanCompute& vk) : vk_(vk) {}
  VulkanCompute& vk_;
  int pipeline_ = -1;
  PointBuffers buffers_;
};

}  // namespace drtv::testing
