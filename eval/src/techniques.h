// The built-in techniques' registrations, one function per folder under eval/techniques/
// (technique.cpp calls each on first use of the registry).
#pragma once

#include <charconv>
#include <string>
#include <utility>
#include <vector>

#include "drtv/eval/technique.h"

namespace drtv::eval {

using TechniqueRegistration = std::pair<TechniqueInfo, TechniqueFactory>;

// What Technique::describe() returns: the registered name, then the given parameters as
// "name k=v,k=v" (none: the name alone).
inline std::string describeTechnique(const std::string& name, const TechniqueParams& given) {
  std::string s = name;
  char sep = ' ';
  for (const auto& [k, v] : given) s += sep + k + "=" + v, sep = ',';
  return s;
}

// A technique parameter `key`=`v` read as an integer in [lo, hi], or an error naming both.
inline Result<int> intIn(const std::string& key, const std::string& v, int lo, int hi) {
  int x = 0;
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
  if (ec != std::errc() || end != v.data() + v.size() || x < lo || x > hi)
    return fail(key + "=" + v + ": expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return x;
}

// eval/techniques/drtv: Deferred Radiance Transfer Volumes (the talk's), nearest and smooth fills.
std::vector<TechniqueRegistration> drtvTechniques();
// eval/techniques/probe_reference: DRTV's probes with path-traced values, no volume (basis rows).
std::vector<TechniqueRegistration> probeReferenceTechniques();
// eval/techniques/ambient_cube: DRTV's probes with a six-axis ambient cube, baked, relit, a volume (in memory).
std::vector<TechniqueRegistration> ambientCubeTechniques();
// eval/techniques/lpv: cascaded light propagation volumes over ray-cast RSMs (drtv/lpv/lpv.h).
std::vector<TechniqueRegistration> lpvTechniques();
// eval/techniques/sweep: the top-down sweep light grid (seed 001), no bake.
std::vector<TechniqueRegistration> sweepTechniques();

}  // namespace drtv::eval
