// render_support.h — private helpers shared by render.cpp, accuracy.cpp and vdb.cpp: the runtime
// options an engine would pick, and small image helpers.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/archive.h"
#include "drtv/formats/error.h"
#include "drtv/formats/sector.h"
#include "drtv/runtime/runtime.h"

namespace drtv::eval::detail {

// Runtime options an engine would pick for an archive with `effects` baked
// (runtime::optionsForEffects), with the fill mode asked for.
inline runtime::RuntimeOptions runtimeOptionsFor(uint32_t effects, bool smooth_fill) {
  runtime::RuntimeOptions o = runtime::optionsForEffects(effects);
  o.volume.fill = smooth_fill ? runtime::FillMode::kSmooth : runtime::FillMode::kNearest;
  return o;
}

// Rec. 709 luminance of linear RGB.
inline double luminance(const glm::vec3& c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

}  // namespace drtv::eval::detail
