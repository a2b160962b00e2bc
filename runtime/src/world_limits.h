// The world positions the runtime looks up, private to drtv::runtime: one definition for the probe
// cache and the occlusion tiles.
#pragma once

namespace drtv::runtime::detail {

// Positions beyond this are treated as outside every sector: floor(x / 64) must fit in int32.
inline constexpr double kMaxWorldM = 1e11;

}  // namespace drtv::runtime::detail
