// The placement journal's record (placement_record.h). Moved from bake.cpp unchanged.
#include "placement_record.h"

#include <bit>
#include <cmath>
#include <cstring>

#include "drtv/formats/sector.h"

namespace drtv::baker::detail {
namespace {

// A placement journal record's payload (little-endian, like the sector records):
//   u32 probe count n, u64 x 9 PlacementStats (in declaration order), f64 seconds,
//   then n x { f32 x, y, z; u16 flags; u16 interior } — positions bit for bit, so that a resumed
//   placement gives the same LPRT source positions as a fresh one.
static_assert(std::endian::native == std::endian::little, "journal records are little-endian");
constexpr size_t kPlacementHeaderBytes = 4 + 9 * 8 + 8;
constexpr size_t kPlacedProbeBytes = 16;

template <class T>
void put(std::vector<uint8_t>& out, T v) {
  const size_t at = out.size();
  out.resize(at + sizeof v);
  std::memcpy(out.data() + at, &v, sizeof v);
}
template <class T>
T take(const uint8_t*& p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  p += sizeof v;
  return v;
}

}  // namespace

std::vector<uint8_t> encodePlacement(const SectorPlacement& p) {
  std::vector<uint8_t> out;
  out.reserve(kPlacementHeaderBytes + p.probes.size() * kPlacedProbeBytes);
  put(out, uint32_t(p.probes.size()));
  const PlacementStats& s = p.stats;
  for (uint64_t v : {uint64_t(s.static_candidates), uint64_t(s.vegetation_candidates), uint64_t(s.interior_probes),
                     uint64_t(s.relocated), uint64_t(s.dropped_inside), uint64_t(s.dropped_gap), uint64_t(s.rejected_distance),
                     uint64_t(s.thinned_cap), s.rays})
    put(out, v);
  put(out, p.seconds);
  for (const PlacedProbe& q : p.probes) {
    put(out, q.position.x);
    put(out, q.position.y);
    put(out, q.position.z);
    put(out, q.flags);
    put(out, q.interior);
  }
  return out;
}

Result<SectorPlacement> decodePlacement(std::span<const uint8_t> bytes, const std::string& where) {
  if (bytes.size() < kPlacementHeaderBytes) return fail(where + ": placement record of " + std::to_string(bytes.size()) + " bytes is truncated");
  const uint8_t* p = bytes.data();
  const uint32_t n = take<uint32_t>(p);
  if (n > uint32_t(kMaxProbesPerSector) || bytes.size() != kPlacementHeaderBytes + size_t(n) * kPlacedProbeBytes)
    return fail(where + ": placement record of " + std::to_string(bytes.size()) + " bytes does not hold " + std::to_string(n) + " probes");
  SectorPlacement out;
  PlacementStats& s = out.stats;
  for (size_t* f : {&s.static_candidates, &s.vegetation_candidates, &s.interior_probes, &s.relocated, &s.dropped_inside,
                    &s.dropped_gap, &s.rejected_distance, &s.thinned_cap})
    *f = size_t(take<uint64_t>(p));
  s.rays = take<uint64_t>(p);
  out.seconds = take<double>(p);
  out.probes.resize(n);
  for (PlacedProbe& q : out.probes) {
    q.position.x = take<float>(p);
    q.position.y = take<float>(p);
    q.position.z = take<float>(p);
    q.flags = take<uint16_t>(p);
    q.interior = take<uint16_t>(p);
    if (!std::isfinite(q.position.x) || !std::isfinite(q.position.y) || !std::isfinite(q.position.z))
      return fail(where + ": placement record holds a non-finite probe position");
  }
  return out;
}

}  // namespace drtv::baker::detail
