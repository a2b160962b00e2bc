// Wall-clock timing of bake stages (reports and benchmarks), shared by the baker's sources.
#pragma once

#include <chrono>

namespace drtv::baker::detail {

using Clock = std::chrono::steady_clock;
// Seconds since `t0`.
inline double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

}  // namespace drtv::baker::detail
