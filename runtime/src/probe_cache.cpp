// probe_cache.cpp — see probe_cache.h for the references [1-3] and the layout.
#include "drtv/runtime/probe_cache.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <new>

#include "drtv/runtime/lighting_sh.h"
#include "pack.h"
#include "simd_clones.h"

namespace drtv::runtime {
namespace {

// Positions beyond this are treated as outside every sector: floor(x / 64) must fit in int32.
constexpr double kMaxWorldM = 1e11;

// The radius of the patch over which a light's falloff is matched to its source's
// (footprintFactor): the index grid's 4 m cell, the patch of surface a receiver finds its probe
// for. Chosen among 0 (the peak under the light), 2, 4, 8 m and none on two scenes against the
// path tracer: a lamp 6 m over open ground (tests/reference/local_lights_test.cpp: summed error
// 119 % none, 39 % at 8 m, 43 % at 4 m, 72 % at 2 m) and the Cornell world, whose ceiling lights
// land on sources 1.5 m over its blocks (local_lights 38.7 % none, 21.0 % at 8 m, 15.8 % at 4 m,
// 14.8 % at 2 m; docs/runtime.md, "Local lights"). 4 m is within 4 points of the best on both.
constexpr double kLightFootprintM = kGridCellSizeM;
// A source's height over its surface is taken as at least this (a probe's clearance, placement.h).
constexpr double kMinSourceHeightM = 0.25;

// The mean irradiance of a unit point light (1 per sr) at height z over the disk of radius
// kLightFootprintM under it: the flux 2 pi (1 - z / sqrt(z^2 + r^2)) through the disk over its area.
double meanDiskIrradiance(double z) {
  constexpr double r2 = kLightFootprintM * kLightFootprintM;
  return 2.0 * (1.0 - z / std::sqrt(z * z + r2)) / r2;
}

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

// The hot loops are compiled for AVX-512 and AVX2 as well as the baseline, and picked at load
// time (DRTV_SIMD_CLONES, simd_clones.h): the relight streams 52 planes and is SIMD-bound.

// Ringing is clamped at the end of a probe's sum, and only there (DESIGN.md): negative and NaN
// (inf - inf) become 0, and colours stop at kMaxColour. Clamped colours are >= 0, so their bit
// patterns order like the floats: the running maximum is an integer max, which vectorises.
// (Written as two selects so that GCC turns them into vector max/min: see relightPlanes.)
inline float clampColour(float x) {
  const float y = x > 0.f ? x : 0.f;
  return y < kMaxColour ? y : kMaxColour;
}

// The bit pattern of the largest |value| over the 12 colour planes (n values each) once clamped:
// with the sign bit cleared, floats order as their bit patterns. A reduction after the planes are
// written, not a running maximum inside their loops: GCC kept that one in memory, and each loop
// then waited on its own store (fc3's relight took 1.18x as long).
[[gnu::always_inline]] inline int32_t maxMagnitudeBits(const float* out, int n, int stride) {
  int32_t m = 0;
  for (int p = 0; p < kColourPlanes; ++p) {
    const float* __restrict o = out + p * stride;
    for (int k = 0; k < n; ++k) m = std::max(m, std::bit_cast<int32_t>(o[k]) & 0x7fffffff);
  }
  return m;
}

// colour[c][b][i] = dot(L[c], T[c][b][i]) + direct[c][b] v[b][i] (+ local[c][b][i], the local
// lights' term, unless `local` is null) for i < n, clamped. Returns the bit pattern of the largest
// clamped value.
DRTV_SIMD_CLONES int32_t relightPlanes(const float* in, float* out, int n, int stride, const float (&lc)[3][4],
                                      const float (&direct)[3][4], const float* local) {
  for (int c = 0; c < 3; ++c)
    for (int b = 0; b < 4; ++b) {
      const float* __restrict t0 = in + ((c * 4 + b) * 4 + 0) * stride;
      const float* __restrict t1 = t0 + stride;
      const float* __restrict t2 = t1 + stride;
      const float* __restrict t3 = t2 + stride;
      const float* __restrict v = in + (kTransferPlanes + b) * stride;
      float* __restrict o = out + (c * 4 + b) * stride;
      const float l0 = lc[c][0], l1 = lc[c][1], l2 = lc[c][2], l3 = lc[c][3], d = direct[c][b];
      // n is a multiple of 16 (the padding lanes hold zero inputs): no scalar epilogue.
      if (local) {
        const float* __restrict x = local + (c * 4 + b) * stride;
        for (int i = 0; i < n; ++i) o[i] = clampColour(l0 * t0[i] + l1 * t1[i] + l2 * t2[i] + l3 * t3[i] + d * v[i] + x[i]);
      } else {
        for (int i = 0; i < n; ++i) o[i] = clampColour(l0 * t0[i] + l1 * t1[i] + l2 * t2[i] + l3 * t3[i] + d * v[i]);
      }
    }
  return maxMagnitudeBits(out, n, stride);
}

// sh-l1's clamp of e1..3 (probe_cache.h): to +-kMaxColour, NaN to 0.
inline float clampSigned(float x) {
  const float y = x > -kMaxColour ? x : -kMaxColour;  // NaN -> -kMaxColour here, fixed below
  const float z = y < kMaxColour ? y : kMaxColour;
  return x == x ? z : 0.f;
}
// sh-l1 keeps its inputs in blocks of 16 probes: block b holds the kInputPlanes planes' 16 values
// of probes 16b..16b+15 side by side (kShL1Block floats), and the sun transfer likewise, 12 planes
// per sample and block. The relight then runs a block through all 12 (channel, coefficient)
// outputs with every input at a fixed offset from one pointer. Relit plane
// by plane, each 16-probe step was one chain of 8 dependent multiply-adds on 10 pointers, and the
// relight waited on their latency (1.6x fc3's, whose chain is 5).
inline constexpr int kShL1Block = kInputPlanes * 16;
inline constexpr int kSunBlock = 12 * 16;
// Where plane p of probe i sits in a run of blocks of `planes` planes x 16 probes.
constexpr size_t blockOffset(int i, int p, int planes) {
  return size_t(i / 16) * size_t(planes) * 16 + size_t(p) * 16 + size_t(i % 16);
}
// GCC's vector extensions, L lanes: 16 (one register) in the AVX-512 version, 8 in the AVX2 and
// baseline ones (where 16 lanes spilled: a block is then two halves). The helpers are always
// inlined into the kernels below, so no vector crosses a call, and GCC's -Wpsabi note on how one
// would be returned without AVX does not apply (runtime/CMakeLists.txt turns it off here).
template <int L>
struct Lanes;
template <>
struct Lanes<8> {
  using F = float __attribute__((vector_size(32)));
  using I = int32_t __attribute__((vector_size(32)));
};
template <>
struct Lanes<16> {
  using F = float __attribute__((vector_size(64)));
  using I = int32_t __attribute__((vector_size(64)));
};
template <class V>
[[gnu::always_inline]] inline V loadLanes(const float* p) {
  V v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <class V>
[[gnu::always_inline]] inline void storeLanes(float* p, V v) {
  std::memcpy(p, &v, sizeof v);
}
// clampColour and clampSigned on a vector (NaN to 0 in both).
template <class V>
[[gnu::always_inline]] inline V clampColourLanes(V x) {
  const V zero{}, hi = zero + kMaxColour;
  const V y = x > zero ? x : zero;
  return y < hi ? y : hi;
}
template <class V>
[[gnu::always_inline]] inline V clampSignedLanes(V x) {
  const V zero{}, lo = zero - kMaxColour, hi = zero + kMaxColour;
  const V y = x > lo ? x : lo;
  const V z = y < hi ? y : hi;
  return x == x ? z : zero;
}

// The weights of one relight: per channel the bounce light and the direct sky's d0, d2, and per
// (channel, coefficient) plane the sun samples' a, b.
struct ShL1Weights {
  float lc[3][4];
  float d0[3], d2[3];
  float a[12], b[12];
};

template <int L, bool kSun, bool kLocal>
[[gnu::always_inline]] inline int32_t shL1Blocks(const float* __restrict in, float* __restrict out, int n, int stride,
                                                 const ShL1Weights& w_, const float* __restrict sx, const float* __restrict sy,
                                                 const float* __restrict local) {
  using F = typename Lanes<L>::F;
  using I = typename Lanes<L>::I;
  const ShL1Weights w = w_;
  I mx{};
  for (int k = 0; k < n; k += 16, in += kShL1Block, sx += kSunBlock, sy += kSunBlock)
    for (int h = 0; h < 16; h += L) {
      float* o = out + k + h;
      const float* x = local + k + h;  // plane-major, as `out`
#pragma GCC unroll 12
      for (int q = 0; q < 12; ++q) {
        const int c = q / 4, i = q % 4;
        const float* t = in + q * 64 + h;
        // The terms in the order of one chain (fused by GCC where the target has FMA): the 12
        // outputs of a block are independent, so that their chains overlap.
        const F p0 = loadLanes<F>(in + (kTransferPlanes + i) * 16 + h), p2 = loadLanes<F>(in + (kTransferPlanes + 4 + i) * 16 + h);
        F v = w.lc[c][0] * loadLanes<F>(t) + w.lc[c][1] * loadLanes<F>(t + 16) + w.lc[c][2] * loadLanes<F>(t + 32) +
              w.lc[c][3] * loadLanes<F>(t + 48) + w.d0[c] * p0 + w.d2[c] * p2;
        if constexpr (kSun) v = v + w.a[q] * loadLanes<F>(sx + q * 16 + h) + w.b[q] * loadLanes<F>(sy + q * 16 + h);
        if constexpr (kLocal) v = v + loadLanes<F>(x);
        v = i == 0 ? clampColourLanes(v) : clampSignedLanes(v);
        // Clamped values order like their bit patterns once the sign bit is cleared.
        I bits;
        std::memcpy(&bits, &v, sizeof bits);
        bits &= 0x7fffffff;
        mx = bits > mx ? bits : mx;
        storeLanes(o, v);
        o += stride;
        x += stride;
      }
    }
  int32_t m = 0;
  for (int l = 0; l < L; ++l) m = std::max(m, mx[l]);
  return m;
}

template <int L>
[[gnu::always_inline]] inline int32_t shL1Relight(const float* in, float* out, int n, int stride, const ShL1Weights& w,
                                                  const float* sx, const float* sy, const float* local) {
  if (sx)
    return local ? shL1Blocks<L, true, true>(in, out, n, stride, w, sx, sy, local) : shL1Blocks<L, true, false>(in, out, n, stride, w, sx, sy, in);
  return local ? shL1Blocks<L, false, true>(in, out, n, stride, w, in, in, local) : shL1Blocks<L, false, false>(in, out, n, stride, w, in, in, in);
}

// sh-l1's relight of one slot's blocks, with its sun transfer's two samples sx, sy (or without,
// sx = nullptr): e[c][i][k] = sum_j lc[c][j] M'[c][i][j][k] + d0[c] P0_i[k] + d2[c] P2_i[k]
// (+ the sun's a x + b y) (+ local[c][i][k], the local lights' term, plane-major at `stride`,
// unless null), then clamped (e0 to [0, kMaxColour], e1..3 to +-kMaxColour, NaN to 0). Returns the
// bit pattern of the largest |clamped value|. `n` a multiple of 16. One version per target
// (GCC's function multiversioning, as DRTV_SIMD_CLONES but with the lanes each target wants).
#if DRTV_SIMD_MULTIVERSION
__attribute__((target("arch=x86-64-v4"))) int32_t relightBlocksShL1(const float* in, float* out, int n, int stride,
                                                                    const ShL1Weights& w, const float* sx, const float* sy,
                                                                    const float* local) {
  return shL1Relight<16>(in, out, n, stride, w, sx, sy, local);
}
__attribute__((target("arch=x86-64-v3"))) int32_t relightBlocksShL1(const float* in, float* out, int n, int stride,
                                                                    const ShL1Weights& w, const float* sx, const float* sy,
                                                                    const float* local) {
  return shL1Relight<8>(in, out, n, stride, w, sx, sy, local);
}
__attribute__((target("default")))
#endif
int32_t relightBlocksShL1(const float* in, float* out, int n, int stride, const ShL1Weights& w, const float* sx, const float* sy,
                          const float* local) {
  return shL1Relight<8>(in, out, n, stride, w, sx, sy, local);
}

// The band factors of the clamped cosine (sh.h): irradiance SH e_i = kLobe[i] R_i.
constexpr float kLobe[4] = {sh::kCosineLobe0, sh::kCosineLobe1, sh::kCosineLobe1, sh::kCosineLobe1};

// acc[k][i] += colour_k * scale[i] * q[k][i] for the 12 (channel, k) planes of one source.
DRTV_SIMD_CLONES void accumulateSource(float* acc, const int16_t* q, const float* scale, int n, int stride,
                                      const float (&colour)[12]) {
  for (int k = 0; k < 12; ++k) {
    float* __restrict a = acc + k * stride;
    const int16_t* __restrict qk = q + k * stride;
    const float* __restrict sc = scale;
    const float w = colour[k];
    for (int i0 = 0; i0 < n; i0 += 16)
      for (int i = i0; i < i0 + 16; ++i) a[i] += w * (sc[i] * float(qk[i]));
  }
}

}  // namespace

struct ProbeCache::Impl {
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
    return in.data[size_t(s) * kInputPlanes * kSlotProbes + blockOffset(i, p, kInputPlanes)];
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

  // The probe the index grid of resident slot `s` names for world position `pos` (cell z clamped
  // into the grid; 255 resolved to the sector's nearest probe). Precondition: the slot has probes.
  int namedProbe(int s, const glm::dvec3& pos) const {
    const Slot& sl = slots[s];
    auto cell = [](double v) { return int(std::clamp(std::floor(v), 0.0, double(kGridDim - 1))); };
    const int x = cell((pos.x - sl.origin.x) / kGridCellSizeM);
    const int y = cell((pos.y - sl.origin.y) / kGridCellSizeM);
    const int z = cell((pos.z - sl.z_min) / sl.cell_h);
    return sl.nearest[IndexGrid::cellIndex(x, y, z)];
  }

  // Source resolution, incremental: a slot's source_ids name the resident probes its sources are,
  // and namers lists, per global probe id, the resident sources that name it. Recomputing all
  // of it at every addSector and removeSector (51 slots x 128 sources) was a third of a lit
  // sector's addSector in `drtv fly` over the lit island (perf, docs/runtime.md); an arrival or a
  // departure touches only its own sources and those of the slots whose sources reach it.

  // Slot s arrived (its fields set): resolves its own sources, and the unresolved sources of
  // resident slots that name probes in its sector.
  void sourcesArrived(int s) {
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

  // Slot s is leaving (its fields still set): its sources, and the sources of other slots that
  // named its probes, no longer count.
  void sourcesLeaving(int s) {
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
  static uint32_t namer(int slot, size_t j) { return uint32_t(slot) << 16 | uint32_t(j); }
  void unname(int32_t id, uint32_t who) {
    std::vector<uint32_t>& v = namers[size_t(id)];
    const auto at = std::find(v.begin(), v.end(), who);
    DRTV_CHECK(at != v.end());
    *at = v.back();
    v.pop_back();
  }

  // litSources of every slot at once: lit[s] for each slot s (cleared first), from the lit probes
  // and the sources naming them, in source order. The same lists as litSources slot by slot.
  void litSourcesOfAll(const RelightInput& li, std::vector<std::vector<LitSource>>& lit) const {
    lit.resize(slots.size());
    for (std::vector<LitSource>& l : lit) l.clear();
    if (!(li.components & kComponentLocalLights)) return;
    for (int id : touched) {
      if (!is_lit[size_t(id)]) continue;
      for (uint32_t who : namers[size_t(id)]) lit[who >> 16].push_back({size_t(who & 0xffffu), light_colour[size_t(id)]});
    }
    for (std::vector<LitSource>& l : lit)
      if (l.size() > 1) std::sort(l.begin(), l.end(), [](const LitSource& a, const LitSource& b) { return a.j < b.j; });
  }

  // Interior volumes' boxes (world metres): the cells whose centres they hold fill from outside.
  std::vector<std::pair<glm::dvec3, glm::dvec3>> interior_boxes;

  // Slot s's fill cells and the bounds of the cells each probe fills (see Slot::fill).
  void fillCells(int s) {
    Slot& sl = slots[s];
    sl.fill = sl.nearest;
    // Only the boxes over the sector's square (a city's rooms are thousands; a sector holds few).
    const glm::dvec2 lo = sl.origin, hi = sl.origin + glm::dvec2(kSectorSizeM);
    std::vector<std::pair<glm::dvec3, glm::dvec3>> here;
    for (const auto& b : interior_boxes)
      if (b.first.x < hi.x && b.second.x > lo.x && b.first.y < hi.y && b.second.y > lo.y) here.push_back(b);
    if (!here.empty()) {
      std::array<uint8_t, kGridCells> inside{};
      for (int z = 0; z < kGridDim; ++z)
        for (int y = 0; y < kGridDim; ++y)
          for (int x = 0; x < kGridDim; ++x) {
            const glm::dvec3 c(sl.origin.x + (x + 0.5) * kGridCellSizeM, sl.origin.y + (y + 0.5) * kGridCellSizeM,
                               double(sl.z_min) + (z + 0.5) * double(sl.cell_h));
            inside[size_t(IndexGrid::cellIndex(x, y, z))] = std::any_of(here.begin(), here.end(), [&](const auto& b) {
              return glm::all(glm::greaterThanEqual(c, b.first)) && glm::all(glm::lessThan(c, b.second));
            });
          }
      // Each layer: a breadth-first search over face neighbours from the cells outside every
      // interior, so that a cell inside takes the nearest outside cell's choice at its height.
      std::array<int16_t, kGridDim * kGridDim> from{};
      std::array<bool, kGridDim> wholly_inside{};  // a layer without a cell outside
      std::vector<int> queue;
      for (int z = 0; z < kGridDim; ++z) {
        queue.clear();
        for (int i = 0; i < kGridDim * kGridDim; ++i) {
          const int cell = IndexGrid::cellIndex(i % kGridDim, i / kGridDim, z);
          from[size_t(i)] = inside[size_t(cell)] ? int16_t(-1) : int16_t(i);
          if (!inside[size_t(cell)]) queue.push_back(i);
        }
        wholly_inside[size_t(z)] = queue.empty();
        for (size_t q = 0; q < queue.size(); ++q) {
          const int i = queue[q], x = i % kGridDim, y = i / kGridDim;
          const int nx[4] = {x - 1, x + 1, x, x}, ny[4] = {y, y, y - 1, y + 1};
          for (int k = 0; k < 4; ++k) {
            if (nx[k] < 0 || ny[k] < 0 || nx[k] >= kGridDim || ny[k] >= kGridDim) continue;
            const int j = ny[k] * kGridDim + nx[k];
            if (from[size_t(j)] >= 0) continue;
            from[size_t(j)] = from[size_t(i)];
            queue.push_back(j);
          }
        }
        for (int i = 0; i < kGridDim * kGridDim; ++i) {
          const int cell = IndexGrid::cellIndex(i % kGridDim, i / kGridDim, z);
          if (inside[size_t(cell)] && from[size_t(i)] >= 0)
            sl.fill[size_t(cell)] = sl.nearest[size_t(IndexGrid::cellIndex(from[size_t(i)] % kGridDim, from[size_t(i)] / kGridDim, z))];
        }
      }
      // A layer wholly inside (a hall wider than the sector): the first cell above outside.
      for (int y = 0; y < kGridDim; ++y)
        for (int x = 0; x < kGridDim; ++x) {
          int above = -1;
          for (int z = kGridDim - 1; z >= 0; --z) {
            const int cell = IndexGrid::cellIndex(x, y, z);
            if (!inside[size_t(cell)])
              above = sl.nearest[size_t(cell)];
            else if (wholly_inside[size_t(z)] && above >= 0)
              sl.fill[size_t(cell)] = uint8_t(above);
          }
        }
    }
    const int n = sl.count;
    sl.cell_bounds.assign(size_t(n), {uint8_t(kGridDim), uint8_t(kGridDim), uint8_t(kGridDim), 0, 0, 0});
    for (int z = 0; z < kGridDim; ++z)
      for (int y = 0; y < kGridDim; ++y)
        for (int x = 0; x < kGridDim; ++x) {
          const uint8_t p = sl.fill[IndexGrid::cellIndex(x, y, z)];
          if (p >= n) continue;
          std::array<uint8_t, 6>& b = sl.cell_bounds[p];
          const uint8_t c[3] = {uint8_t(x), uint8_t(y), uint8_t(z)};
          for (int a = 0; a < 3; ++a) b[a] = std::min(b[a], c[a]), b[3 + a] = std::max(b[3 + a], c[a]);
        }
  }

  uint64_t slot_relights = 0;  // relightSlot calls (slotRelightCount)
  uint64_t local_sums = 0;     // sumLocalLights calls (localSumCount)

  std::vector<LightShare> distribute(std::span<const PointLight> lights) const;

  // The bake lit source p with a unit point light at the probe, height_m above the surface below
  // it; a light hung H above that surface lights it less, and over a wider area. The share is
  // scaled by meanDiskIrradiance(H) / meanDiskIrradiance(h): the irradiance each puts on the disk
  // of radius kLightFootprintM (the index cell) under it (probe_cache.h, "Local lights"). 1 for a
  // light at the probe's own height above that surface or lower.
  double footprintFactor(double light_z, const ProbeRef& p) const {
    const Slot& sl = slots[p.slot];
    const double h = std::max(kMinSourceHeightM, double(sl.height[p.index]));
    const double H = light_z - (double(sl.position[p.index].z) - double(sl.height[p.index]));
    if (!(H > h)) return 1.0;
    return meanDiskIrradiance(H) / meanDiskIrradiance(h);
  }
  void setLights(std::span<const PointLight> lights);
  // The sources of slot `s` that the current light shares light, in source order (all of a
  // slot's dependence on the lights: relightSlot reads nothing else of them).
  // From the lit probes and the sources naming them, as litSourcesOfAll (one way to find them).
  void litSources(int s, const RelightInput& li, std::vector<LitSource>& lit) const {
    lit.clear();
    if (!(li.components & kComponentLocalLights)) return;
    for (int id : touched) {
      if (!is_lit[size_t(id)]) continue;
      for (uint32_t who : namers[size_t(id)])
        if (int(who >> 16) == s) lit.push_back({size_t(who & 0xffffu), light_colour[size_t(id)]});
    }
    if (lit.size() > 1) std::sort(lit.begin(), lit.end(), [](const LitSource& a, const LitSource& b) { return a.j < b.j; });
  }
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
  const int16_t* sourcePlanes(int s, size_t j) {
    Slot& sl = slots[s];
    std::vector<int16_t>& planes = sl.lprt[j];
    if (planes.empty()) {
      const size_t stride = size_t(this->stride(s)), row = sl.sources.size() * 12;
      planes.assign(12 * stride, 0);
      const int16_t* src = sl.lprt_coeffs + j * 12;
      for (int i = 0; i < sl.count; ++i)
        for (size_t k = 0; k < 12; ++k) planes[k * stride + size_t(i)] = src[size_t(i) * row + k];
    }
    return planes.data();
  }
};

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
  if (!(std::isfinite(sector.grid.z_min_m) && std::isfinite(sector.grid.cell_height_m) && sector.grid.cell_height_m > 0.f))
    return fail(where + ": index grid z range is not finite and positive");
  const size_t sources = sector.lprt.sources.size();
  if (sources > size_t(kMaxLprtSources) || sector.lprt.coeffs.size() != size_t(n) * sources * 12)
    return fail(where + ": LPRT block size does not match its probes and sources");
  for (int i = 0; i < n; ++i)
    if (std::string e = validateProbe(sector.probes[i]); !e.empty()) return fail(where + ": probe " + std::to_string(i) + ": " + e);
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
  // fill never branches (sector.h allows 255 anywhere).
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

std::vector<LightShare> ProbeCache::Impl::distribute(std::span<const PointLight> lights) const {
  std::vector<LightShare> shares;
  const int k_max = opt.sources_per_light;
  struct Candidate {
    double d2;
    ProbeRef p;
  };
  std::vector<Candidate> best;
  // Keeps the k_max nearest, sorted; ties keep the earlier (slot, index): deterministic.
  auto consider = [&](const ProbeRef& p, double d2) {
    for (const Candidate& c : best)
      if (c.p == p) return;
    if (int(best.size()) == k_max && d2 >= best.back().d2) return;
    if (int(best.size()) == k_max) best.pop_back();
    auto at = std::upper_bound(best.begin(), best.end(), d2, [](double v, const Candidate& c) { return v < c.d2; });
    best.insert(at, Candidate{d2, p});
  };
  auto world = [&](int s, int i) {
    const Slot& sl = slots[s];
    return glm::dvec3(sl.origin.x + sl.position[i].x, sl.origin.y + sl.position[i].y, sl.position[i].z);
  };
  for (const PointLight& light : lights) {
    const double r = light.radius_m, r2 = r * r;
    best.clear();
    if (opt.light_sources == LightSources::kVisibleFromLight) {
      // The probes the index grid names in the 4 cells at the light's height whose centres
      // surround it (a bilinear look-up's cells). The bake named, for each cell, a probe that
      // sees it, so a probe on the far side of a roof or wall is not among them unless a cell
      // centre lies there too. Not the cells above: 4 m x 4 m x ~1.5 m cells put a centre above
      // a roof as soon as a lamp hangs within a cell of it. Such a cell names the probe standing
      // on the roof, whose floor (height_m below it) is above the light: that probe cannot see
      // the light, so the column is walked down, a cell at a time, to the first named source that
      // does not stand on a surface above the light (a ceiling quad 1 cm under the Cornell box's
      // roof sent all its light to the roof's top before: docs/runtime.md, "Local lights").
      auto lower = [](double v) { return (std::floor(v / kGridCellSizeM - 0.5) + 0.5) * kGridCellSizeM; };
      for (int k = 0; k < 4; ++k) {
        glm::dvec3 at = light.position;
        // The lower corner of the surrounding centres, then this corner's offset.
        at.x = lower(at.x) + ((k & 1) ? kGridCellSizeM : 0.0);
        at.y = lower(at.y) + ((k & 2) ? kGridCellSizeM : 0.0);
        if (!(std::fabs(at.x) < kMaxWorldM && std::fabs(at.y) < kMaxWorldM && std::isfinite(at.z))) continue;
        const int s = slotOf(sectorAt(at.x, at.y));
        if (s < 0 || slots[s].count == 0) continue;
        const Slot& sl = slots[s];
        for (int step = 0; step < kGridDim; ++step, at.z -= sl.cell_h) {
          const int i = namedProbe(s, at);
          if (i >= sl.count) break;
          const double floor_z = double(sl.position[i].z) - double(sl.height[i]);
          if (floor_z > light.position.z) {
            if (at.z < double(sl.z_min)) break;  // clamped into the bottom cell: nothing lower
            continue;
          }
          if (namers[size_t(s * kSlotProbes + i)].empty()) break;
          const glm::dvec3 d = world(s, i) - light.position;
          if (glm::dot(d, d) < r2) consider({s, i}, glm::dot(d, d));
          break;
        }
      }
    } else {
      for (size_t s = 0; s < slots.size(); ++s) {
        const Slot& sl = slots[s];
        if (!sl.used || sl.count == 0) continue;
        // Skip sectors whose probes' bounding box is out of reach.
        const glm::dvec3 lo(sl.origin.x + sl.lo.x, sl.origin.y + sl.lo.y, sl.lo.z);
        const glm::dvec3 hi(sl.origin.x + sl.hi.x, sl.origin.y + sl.hi.y, sl.hi.z);
        const glm::dvec3 gap = glm::max(glm::dvec3(0.0), glm::max(lo - light.position, light.position - hi));
        if (glm::dot(gap, gap) >= r2) continue;
        for (int i = 0; i < sl.count; ++i) {
          if (namers[s * kSlotProbes + size_t(i)].empty()) continue;
          const glm::dvec3 d = world(int(s), i) - light.position;
          const double d2 = glm::dot(d, d);
          if (d2 < r2) consider({int(s), i}, d2);
        }
      }
    }
    double sum = 0.0;
    std::array<double, 64> w{};
    for (size_t i = 0; i < best.size() && i < w.size(); ++i) {
      const double t = 1.0 - best[i].d2 / r2;
      w[i] = t * t;
      sum += w[i];
    }
    if (!(sum > 0.0)) continue;
    for (size_t i = 0; i < best.size() && i < w.size(); ++i)
      shares.push_back({best[i].p, light.intensity * float(w[i] / sum * footprintFactor(light.position.z, best[i].p))});
  }
  return shares;
}

int ProbeCache::sourcesNaming(ProbeRef p) const {
  DRTV_CHECK(slotUsed(p.slot) && p.index >= 0 && p.index < impl_->slots[size_t(p.slot)].count);
  return int(impl_->namers[size_t(p.slot) * kSlotProbes + size_t(p.index)].size());
}

std::vector<LightShare> ProbeCache::distributeLights(std::span<const PointLight> lights) const {
  return impl_->distribute(lights);
}

void ProbeCache::Impl::setLights(std::span<const PointLight> lights) {
  for (int id : touched) light_colour[id] = glm::vec3(0.f), is_lit[id] = 0;
  touched.clear();
  // is_lit marks the ids in `touched` while the shares are summed: once each, also where a share
  // is 0 (a light of intensity 0) and another light's share follows (a zero colour as the test
  // pushed such an id twice, and litSourcesOfAll would have counted its sources twice).
  for (const LightShare& sh : distribute(lights)) {
    const int id = sh.probe.slot * kSlotProbes + sh.probe.index;
    if (!is_lit[id]) is_lit[id] = 1, touched.push_back(id);
    light_colour[id] += sh.colour;
  }
  for (int id : touched) is_lit[id] = light_colour[id] != glm::vec3(0.f);
}

void ProbeCache::Impl::relightSlot(int s, const RelightInput& li, const std::vector<LitSource>* lit) {
  Slot& sl = slots[s];
  const int n = sl.count;
  // Per-relight constants: the bounce lighting L = sky + sun, and the direct-sky colour of each
  // basis before masking, dot(cosineLobe(B_b), SkySH) with the sky continued through the horizon
  // (lighting_sh.h, "Direct sky").
  float lc[3][4], direct[3][4];
  for (int c = 0; c < 3; ++c) {
    const sh::Sh4 bounce = (li.components & kComponentSkyBounce ? li.sky_sh[c] : sh::Sh4(0.f)) +
                           (li.components & kComponentSunBounce ? li.sun_sh[c] : sh::Sh4(0.f));
    for (int k = 0; k < 4; ++k) lc[c][k] = bounce[k];
    for (int b = 0; b < 4; ++b)
      direct[c][b] = li.components & kComponentDirectSky ? glm::dot(sh::cosineLobe(sh::kBasis[b]), li.sky_direct_sh[c]) : 0.f;
  }
  // Local lights: only sources that received light cost anything, and only when they (or their
  // shares) changed since the slot's last relight; an hour's relight adds the kept sum.
  thread_local std::vector<LitSource> now;
  if (lit)
    now.assign(lit->begin(), lit->end());
  else
    litSources(s, li, now);
  const bool lprt = !now.empty();
  if (lprt && !(sl.local_of_lit && now == sl.lit)) sumLocalLights(s, now);
  std::swap(sl.lit, now);
  sl.local_of_lit = lprt;
  sl.relit = true;
  ++slot_relights;
  const float* local = lprt ? sl.local.data : nullptr;
  const int stride = this->stride(s);
  const int n16 = (n + 15) & ~15;
  if (opt.representation == Representation::kShL1) {
    ShL1Weights w{};
    std::memcpy(w.lc, lc, sizeof lc);
    for (int c = 0; c < 3; ++c) {
      const bool on = li.components & kComponentDirectSky;
      w.d0[c] = on ? li.sky_direct_sh[c][0] : 0.f;
      w.d2[c] = on ? li.sky_direct_sh[c][2] : 0.f;
    }
    const size_t K = sl.sun_dirs.size();
    const bool sun = K > 0 && li.sun_transfer && (li.components & kComponentSunBounce) && li.sun_irradiance != glm::vec3(0.f);
    if (sun && (li.sun_direction != sun_seen || sl.sun_dirs != sun_dirs_seen)) {
      sunTransferWeights(sl.sun_dirs, li.sun_direction, std::span<float>(sun_w_seen.data(), K));
      sun_seen = li.sun_direction;
      sun_dirs_seen = sl.sun_dirs;
    }
    // e_i += kLobe_i E_c sum_k w_k C[k][c][i] (sector.h SunBlock), in the relight's own pass.
    // At most two samples weigh (sunTransferWeights): the first and the last with a weight.
    size_t k0 = K, k1 = K;
    if (sun)
      for (size_t k = 0; k < K; ++k)
        if (sun_w_seen[k] != 0.f) (k0 == K ? k0 : k1) = k;
    int32_t bits = 0;
    const float* blocks = in.data + size_t(s) * kInputPlanes * kSlotProbes;
    if (k0 < K) {
      if (k1 == K) k1 = k0;
      for (int q = 0; q < 12; ++q) {
        const float e = li.sun_irradiance[q / 4] * kLobe[q % 4];
        w.a[q] = sun_w_seen[k0] * e;
        w.b[q] = k1 == k0 ? 0.f : sun_w_seen[k1] * e;
      }
      bits = relightBlocksShL1(blocks, outPlane(s, 0), n16, stride, w, sl.sun.data + k0 * 12 * size_t(stride),
                               sl.sun.data + k1 * 12 * size_t(stride), local);
    } else {
      bits = relightBlocksShL1(blocks, outPlane(s, 0), n16, stride, w, nullptr, nullptr, local);
    }
    sl.max_colour = std::bit_cast<float>(bits);
    return;
  }
  sl.max_colour = std::bit_cast<float>(relightPlanes(inPlane(s, 0), outPlane(s, 0), n16, stride, lc, direct, local));
}

void ProbeCache::Impl::sumLocalLights(int s, std::span<const LitSource> lit) {
  Slot& sl = slots[s];
  const int stride = this->stride(s);
  const int n16 = (sl.count + 15) & ~15;
  ++local_sums;
  float* acc = sl.local.data;
  std::fill_n(acc, size_t(12) * stride, 0.f);
  for (const LitSource& a : lit) {
    float colour[12];
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 4; ++k) colour[c * 4 + k] = a.colour[c];
    accumulateSource(acc, sourcePlanes(s, a.j), sl.lprt_scale.data(), n16, stride, colour);
  }
  if (sl.on_bases) return;  // the sums are basis irradiance already
  // In SH: turned into the colour planes' units, in place (the padding lanes stay 0).
  if (opt.representation == Representation::kShL1) {
    for (int q = 0; q < 12; ++q) {
      float* x = acc + size_t(q) * stride;
      for (int i = 0; i < n16; ++i) x[i] = kLobe[q % 4] * x[i];
    }
    return;
  }
  // fc3 with an SH block: basis irradiance with the clamped-cosine lobes.
  sh::Sh4 lobe[4];
  for (int b = 0; b < 4; ++b) lobe[b] = sh::cosineLobe(sh::kBasis[b]);
  for (int c = 0; c < 3; ++c) {
    float* q = acc + size_t(c) * 4 * stride;
    for (int i = 0; i < n16; ++i) {
      const float r[4] = {q[i], q[stride + i], q[2 * stride + i], q[3 * stride + i]};
      for (int b = 0; b < 4; ++b) q[b * stride + i] = lobe[b][0] * r[0] + lobe[b][1] * r[1] + lobe[b][2] * r[2] + lobe[b][3] * r[3];
    }
  }
}

void ProbeCache::relightAll(const RelightInput& in) {
  Impl& m = *impl_;
  m.setLights(in.components & kComponentLocalLights ? in.lights : std::span<const PointLight>{});
  thread_local std::vector<std::vector<LitSource>> lit;
  m.litSourcesOfAll(in, lit);
  for (size_t s = 0; s < m.slots.size(); ++s)
    if (m.slots[s].used) m.relightSlot(int(s), in, &lit[s]);
}

std::vector<int> ProbeCache::relightChangedLights(const RelightInput& in) {
  Impl& m = *impl_;
  m.setLights(in.components & kComponentLocalLights ? in.lights : std::span<const PointLight>{});
  std::vector<int> relit;
  // Every slot's lit sources from the lit probes (a test of all 51 x 128 sources per frame was a
  // sixth of BM_RelightChangedWith32MovingLights, perf).
  thread_local std::vector<std::vector<LitSource>> now;
  m.litSourcesOfAll(in, now);
  for (size_t s = 0; s < m.slots.size(); ++s) {
    Slot& sl = m.slots[s];
    if (!sl.used) continue;
    if (sl.relit && now[s] == sl.lit) continue;  // the same shares on the same sources: the same colours
    m.relightSlot(int(s), in, &now[s]);
    relit.push_back(int(s));
  }
  return relit;
}

void ProbeCache::setInteriorBoxes(std::vector<std::pair<glm::dvec3, glm::dvec3>> boxes) {
  Impl& m = *impl_;
  if (boxes == m.interior_boxes) return;
  m.interior_boxes = std::move(boxes);
  for (size_t s = 0; s < m.slots.size(); ++s)
    if (m.slots[s].used) m.fillCells(int(s));
}

uint64_t ProbeCache::slotRelightCount() const { return impl_->slot_relights; }
uint64_t ProbeCache::localSumCount() const { return impl_->local_sums; }

void ProbeCache::relightSector(SectorKey key, const RelightInput& in) {
  Impl& m = *impl_;
  const int s = m.slotOf(key);
  DRTV_CHECK(s >= 0);
  m.setLights(in.components & kComponentLocalLights ? in.lights : std::span<const PointLight>{});
  m.relightSlot(s, in);
}

float ProbeCache::maxColour(int slot) const {
  DRTV_CHECK(slot >= 0 && slot < int(impl_->slots.size()));
  return impl_->slots[slot].used ? impl_->slots[slot].max_colour : 0.f;
}
float ProbeCache::maxColour() const {
  float mx = 0.f;
  for (const Slot& s : impl_->slots)
    if (s.used) mx = std::max(mx, s.max_colour);
  return mx;
}

namespace {
// One channel's texels of a slot, plane by plane, in pack.h's encodings (branch-free there, so
// that these loops vectorise). Per probe and
// channel the scalar form, with the representation tested per texel, made the pack after each
// relight as costly as half a volume refill (perf of a fly at 0.2 h/s).
DRTV_SIMD_CLONES void packPlanes(const float* __restrict p0, const float* __restrict p1, const float* __restrict p2,
                                const float* __restrict p3, int n, float inv, bool sh_l1, uint32_t* __restrict out) {
  if (sh_l1)
    for (int i = 0; i < n; ++i) out[i] = detail::packTexelShL1(p0[i], p1[i], p2[i], p3[i], inv);
  else
    for (int i = 0; i < n; ++i) out[i] = detail::packTexel(p0[i], p1[i], p2[i], p3[i], inv);
}
}  // namespace

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

ProbeCache::WorldBox ProbeCache::cellsNaming(int s, const std::bitset<kSlotProbes>& probes) const {
  DRTV_CHECK(slotUsed(s));
  const Slot& sl = impl_->slots[s];
  glm::ivec3 lo(kGridDim), hi(-1);
  for (int i = 0; i < sl.count; ++i) {
    if (!probes.test(size_t(i))) continue;
    const std::array<uint8_t, 6>& c = sl.cell_bounds[size_t(i)];
    if (c[0] > c[3]) continue;  // no cell names it
    lo = glm::min(lo, glm::ivec3(c[0], c[1], c[2]));
    hi = glm::max(hi, glm::ivec3(c[3], c[4], c[5]));
  }
  WorldBox b;
  if (hi.x < 0) return b;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  b.lo = {sl.origin.x + lo.x * kGridCellSizeM, sl.origin.y + lo.y * kGridCellSizeM,
          lo.z == 0 ? -kInf : sl.z_min + double(lo.z) * sl.cell_h};
  b.hi = {sl.origin.x + (hi.x + 1) * kGridCellSizeM, sl.origin.y + (hi.y + 1) * kGridCellSizeM,
          hi.z == kGridDim - 1 ? kInf : sl.z_min + double(hi.z + 1) * sl.cell_h};
  return b;
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

glm::vec3 shade(Representation r, const BasisColours& c, const glm::vec3& n) {
  if (r == Representation::kShL1) {
    const glm::vec3 e = c[0] + c[1] * n.y + c[2] * n.z + c[3] * n.x;
    return glm::max(e, glm::vec3(0.f));
  }
  const glm::vec4 w = sh::shadingWeights(n);
  return w.x * c[0] + w.y * c[1] + w.z * c[2] + w.w * c[3];
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

ProbeRef ProbeCache::probeAt(const glm::dvec3& pos) const {
  if (!(std::fabs(pos.x) < kMaxWorldM && std::fabs(pos.y) < kMaxWorldM && std::isfinite(pos.z))) return {};
  const int s = slotOf(sectorAt(pos.x, pos.y));
  if (s < 0) return {};
  const Slot& sl = impl_->slots[s];
  if (sl.count == 0) return {};
  return {s, impl_->namedProbe(s, pos)};
}

ProbeRef ProbeCache::interiorProbe(uint16_t index, const glm::dvec3& designated, const glm::dvec3& lo,
                                   const glm::dvec3& hi) const {
  auto world = [](const Slot& sl, int i) {
    const glm::vec3& q = sl.position[i];
    return glm::dvec3(sl.origin.x + q.x, sl.origin.y + q.y, q.z);
  };
  // Flagged probes: each slot keeps their short list.
  ProbeRef best;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (size_t s = 0; s < impl_->slots.size(); ++s) {
    const Slot& sl = impl_->slots[s];
    if (!sl.used) continue;
    for (uint8_t i : sl.designated) {
      if (sl.interior[i] != index) continue;
      const glm::dvec3 d = world(sl, i) - designated;
      if (glm::dot(d, d) < best_d2) best_d2 = glm::dot(d, d), best = {int(s), i};
    }
  }
  if (best.valid()) return best;
  // Else the nearest probe inside the box, visiting only slots whose bounds meet it.
  for (size_t s = 0; s < impl_->slots.size(); ++s) {
    const Slot& sl = impl_->slots[s];
    if (!sl.used || sl.count == 0) continue;
    const glm::dvec3 slo(sl.origin.x + sl.lo.x, sl.origin.y + sl.lo.y, sl.lo.z);
    const glm::dvec3 shi(sl.origin.x + sl.hi.x, sl.origin.y + sl.hi.y, sl.hi.z);
    if (glm::any(glm::greaterThan(slo, hi)) || glm::any(glm::lessThan(shi, lo))) continue;
    for (int i = 0; i < sl.count; ++i) {
      if ((sl.flags[i] & kProbeInterior) && sl.interior[i] == index) continue;  // none, or found above
      const glm::dvec3 w = world(sl, i);
      if (!glm::all(glm::greaterThanEqual(w, lo)) || !glm::all(glm::lessThanEqual(w, hi))) continue;
      const glm::dvec3 d = w - designated;
      if (glm::dot(d, d) < best_d2) best_d2 = glm::dot(d, d), best = {int(s), i};
    }
  }
  return best;
}

ProbeRef ProbeCache::nearestProbe(const glm::dvec3& pos) const {
  ProbeRef best;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (size_t s = 0; s < impl_->slots.size(); ++s) {
    const Slot& sl = impl_->slots[s];
    if (!sl.used) continue;
    for (int i = 0; i < sl.count; ++i) {
      const glm::dvec3 d = worldPosition({int(s), i}) - pos;
      const double d2 = glm::dot(d, d);
      if (d2 < best_d2) best_d2 = d2, best = {int(s), i};
    }
  }
  return best;
}

}  // namespace drtv::runtime
