// ProbeCache's state (probe_cache.h), shared by the files that make it: the slots, their planes,
// the sources' bookkeeping and the lights' shares. Private to drtv::runtime.
//   probe_cache.cpp         adding and removing sectors, the sources' bookkeeping, packing
//   probe_cache_lights.cpp  the lights' shares among the sources (distributeLights)
//   probe_cache_relight.cpp relighting (relight_kernels.h: the loops over the planes)
//   probe_cache_lookup.cpp  the cells each probe fills, and finding a position's probe
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <new>
#include <vector>

#include "drtv/formats/error.h"
#include "drtv/runtime/probe_cache.h"
#include "relight_kernels.h"
#include "world_limits.h"

namespace drtv::runtime {
namespace detail {

// 64-byte aligned float storage, so that the relight loops start on cache lines.
struct AlignedFloats {
  float* data = nullptr;
  size_t size = 0;
  AlignedFloats() = default;
  explicit AlignedFloats(size_t n) : data(static_cast<float*>(::operator new[](n * sizeof(float), std::align_val_t(64)))), size(n) {
    std::memset(data, 0, n * sizeof(float));
  }
  AlignedFloats(AlignedFloats&& o) noexcept : data(o.data), size(o.size) { o.data = nullptr; o.size = 0; }
  AlignedFloats& operator=(AlignedFloats&& o) noexcept {
    std::swap(data, o.data);
    std::swap(size, o.size);
    return *this;
  }
  ~AlignedFloats() {
    if (data) ::operator delete[](data, std::align_val_t(64));
  }
};

// A source that carried light in a slot's relight, and how much (what relightChangedLights compares).
struct LitSource {
  size_t j;  // index into the slot's LPRT sources
  glm::vec3 colour;
  friend bool operator==(const LitSource&, const LitSource&) = default;
};

struct Slot {
  bool used = false;
  bool relit = false;             // relit since it was added
  std::vector<LitSource> lit;     // the lit sources of its last relight, in source order
  SectorKey key{};
  int count = 0;
  glm::dvec2 origin{0.0};
  float z_min = 0.f, cell_h = 1.f;
  std::array<uint8_t, kGridCells> nearest{};
  // What the volume fills each cell's texels from: `nearest`, except that a cell whose centre lies
  // in an interior volume takes the nearest cell outside every one at its height (fillCells): the room's
  // own points read its designated probe, so its texels only lend light to the points outside its
  // walls and roof, which the trilinear filter reaches across them (issue 16's roof leak).
  std::array<uint8_t, kGridCells> fill{};
  // Per probe, the bounds of the cells `nearest` names it in: x0, y0, z0, x1, y1, z1 (inclusive;
  // x0 > x1 when none), so that cellsNaming is a union over the changed probes.
  std::vector<std::array<uint8_t, 6>> cell_bounds;
  std::vector<glm::vec3> position;  // sector-relative x, y; world z
  std::vector<uint16_t> flags, interior;
  std::vector<float> height;
  std::vector<glm::vec4> sky_vis;
  glm::vec3 lo{0.f}, hi{0.f};       // bounding box of `position`
  std::vector<uint8_t> designated;  // probes flagged kProbeInterior (few: one per interior)
  // The fine level (probe_cache.h fineLookup): the probes flagged kProbeCovered, in probe order,
  // and their visibility maps (visibility.h), kVisValuesPerProbe each in the same order.
  std::vector<uint8_t> covered;
  std::vector<uint8_t> visibility;
  // The probes flagged kProbeLightSource (a baked light's own LPRT source), in probe order.
  std::vector<uint8_t> light_sources;
  // LPRT [2]
  std::vector<LprtSource> sources;
  // The local lights' term of the colours (the last sum of probe_cache.h's formula, in the colour
  // planes' units: lobes applied), of the sources and shares in `lit`, valid when `local_of_lit`.
  // [channel * 4 + b][probe], planes of the slot stride (48 bytes a probe; only slots with LPRT).
  // The sky and sun change with the hour, the lights do not: an hour's relight adds this to the
  // sky's terms and re-sums it only where the lit sources changed (relightSlot).
  AlignedFloats local;
  bool local_of_lit = false;
  std::vector<int16_t> lprt_block;  // the sector's block, when copied (SectorBlock::kCopy)
  const int16_t* lprt_coeffs = nullptr;  // the block: [probe][source][channel * 4 + k], lprt_block's or the sector's
  // Per source, once it has been lit: [channel * 4 + k][probe], planes of the slot stride (empty
  // until then; sourcePlanes).
  std::vector<std::vector<int16_t>> lprt;
  std::vector<float> lprt_scale;    // lprt_range / 32767 per probe, padded to the stride with 0
  bool on_bases = true;
  std::vector<int32_t> source_ids;  // global probe id (slot * kSlotProbes + index) or -1
  glm::ivec2 source_lo{0}, source_hi{-1};  // the range of its sources' sector offsets (dx, dy)
  // Sun transfer (sector.h SunBlock)
  std::vector<glm::vec3> sun_dirs;  // its samples; empty = none
  AlignedFloats sun;                // [sample][channel * 4 + i][probe], dequantised, planes of the slot stride
  float max_colour = 0.f;

  // Empty again for the next sector, keeping the LPRT block's capacity: a fresh ~200 KB block
  // was mapped (page faults) at every lit arrival (addSector).
  void reset() {
    std::vector<int16_t> block = std::move(lprt_block);
    block.clear();
    *this = Slot{};
    lprt_block = std::move(block);
  }
};

}  // namespace detail

struct ProbeCache::Impl {
  using AlignedFloats = detail::AlignedFloats;
  using LitSource = detail::LitSource;
  using Slot = detail::Slot;

  ProbeCacheOptions opt;
  std::vector<Slot> slots;
  AlignedFloats in;              // [slot][kInputPlanes][kSlotProbes]
  AlignedFloats out;             // [slot][kColourPlanes][kSlotProbes]
  std::vector<uint32_t> packed;  // [slot][kSlotProbes][3]
  // [global probe id]: the resident sources naming it, as slot << 16 | source index
  // (sourcesArrived, sourcesLeaving): a probe is a source when its list is not empty, and the lit
  // sources of every slot come from the few lit probes (litSourcesOfAll) instead of a test of
  // every source of every slot.
  std::vector<std::vector<uint32_t>> namers;
  std::vector<glm::vec3> light_colour;  // [global probe id]
  std::vector<int> touched;             // ids with non-zero light_colour
  // [global probe id]: light_colour[id] != 0. litSources tests every source of every slot at each
  // relight; 12-byte colours there missed the cache at most of them (perf of the lit-island fly).
  std::vector<uint8_t> is_lit;
  // The last sun-transfer weights (every sector of a world has the same samples: one
  // sunTransferWeights per relight, not per sector).
  std::vector<glm::vec3> sun_dirs_seen;
  glm::vec3 sun_seen{NAN};
  std::array<float, kMaxSunSamples> sun_w_seen{};
  float scale = 1.f;
  BasisColours fallback{};
  std::array<uint32_t, 3> packed_fallback{};

  // A slot's planes are packed at a stride of its probe count rounded up to 16 floats (one
  // 64-byte line), so relighting a slot streams one contiguous block.
  int stride(int s) const { return std::max(16, (slots[s].count + 15) & ~15); }
  float* inPlane(int s, int p) { return in.data + size_t(s) * kInputPlanes * kSlotProbes + size_t(p) * stride(s); }
  // sh-l1's input value of plane p for probe i, in its blocks of 16 probes (kShL1Block).
  float& inShL1(int s, int p, int i) {
    return in.data[size_t(s) * kInputPlanes * kSlotProbes + detail::blockOffset(i, p, kInputPlanes)];
  }
  float* outPlane(int s, int p) { return out.data + size_t(s) * kColourPlanes * kSlotProbes + size_t(p) * stride(s); }
  const float* outPlane(int s, int p) const {
    return out.data + size_t(s) * kColourPlanes * kSlotProbes + size_t(p) * stride(s);
  }

  // The used slots' keys side by side (a Slot is 4.5 KB: looking keys up in the slots touched a
  // line per slot, and the look-ups of distribute, a few per light, were most of its time).
  struct SlotKey {
    SectorKey key{};
    bool used = false;
  };
  std::vector<SlotKey> slot_keys;
  int slotOf(SectorKey key) const {
    for (size_t s = 0; s < slot_keys.size(); ++s)
      if (slot_keys[s].used && slot_keys[s].key == key) return int(s);
    return -1;
  }
  // The resident slot holding world position `pos` with probes in it, or -1 (not resident, no
  // probes, `pos` not finite or beyond the world).
  int slotWithProbes(const glm::dvec3& pos) const {
    if (!(std::fabs(pos.x) < detail::kMaxWorldM && std::fabs(pos.y) < detail::kMaxWorldM && std::isfinite(pos.z))) return -1;
    const int s = slotOf(sectorAt(pos.x, pos.y));
    return s >= 0 && slots[s].count > 0 ? s : -1;
  }

  // The probe the index grid of resident slot `s` names for world position `pos` (cell z clamped
  // into the grid; 255 resolved to the sector's nearest probe). Precondition: the slot has probes.
  int namedProbe(int s, const glm::dvec3& pos) const { return slots[s].nearest[cellAt(s, pos)]; }
  // The probe the volume's nearest fill takes there (Slot::fill: interiors' cells remapped).
  int filledProbe(int s, const glm::dvec3& pos) const { return slots[s].fill[cellAt(s, pos)]; }
  // The index cell of slot s holding `pos` (z clamped into the grid).
  size_t cellAt(int s, const glm::dvec3& pos) const {
    const Slot& sl = slots[s];
    auto cell = [](double v) { return int(std::clamp(std::floor(v), 0.0, double(kGridDim - 1))); };
    const int x = cell((pos.x - sl.origin.x) / kGridCellSizeM);
    const int y = cell((pos.y - sl.origin.y) / kGridCellSizeM);
    const int z = cell((pos.z - sl.z_min) / sl.cell_h);
    return size_t(IndexGrid::cellIndex(x, y, z));
  }

  // Source resolution, incremental: a slot's source_ids name the resident probes its sources are,
  // and namers lists, per global probe id, the resident sources that name it. Recomputing all
  // of it at every addSector and removeSector (51 slots x 128 sources) was a third of a lit
  // sector's addSector in `drtv fly` over the lit island (perf, docs/runtime.md); an arrival or a
  // departure touches only its own sources and those of the slots whose sources reach it.

  // Slot s arrived (its fields set): resolves its own sources, and the unresolved sources of
  // resident slots that name probes in its sector.
  void sourcesArrived(int s);

  // Slot s is leaving (its fields still set): its sources, and the sources of other slots that
  // named its probes, no longer count.
  void sourcesLeaving(int s);
  static uint32_t namer(int slot, size_t j) { return uint32_t(slot) << 16 | uint32_t(j); }
  void unname(int32_t id, uint32_t who);

  // litSources of every slot at once: lit[s] for each slot s (cleared first), from the lit probes
  // and the sources naming them, in source order. The same lists as litSources slot by slot.
  void litSourcesOfAll(const RelightInput& li, std::vector<std::vector<LitSource>>& lit) const;

  // Interior volumes' boxes (world metres): the cells whose centres they hold fill from outside.
  std::vector<std::pair<glm::dvec3, glm::dvec3>> interior_boxes;

  // Slot s's fill cells and the bounds of the cells each probe fills (see Slot::fill).
  void fillCells(int s);

  uint64_t slot_relights = 0;  // relightSlot calls (slotRelightCount)
  uint64_t local_sums = 0;     // sumLocalLights calls (localSumCount)

  std::vector<LightShare> distribute(std::span<const PointLight> lights) const;

  // The bake lit source p with a unit point light at the probe, height_m above the surface below
  // it; a light hung H above that surface lights it less, and over a wider area. The share is
  // scaled by meanDiskIrradiance(H) / meanDiskIrradiance(h): the irradiance each puts on the disk
  // of radius kLightFootprintM (the index cell) under it (probe_cache.h, "Local lights"). 1 for a
  // light at the probe's own height above that surface or lower.
  double footprintFactor(double light_z, const ProbeRef& p) const;
  void setLights(std::span<const PointLight> lights);
  // The sources of slot `s` that the current light shares light, in source order (all of a
  // slot's dependence on the lights: relightSlot reads nothing else of them).
  // From the lit probes and the sources naming them, as litSourcesOfAll (one way to find them).
  void litSources(int s, const RelightInput& li, std::vector<LitSource>& lit) const;
  // `lit`: the slot's lit sources when the caller has them (litSourcesOfAll), else found here.
  void relightSlot(int s, const RelightInput& in, const std::vector<LitSource>* lit = nullptr);
  // Sums the local lights' term of slot `s` (Slot::local) from its lit sources `lit`, in their order.
  void sumLocalLights(int s, std::span<const LitSource> lit);
  // Source j's 12 planes in slot s, transposed from the block the first time they are asked for,
  // so that a lit source is 12 streams over the probes (padding lanes 0). A write inside the
  // relight, safe because every relight (relightAll, relightChangedLights, relightSector) is a
  // non-const member that walks the slots on the calling thread, and ProbeCache has one writer
  // (probe_cache.h); no const member reads lprt. A relight split over threads by slot would stay
  // safe (a slot's planes are its own); one split within a slot would not.
  const int16_t* sourcePlanes(int s, size_t j);
};

}  // namespace drtv::runtime
