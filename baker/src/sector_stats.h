// Private: SectorStats as the sector journal stores it (a typed binary record, read back
// without parsing text) and as the bake report writes it (JSON), from one list of its fields.
#pragma once

#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "drtv/baker/bake.h"

namespace drtv::baker {

// Every field of SectorStats but the key and `resumed`, once, with its report name, in the
// journal record's order. Adding a field here adds it to both (bump kVersion in sector_journal.cpp).
template <class Stats, class F>
void forEachStat(Stats& s, F&& f) {
  f("probes", s.probes);
  f("triangles", s.triangles);
  f("lprt_sources", s.lprt_sources);
  f("bytes", s.bytes);
  f("bytes_without_lprt", s.bytes_without_lprt);
  f("static_candidates", s.placement.static_candidates);
  f("vegetation_candidates", s.placement.vegetation_candidates);
  f("interior_probes", s.placement.interior_probes);
  f("relocated", s.placement.relocated);
  f("dropped_inside", s.placement.dropped_inside);
  f("dropped_gap", s.placement.dropped_gap);
  f("rejected_distance", s.placement.rejected_distance);
  f("thinned_cap", s.placement.thinned_cap);
  f("placement_rays", s.placement.rays);
  f("probe_rays", s.transfer.probe_rays);
  f("surfel_rays", s.transfer.surfel_rays);
  f("lprt_rays", s.transfer.lprt_rays);
  f("sun_rays", s.transfer.sun_rays);
  f("surfels", s.transfer.surfels);
  f("probe_hits_cached", s.transfer.probe_hits_cached);
  f("probe_s", s.transfer.probe_seconds);
  f("surfel_s", s.transfer.surfel_seconds);
  f("lprt_s", s.transfer.lprt_seconds);
  f("sun_s", s.transfer.sun_seconds);
  f("grid_rays", s.grid.rays);
  f("cells_nearest", s.grid.cells_nearest);
  f("cells_farther", s.grid.cells_farther);
  f("cells_inside", s.grid.cells_inside);
  f("cells_unseen", s.grid.cells_unseen);
  f("cells_searched", s.grid.cells_searched);
  f("cells_other_side", s.grid.cells_other_side);
  f("other_rays", s.other_rays);
  f("gather_s", s.gather_s);
  f("build_s", s.build_s);
  f("placement_s", s.placement_s);
  f("transfer_s", s.transfer_s);
  f("grid_s", s.grid_s);
  f("visibility_s", s.visibility_s);
  f("total_s", s.total_s);
}

// 8 bytes a field, little-endian: counts as u64, seconds as IEEE-754 binary64.
inline std::vector<uint8_t> encodeStats(const SectorStats& s) {
  std::vector<uint8_t> out;
  forEachStat(s, [&](const char*, const auto& v) {
    uint64_t bits;
    if constexpr (std::is_floating_point_v<std::decay_t<decltype(v)>>) {
      const double d = double(v);
      std::memcpy(&bits, &d, 8);
    } else {
      bits = uint64_t(v);
    }
    for (int i = 0; i < 8; ++i) out.push_back(uint8_t(bits >> (8 * i)));
  });
  return out;
}

// The stats of a record, or nothing if its size is not the record's (an older journal's).
inline std::optional<SectorStats> decodeStats(std::span<const uint8_t> bytes) {
  SectorStats s;
  size_t n = 0;
  forEachStat(s, [&](const char*, const auto&) { n += 8; });
  if (bytes.size() != n) return std::nullopt;
  size_t at = 0;
  forEachStat(s, [&](const char*, auto& v) {
    uint64_t bits = 0;
    for (int i = 0; i < 8; ++i) bits |= uint64_t(bytes[at + size_t(i)]) << (8 * i);
    at += 8;
    using T = std::decay_t<decltype(v)>;
    if constexpr (std::is_floating_point_v<T>) {
      double d;
      std::memcpy(&d, &bits, 8);
      v = T(d);
    } else {
      v = T(bits);
    }
  });
  return s;
}

inline nlohmann::json toJson(const SectorStats& s) {
  nlohmann::json j = {{"ix", s.key.ix}, {"iy", s.key.iy}};
  forEachStat(s, [&](const char* name, const auto& v) { j[name] = v; });
  return j;
}

}  // namespace drtv::baker
