// probe_cache.cpp — see probe_cache.h for the references [1-3] and the layout. Adding and
// removing sectors, the sources' bookkeeping, packing and the probes' data.
#include "drtv/runtime/probe_cache.h"
#include "drtv/formats/visibility.h"

#include <algorithm>
#include <string>

#include "drtv/runtime/lighting_sh.h"
#include "pack.h"
#include "probe_cache_impl.h"

namespace drtv::runtime {

using namespace detail;

ProbeCache::ProbeCache(ProbeCacheOptions options) : impl_(std::make_unique<Impl>()) {
  DRTV_CHECK(options.max_sectors >= 1 && options.sources_per_light >= 1);
  DRTV_CHECK_LE(options.sources_per_light, 64);  // the weights live in a fixed array of 64
  Impl& m = *impl_;
  m.opt = options;
  const size_t n = size_t(options.max_sectors);
  m.slots.resize(n);
  m.slot_keys.resize(n);
  m.in = AlignedFloats(n * kInputPlanes * kSlotProbes);
  m.out = AlignedFloats(n * kColourPlanes * kSlotProbes);
  m.packed.assign(n * kSlotProbes * 3, 0);
  m.namers.assign(n * kSlotProbes, {});
  m.light_colour.assign(n * kSlotProbes, glm::vec3(0.f));
  m.is_lit.assign(n * kSlotProbes, 0);
}
ProbeCache::~ProbeCache() = default;
ProbeCache::ProbeCache(ProbeCache&&) noexcept = default;
ProbeCache& ProbeCache::operator=(ProbeCache&&) noexcept = default;

Result<void> ProbeCache::addSector(const Sector& sector, SectorBlock keep) {
  Impl& m = *impl_;
  const std::string where = "sector " + toString(sector.key);
  if (m.slotOf(sector.key) >= 0) return fail(where + ": already resident");
  const int n = int(sector.probes.size());
  if (n > kMaxProbesPerSector) return fail(where + ": " + std::to_string(n) + " probes (max 255)");
  for (int i = 0; i < kGridCells; ++i)
    if (sector.grid.cells[i] != kNoProbe && sector.grid.cells[i] >= n)
      return fail(where + ": index grid cell " + std::to_string(i) + " names probe " + std::to_string(sector.grid.cells[i]) +
                  " of " + std::to_string(n));
    else if (sector.grid.cells[i] != kNoProbe && (sector.probes[sector.grid.cells[i]].flags & kProbeLightSource))
      return fail(where + ": index grid cell " + std::to_string(i) + " names probe " + std::to_string(sector.grid.cells[i]) +
                  ", a light source (which no lookup reads)");
  if (!(std::isfinite(sector.grid.z_min_m) && std::isfinite(sector.grid.cell_height_m) && sector.grid.cell_height_m > 0.f))
    return fail(where + ": index grid z range is not finite and positive");
  const size_t sources = sector.lprt.sources.size();
  if (sources > size_t(kMaxLprtSources) || sector.lprt.coeffs.size() != size_t(n) * sources * 12)
    return fail(where + ": LPRT block size does not match its probes and sources");
  for (int i = 0; i < n; ++i)
    if (auto e = validateProbe(sector.probes[i]); !e) return std::unexpected(e.error().context(where + ": probe " + std::to_string(i)));
  const Representation want = m.opt.representation;
  for (int i = 0; i < n; ++i) {
    const Representation got =
        (sector.probes[i].flags & (kProbeSkyMoments | kProbeSkyFit)) ? Representation::kShL1 : Representation::kFc3;
    if (got != want)
      return fail(where + ": probe " + std::to_string(i) + " was baked as " + representationName(got) + ", the runtime reads " +
                  representationName(want) + " (set it up from the archive's manifest)");
  }
  if (want == Representation::kShL1 && sources > 0 && sector.lprt_on_bases)
    return fail(where + ": sh-l1 needs its LPRT block in SH, this one is on the talk's bases");
  if (sector.sun) {
    const size_t K = sector.sun->samples();
    if (want != Representation::kShL1) return fail(where + ": a sun-transfer block is sh-l1's, the runtime reads " + representationName(want));
    if (K > size_t(kMaxSunSamples) || sector.sun->ranges.size() != size_t(n) || sector.sun->coeffs.size() != size_t(n) * K * 12)
      return fail(where + ": sun-transfer block size does not match its probes and samples");
  }
  const size_t covered = coveredProbes(sector);
  const size_t vis_values = sector.visibility ? sector.visibility->values.size() : 0;
  if (vis_values != covered * kVisValuesPerProbe)
    return fail(where + ": visibility block holds " + std::to_string(vis_values) + " values for " +
                std::to_string(covered) + " covered probes (" + std::to_string(kVisValuesPerProbe) + " each)");
  int s = -1;
  for (size_t k = 0; k < m.slots.size(); ++k)
    if (!m.slots[k].used) {
      s = int(k);
      break;
    }
  if (s < 0) return fail(where + ": all " + std::to_string(m.slots.size()) + " resident sector slots are used");

  Slot& sl = m.slots[s];
  sl.reset();
  sl.used = true;
  m.slot_keys[s] = {sector.key, true};
  const bool sh_l1 = m.opt.representation == Representation::kShL1;
  sl.key = sector.key;
  sl.count = n;
  sl.origin = glm::dvec2(sector.key.ix * kSectorSizeM, sector.key.iy * kSectorSizeM);
  sl.z_min = sector.grid.z_min_m;
  sl.cell_h = sector.grid.cell_height_m;
  sl.position.resize(n);
  sl.flags.resize(n);
  sl.interior.resize(n);
  sl.height.resize(n);
  sl.sky_vis.resize(n);
  sl.lo = glm::vec3(std::numeric_limits<float>::max());
  sl.hi = glm::vec3(std::numeric_limits<float>::lowest());
  std::fill_n(m.inPlane(s, 0), size_t(kInputPlanes) * kSlotProbes, 0.f);
  std::fill_n(m.outPlane(s, 0), size_t(kColourPlanes) * kSlotProbes, 0.f);
  std::fill_n(m.packed.begin() + size_t(s) * kSlotProbes * 3, kSlotProbes * 3, 0u);
  for (int i = 0; i < n; ++i) {
    const ProbeData d = unpackProbe(sector.probes[i]);
    sl.position[i] = d.position;
    sl.flags[i] = d.flags;
    sl.interior[i] = d.interior;
    sl.height[i] = d.height_m;
    sl.sky_vis[i] = d.sky_vis;
    if (d.flags & kProbeInterior) sl.designated.push_back(uint8_t(i));
    if (d.flags & kProbeCovered) sl.covered.push_back(uint8_t(i));
    if (d.flags & kProbeLightSource) sl.light_sources.push_back(uint8_t(i));
    sl.lo = glm::min(sl.lo, d.position);
    sl.hi = glm::max(sl.hi, d.position);
    if (sh_l1) {
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 4; ++r)
          for (int k = 0; k < 4; ++k) m.inShL1(s, (c * 4 + r) * 4 + k, i) = kLobe[r] * d.prt[c][r][k];
      if (d.flags & kProbeSkyFit) {
        // e = H a + (Z - H) b (probe.h) in the relight's terms: with the sky continued through the
        // horizon, SkyDirectSH[c][0] = 4 pi Y0 (H + (Z - H) / 3) and SkyDirectSH[c][2] = (4 pi / 5) Y1 (Z - H)
        // (lighting_sh.h), so P0 = a / (4 pi Y0) and P2 = 5 (b - a / 3) / (4 pi Y1).
        for (int r = 0; r < 4; ++r) {
          m.inShL1(s, kTransferPlanes + r, i) = d.sky_fit_h[r] / (4.f * sh::kPi * sh::kY0);
          m.inShL1(s, kTransferPlanes + 4 + r, i) = 5.f * (d.sky_fit_delta[r] - d.sky_fit_h[r] / 3.f) / (4.f * sh::kPi * sh::kY1);
        }
        continue;
      }
      const float p2[4] = {sh::kY0 * d.sky_vis_sh[2], d.sky_moments[0], d.sky_moments[1], d.sky_moments[2]};
      for (int r = 0; r < 4; ++r) {
        m.inShL1(s, kTransferPlanes + r, i) = kLobe[r] * sh::kY0 * d.sky_vis_sh[r];
        m.inShL1(s, kTransferPlanes + 4 + r, i) = kLobe[r] * p2[r];
      }
      continue;
    }
    for (int c = 0; c < 3; ++c)
      for (int b = 0; b < 4; ++b)
        for (int k = 0; k < 4; ++k) m.inPlane(s, (c * 4 + b) * 4 + k)[i] = d.prt[c][b][k];
    for (int b = 0; b < 4; ++b) m.inPlane(s, kTransferPlanes + b)[i] = d.sky_vis[b];
  }
  // Cells that name no probe take the sector's probe nearest to the cell centre, so that the
  // fill never branches (sector.h allows 255 anywhere); not a light source (which stands at its
  // lamp) unless the sector has nothing else.
  const bool only_lights = sl.light_sources.size() == size_t(n);
  for (int z = 0; z < kGridDim; ++z)
    for (int y = 0; y < kGridDim; ++y)
      for (int x = 0; x < kGridDim; ++x) {
        const int cell = IndexGrid::cellIndex(x, y, z);
        uint8_t p = sector.grid.cells[cell];
        if (p == kNoProbe && n > 0) {
          const glm::vec3 c(float((x + 0.5) * kGridCellSizeM), float((y + 0.5) * kGridCellSizeM),
                            sl.z_min + (z + 0.5f) * sl.cell_h);
          float best = std::numeric_limits<float>::max();
          for (int i = 0; i < n; ++i) {
            if ((sl.flags[i] & kProbeLightSource) && !only_lights) continue;
            const glm::vec3 d = sl.position[i] - c;
            const float d2 = glm::dot(d, d);
            if (d2 < best) best = d2, p = uint8_t(i);
          }
        }
        sl.nearest[cell] = p;
      }
  m.fillCells(s);
  if (sources > 0) {
    // Kept as the block came; a source is transposed to planes the first time it is lit
    // (sourcePlanes). Few of a sector's sources ever are, and transposing all of them here was
    // most of addSector's own time in a lit-island fly (perf, docs/runtime.md).
    const int stride = m.stride(s);
    sl.sources = sector.lprt.sources;
    sl.on_bases = sector.lprt_on_bases;
    if (keep == SectorBlock::kBorrow) {
      sl.lprt_coeffs = sector.lprt.coeffs.data();
    } else {
      // Into the capacity the slot kept from the sectors before: a fresh 200 KB block was mapped
      // and faulted in at every lit sector's arrival (perf of the lit-island fly).
      sl.lprt_block.assign(sector.lprt.coeffs.begin(), sector.lprt.coeffs.end());
      sl.lprt_coeffs = sl.lprt_block.data();
    }
    sl.lprt.assign(sources, {});
    sl.lprt_scale.assign(stride, 0.f);
    for (int i = 0; i < n; ++i) sl.lprt_scale[i] = sector.probes[i].lprt_range / kSnorm16Max;
    sl.local = AlignedFloats(size_t(12) * stride);
  }
  if (sector.sun && sh_l1) {
    const SunBlock& sun = *sector.sun;
    const size_t K = sun.samples();
    const int stride = m.stride(s);
    sl.sun_dirs = sun.directions;
    // Dequantised once (as the transfer planes are): 6 x 12 floats a probe, 1.2 MB for 51 sectors;
    // per sample in blocks of 16 probes, as the transfer (kSunBlock).
    sl.sun = AlignedFloats(K * 12 * size_t(stride));  // on cache lines, as the transfer planes
    for (int i = 0; i < n; ++i)
      for (size_t k = 0; k < K; ++k)
        for (int q = 0; q < 12; ++q)
          sl.sun.data[k * 12 * stride + blockOffset(i, q, 12)] = dequantizeSnorm8(sun.coeffs[sun.index(size_t(i), k, q / 4, q % 4)], sun.ranges[size_t(i)]);
  }
  if (sector.visibility) sl.visibility = sector.visibility->values;
  m.sourcesArrived(s);
  return {};
}

bool ProbeCache::removeSector(SectorKey key) {
  Impl& m = *impl_;
  const int s = m.slotOf(key);
  if (s < 0) return false;
  m.sourcesLeaving(s);
  m.slots[s].reset();
  m.slot_keys[s] = {};
  // Light shares on the removed probes are stale: clear them (the next relight recomputes).
  for (int id : m.touched) m.light_colour[id] = glm::vec3(0.f), m.is_lit[id] = 0;
  m.touched.clear();
  return true;
}

int ProbeCache::slotOf(SectorKey key) const { return impl_->slotOf(key); }
int ProbeCache::maxSectors() const { return int(impl_->slots.size()); }
int ProbeCache::sectorCount() const {
  return int(std::count_if(impl_->slots.begin(), impl_->slots.end(), [](const Slot& s) { return s.used; }));
}
int ProbeCache::probeCount() const {
  int n = 0;
  for (const Slot& s : impl_->slots) n += s.used ? s.count : 0;
  return n;
}
std::vector<SectorKey> ProbeCache::keys() const {
  std::vector<SectorKey> k;
  for (const Slot& s : impl_->slots)
    if (s.used) k.push_back(s.key);
  return k;
}

void ProbeCache::Impl::sourcesArrived(int s) {
  Slot& in = slots[s];
  in.source_ids.assign(in.sources.size(), -1);
  in.source_lo = glm::ivec2(std::numeric_limits<int>::max());
  in.source_hi = glm::ivec2(std::numeric_limits<int>::min());
  for (const LprtSource& src : in.sources) {
    in.source_lo = glm::min(in.source_lo, glm::ivec2(src.dx, src.dy));
    in.source_hi = glm::max(in.source_hi, glm::ivec2(src.dx, src.dy));
  }
  if (!in.sources.empty()) {
    // Its sources lie in its own sector and its neighbours: their slots are looked up once.
    int near[3][3];
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) near[dy + 1][dx + 1] = slotOf({in.key.ix + dx, in.key.iy + dy});
    for (size_t j = 0; j < in.sources.size(); ++j) {
      const LprtSource& src = in.sources[j];
      const bool close = src.dx >= -1 && src.dx <= 1 && src.dy >= -1 && src.dy <= 1;
      const int s2 = close ? near[src.dy + 1][src.dx + 1] : slotOf({in.key.ix + src.dx, in.key.iy + src.dy});
      if (s2 < 0 || src.probe >= slots[s2].count) continue;
      in.source_ids[j] = s2 * kSlotProbes + src.probe;
      namers[size_t(in.source_ids[j])].push_back(namer(s, j));
    }
  }
  for (size_t t = 0; t < slots.size(); ++t) {
    Slot& other = slots[t];
    if (!other.used || int(t) == s || other.sources.empty()) continue;
    const glm::ivec2 d(in.key.ix - other.key.ix, in.key.iy - other.key.iy);
    if (glm::any(glm::lessThan(d, other.source_lo)) || glm::any(glm::greaterThan(d, other.source_hi))) continue;
    for (size_t j = 0; j < other.sources.size(); ++j) {
      const LprtSource& src = other.sources[j];
      if (src.dx != d.x || src.dy != d.y || src.probe >= in.count) continue;
      DRTV_CHECK_EQ(other.source_ids[j], -1);  // its sector was not resident
      other.source_ids[j] = s * kSlotProbes + src.probe;
      namers[size_t(other.source_ids[j])].push_back(namer(int(t), j));
    }
  }
}

void ProbeCache::Impl::sourcesLeaving(int s) {
  Slot& out = slots[s];
  for (size_t j = 0; j < out.source_ids.size(); ++j)
    if (int32_t& id = out.source_ids[j]; id >= 0) unname(id, namer(s, j)), id = -1;
  const int lo = s * kSlotProbes, hi = lo + kSlotProbes;
  for (size_t t = 0; t < slots.size(); ++t) {
    Slot& other = slots[t];
    if (!other.used || int(t) == s || other.sources.empty()) continue;
    const glm::ivec2 d(out.key.ix - other.key.ix, out.key.iy - other.key.iy);
    if (glm::any(glm::lessThan(d, other.source_lo)) || glm::any(glm::greaterThan(d, other.source_hi))) continue;
    for (size_t j = 0; j < other.source_ids.size(); ++j)
      if (int32_t& id = other.source_ids[j]; id >= lo && id < hi) unname(id, namer(int(t), j)), id = -1;
  }
  for (int id = lo; id < hi; ++id) DRTV_CHECK(namers[size_t(id)].empty());
}

void ProbeCache::Impl::unname(int32_t id, uint32_t who) {
  std::vector<uint32_t>& v = namers[size_t(id)];
  const auto at = std::find(v.begin(), v.end(), who);
  DRTV_CHECK(at != v.end());
  *at = v.back();
  v.pop_back();
}

std::bitset<kSlotProbes> ProbeCache::packSlot(int s) {
  Impl& m = *impl_;
  const Slot& sl = m.slots[s];
  const float inv = 1.f / m.scale;
  const bool sh_l1 = m.opt.representation == Representation::kShL1;
  uint32_t* out = m.packed.data() + size_t(s) * kSlotProbes * 3;
  std::bitset<kSlotProbes> changed;
  std::array<uint32_t, kSlotProbes> channel;
  for (int c = 0; c < 3; ++c) {
    packPlanes(m.outPlane(s, c * 4 + 0), m.outPlane(s, c * 4 + 1), m.outPlane(s, c * 4 + 2), m.outPlane(s, c * 4 + 3), sl.count, inv,
               sh_l1, channel.data());
    for (int i = 0; i < sl.count; ++i) {
      if (out[i * 3 + c] != channel[size_t(i)]) changed.set(size_t(i));
      out[i * 3 + c] = channel[size_t(i)];
    }
  }
  return changed;
}

void ProbeCache::pack(float hdr_scale) {
  DRTV_CHECK(hdr_scale > 0.f && std::isfinite(hdr_scale));
  Impl& m = *impl_;
  m.scale = hdr_scale;
  const float inv = 1.f / hdr_scale;
  for (int c = 0; c < 3; ++c)
    m.packed_fallback[c] = detail::packTexel(m.opt.representation, m.fallback[0][c], m.fallback[1][c], m.fallback[2][c], m.fallback[3][c], inv);
  for (size_t s = 0; s < m.slots.size(); ++s)
    if (m.slots[s].used) packSlot(int(s));
}

float ProbeCache::packedScale() const { return impl_->scale; }
Representation ProbeCache::representation() const { return impl_->opt.representation; }
void ProbeCache::setFallback(const BasisColours& colours) {
  const bool sh_l1 = impl_->opt.representation == Representation::kShL1;
  for (int b = 0; b < 4; ++b)
    for (int c = 0; c < 3; ++c) {
      const float x = colours[b][c];
      impl_->fallback[b][c] = sh_l1 && b > 0 ? clampSigned(x) : (x > 0.f ? std::min(x, kMaxColour) : 0.f);
    }
}

const BasisColours& ProbeCache::fallback() const { return impl_->fallback; }
const std::array<uint32_t, 3>& ProbeCache::packedFallback() const { return impl_->packed_fallback; }

bool ProbeCache::slotUsed(int s) const { return s >= 0 && s < int(impl_->slots.size()) && impl_->slots[s].used; }

ProbeCache::SlotView ProbeCache::slot(int s) const {
  DRTV_CHECK(slotUsed(s));
  const Slot& sl = impl_->slots[s];
  SlotView v;
  v.key = sl.key;
  v.probe_count = sl.count;
  v.origin_m = sl.origin;
  v.grid_z_min_m = sl.z_min;
  v.grid_cell_height_m = sl.cell_h;
  v.nearest = sl.fill.data();
  v.colour = impl_->outPlane(s, 0);
  v.colour_stride = impl_->stride(s);
  v.packed = impl_->packed.data() + size_t(s) * kSlotProbes * 3;
  return v;
}

BasisColours ProbeCache::colours(ProbeRef p) const {
  DRTV_CHECK(slotUsed(p.slot) && p.index >= 0 && p.index < impl_->slots[p.slot].count);
  BasisColours out;
  for (int b = 0; b < 4; ++b)
    for (int c = 0; c < 3; ++c) out[b][c] = impl_->outPlane(p.slot, c * 4 + b)[p.index];
  return out;
}

glm::dvec3 ProbeCache::worldPosition(ProbeRef p) const {
  DRTV_CHECK(slotUsed(p.slot) && p.index >= 0 && p.index < impl_->slots[p.slot].count);
  const Slot& sl = impl_->slots[p.slot];
  const glm::vec3& q = sl.position[p.index];
  return {sl.origin.x + q.x, sl.origin.y + q.y, q.z};
}
uint16_t ProbeCache::flags(ProbeRef p) const { return impl_->slots.at(p.slot).flags.at(p.index); }
uint16_t ProbeCache::interior(ProbeRef p) const { return impl_->slots.at(p.slot).interior.at(p.index); }
float ProbeCache::heightAboveGround(ProbeRef p) const { return impl_->slots.at(p.slot).height.at(p.index); }
glm::vec4 ProbeCache::skyVisibility(ProbeRef p) const { return impl_->slots.at(p.slot).sky_vis.at(p.index); }

}  // namespace drtv::runtime
