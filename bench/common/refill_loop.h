// The full volume refill that drtv_runtime_bench and drtv_limit_bench time: a relit, packed cache
// filled into a volume at one origin, again and again. Benchmarks only (Google Benchmark).
#pragma once

#include <benchmark/benchmark.h>

#include <cstdint>

#include "drtv/runtime/probe_cache.h"
#include "drtv/runtime/volume.h"

namespace drtv::testing {

inline void timeFullRefill(benchmark::State& state, const runtime::ProbeCache& cache, const runtime::VolumeOptions& o) {
  runtime::Volume v(o);
  const glm::ivec3 origin = v.originFor({10.0, -20.0, 12.0});
  for (auto _ : state) {
    v.rebuild(origin, cache);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * int64_t(v.period().x) * v.period().y * v.period().z);
}

}  // namespace drtv::testing
