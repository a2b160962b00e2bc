// drtv/runtime/probe_cache.h — the resident probes, laid out for relighting, and their relit
// colours, laid out for the volume fill.
//
// References
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slides 26-32
//      (relighting code, dynamic lights distributed onto probes), slide 17 (index grid), slide 54
//      (the closest probe for transparencies).
//  [2] Kristensen, Akenine-Moeller, Jensen, "Precomputed Local Radiance Transfer for Real-Time
//      Lighting Design", SIGGRAPH 2005 (LPRT: lights snapped to baked source positions).
//  [3] DESIGN.md, "What a probe holds and how it is relit" (the formula implemented here).
//
// Relighting (per resident probe, basis b, channel c; DESIGN.md [3]):
//   colour[c][b] = dot(SkySH[c] + SunSH[c], T[c][b])                 sky and sun bounce
//                + dot(cosineLobe(B_b), SkySH[c]) * v[b]              direct sky, masked
//                + sum_j light[j][c] * LPRT[j][c][b]                  local lights (if baked)
//   then clamped to [0, kMaxColour] (never earlier; NaN from inf - inf becomes 0).
//
// Layout: each resident sector occupies a slot. A slot holds its probes' inputs as
// structure-of-arrays planes (one float per probe, the probe count rounded up to 16 apart, so a
// slot is one contiguous block): 48 transfer planes T[c][b][k] and 4
// sky-visibility planes v[b], dequantised once when the sector is added; relighting streams
// these planes (the loop over probes vectorises) and writes 12 colour planes colour[c][b].
// Packing then converts each probe once to three RGBA8 texels (one per colour channel, RGBA =
// the four basis intensities) for the volume fill to gather by index.
//
// The relight is linear in the lighting, and the local lights' sum does not depend on the hour:
// each slot with LPRT keeps that term (12 planes, 48 bytes a probe at the slot stride, lobes
// applied) with the lit sources and shares it was summed from. A relight re-sums it only when
// they differ (a light moved, dimmed, or a sector came or went), else adds the kept planes in the
// relight's own pass, so that a time-of-day relight costs the sky and sun terms plus the local
// sum of the slots whose lights changed. Each term is always summed the same way, so the colours
// are bit for bit those of a cache relit once from scratch with the same input.
//
// sh-l1 (representation.h): the same planes hold M'[c][i][j] = A_i M[c][i][j] (A = the clamped
// cosine's band factors pi Y0, 2pi/3 Y1, so that the output is irradiance SH e) and, in planes
// 48..55, the direct sky's per-probe factors P0_i = A_i Y0 s_i and P2_i = A_i (i = 0: Y0 s_2;
// i = 1..3: the moments m_yz, m_zz, m_xz) with s = sky_vis_sh. Then, per channel c and i:
//   e[c][i] = sum_j (SkySH[c][j] + SunSH[c][j]) M'[c][i][j]                     bounce
//           + SkyDirectSH[c][0] P0_i + SkyDirectSH[c][2] P2_i                   direct sky
//           + sum_j light[j][c] A_i LPRT_sh[j][c][i]                             local lights
// exact for the band-1 projection of the masked sky because the sky's SH has Y00 and Y10 only
// (lighting_sh.h; its Y1-1 and Y11 are ignored here). With kProbeSkyFit (probe.h) the planes are
// P0 = a / (4 pi Y0) and P2 = 5 (b - a / 3) / (4 pi Y1) instead, which the same two sky
// coefficients turn into H a + (Z - H) b. A sector's sun transfer (sector.h SunBlock) adds
// kLobe_i E_sun,c sum_k w_k C[k][c][i] to the bounce (sunTransferWeights), before the clamp. Clamping at the end: e0 to [0, kMaxColour],
// e1..3 to [-kMaxColour, kMaxColour] (E(n) itself is clamped at 0 where it is evaluated, shade()).
//
// Local lights [2]: a light's intensity is distributed onto LPRT source probes within its radius:
// the `sources_per_light` nearest candidates (default 4) with weights w = (1 - (d/R)^2)^2,
// normalised to sum to 1. The weight is finite and largest (1) at d = 0, so a light exactly on a
// probe is fine; a light with no candidate within its radius contributes nothing (no baked bounce
// exists for it there). The bake lit a source with a unit point light at the probe, h = height_m
// above the surface below it; a light hung H > h above that surface puts far less light on it
// under the light. Each share is therefore scaled by the footprint factor
//   Ebar(H) / Ebar(h),  Ebar(z) = 2 (1 - z / sqrt(z^2 + r^2)) / r^2, r = 4 m (an index cell),
// the mean irradiance a unit light at height z puts on the disk of radius r under it (1 when
// H <= h: energy kept). It was 1.4-3.7x too bright over open ground without it, 26x on the
// Cornell box's short block (docs/runtime.md, "Local lights"). The candidates (LightSources):
//  - kVisibleFromLight (default): the probes the index grid names in the 4 cells whose centres
//    surround the light, at its height. The bake named for each cell a probe that sees it, so a
//    lamp under a roof never lends its light to a probe standing on the roof (which would then
//    light the roof's outside: tests/reference/local_lights_test.cpp); where such a cell's centre
//    lies above the roof (a lamp within half a cell of it) and names a probe standing on a surface
//    above the light, the column is walked down to the first probe that does not. A few cell
//    look-ups per light, independent of how many probes are resident.
//  - kNearest: every resident source probe (the talk's rule); leaks through roofs and walls.
// Before either, a light standing where a baked light stands (within 0.25 m of a probe flagged
// kProbeLightSource, which the bake placed there: baker/placement.h, step 7) gives that source its
// whole intensity, no footprint factor: the bake lit the source with the light itself
// (`own_light_sources`; issue 35: the Cornell box's ceiling lights were shared out over probes
// 1.5 m over its blocks and floor).
//
// Thread-safety: not thread-safe; one writer. Const member functions may run concurrently with
// each other.
#pragma once

#include <array>
#include <bitset>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"
#include "drtv/formats/lighting.h"
#include "drtv/formats/representation.h"
#include "drtv/formats/sector.h"
#include "drtv/formats/sh.h"

namespace drtv::runtime {

inline constexpr int kMaxResidentSectors = 51;  // DESIGN.md: at most 51 resident sectors
inline constexpr int kSlotProbes = 256;         // plane length per slot: >= 255 probes, 64-byte multiple
inline constexpr int kTransferPlanes = 48;      // T[c][b][k]
inline constexpr int kInputPlanes = kTransferPlanes + 8;  // + v[b] (fc3) or P0_i, P2_i (sh-l1)
inline constexpr int kColourPlanes = 12;        // colour[c][b]
// Relit colours are clamped to this, so that no finite input gives Inf downstream (an HDR scale
// times 255 times three channels stays far inside float range).
inline constexpr float kMaxColour = 1e30f;

// Which terms of the relighting formula to evaluate (all for rendering; one at a time for
// diagnostics such as `drtv query`).
enum Component : uint32_t {
  kComponentSunBounce = 1u << 0,
  kComponentSkyBounce = 1u << 1,
  kComponentDirectSky = 1u << 2,
  kComponentLocalLights = 1u << 3,
};
inline constexpr uint32_t kAllComponents = 0xf;

// A probe's relit colours. kFc3: irradiance (linear RGB) at a virtual surface facing each basis
// B0..B3. kShL1: the band-1 irradiance SH e0..e3 per channel (representation.h).
using BasisColours = std::array<glm::vec3, 4>;

// Irradiance (linear RGB) for unit normal `n` from four colours in representation `r`: kFc3, the
// talk's shading weights (sh::shadingWeights); kShL1, max(0, e0 + e1 n.y + e2 n.z + e3 n.x) per
// channel. Pure, thread-safe.
glm::vec3 shade(Representation r, const BasisColours& colours, const glm::vec3& n);

// The lighting one relight uses.
struct RelightInput {
  sh::Sh4Rgb sky_sh{};                    // sky radiance SH (lighting_sh.h)
  sh::Sh4Rgb sun_sh{};                    // sun radiance SH, windowed
  sh::Sh4Rgb sky_direct_sh{};             // sky masked by v[b] in the direct-sky term (lighting_sh.h)
  std::span<const PointLight> lights;     // validated (validateLighting)
  uint32_t components = kAllComponents;
  // The sun transfer (sector.h SunBlock, sh-l1): added to the sun bounce when `sun_transfer` and
  // the sector has one; meant for the linear sun lobe the bake corrected (lighting_sh.h).
  glm::vec3 sun_direction{0.f, 0.f, 1.f};  // unit, towards the sun
  glm::vec3 sun_irradiance{0.f};          // after the horizon fade
  bool sun_transfer = false;
};

// A resident probe: its slot and its index in that sector.
struct ProbeRef {
  int slot = -1;
  int index = -1;
  bool valid() const { return slot >= 0 && index >= 0; }
  friend bool operator==(const ProbeRef&, const ProbeRef&) = default;
};

// Which source probes may take a light's energy (see the header comment).
enum class LightSources { kVisibleFromLight, kNearest };

// The fine level near surfaces (issue 35; visibility.h): the covered probes around a point, each
// weighted by distance, by the side of the surface it stands on and by whether it sees the point.
struct FineOptions {
  bool enabled = true;
  float radius_m = 4.f;       // probes farther than this from the point take no part
  float normal_bias_m = 0.25f;  // the point moves this far along its normal first ([1] of visibility.h)
  // A probe whose visibility test gives less than this takes no part: the far field lights what no
  // covered probe sees (a roof's top over a lit room), where DDGI has no fallback and keeps them.
  float min_visibility = 0.1f;
  // The fine level covers a point wholly once the weights sum to this (one probe at 1.5 m facing it).
  float full_weight = 0.3f;
};
struct FineSample {
  BasisColours colours{};  // the weighted mean of the probes' colours
  float weight = 0.f;      // in [0, 1]: how fully the fine level covers the point (0: not at all)
  int probes = 0;          // probes that took part
};

struct ProbeCacheOptions {
  int max_sectors = kMaxResidentSectors;  // slots; memory is reserved for all of them up front
  int sources_per_light = 4;              // LPRT source probes that share one light, 1..64
  LightSources light_sources = LightSources::kVisibleFromLight;
  bool own_light_sources = true;          // a light on a baked light's own source takes it whole (above)
  Representation representation = Representation::kFc3;  // what the added sectors were baked in
};

// One light's share on one source probe (the output of distributeLights).
struct LightShare {
  ProbeRef probe;
  glm::vec3 colour{0.f};  // intensity (per sr, linear RGB) assigned to this source
};

// How addSector holds a sector's LPRT block, the largest part of a lit sector (sources x probes
// x 12 int16: ~200 KB for 66 probes and 128 sources): kCopy copies it into the slot; kBorrow
// keeps a pointer into `sector.lprt.coeffs`, which must then stay alive and unchanged until
// removeSector(sector.key) returns, as the streamer guarantees its SectorSink (streamer.h). The
// copy was a fifth of a lit sector's arrival in the lit-island fly (perf, docs/runtime.md).
enum class SectorBlock { kCopy, kBorrow };

class ProbeCache {
 public:
  explicit ProbeCache(ProbeCacheOptions options = {});
  ~ProbeCache();
  ProbeCache(ProbeCache&&) noexcept;
  ProbeCache& operator=(ProbeCache&&) noexcept;

  // Copies `sector` into a free slot (dequantising its probes once). Its colours are black until
  // it is relit. Errors: the key is already resident; all slots are used; a grid cell names a
  // probe that does not exist; an LPRT block whose size does not match; a sector baked in another
  // representation than the cache's (kProbeSkyMoments marks sh-l1 probes; sh-l1 LPRT is in SH).
  // `block`: whether its LPRT block is copied too or borrowed (SectorBlock).
  Result<void> addSector(const Sector& sector, SectorBlock block = SectorBlock::kCopy);
  // Frees the sector's slot; false if it was not resident.
  bool removeSector(SectorKey key);
  // The slot holding `key`, or -1. O(slots).
  int slotOf(SectorKey key) const;
  int maxSectors() const;
  int sectorCount() const;
  int probeCount() const;
  std::vector<SectorKey> keys() const;

  // Relights every resident probe (and redistributes the lights over all source probes). A slot's
  // local lights' term is re-summed only if its lit sources or their shares changed since its last
  // relight (see the header comment); the colours are the same either way, bit for bit.
  void relightAll(const RelightInput& in);
  // Relights only `key`'s probes (precondition: resident); lights are redistributed over all
  // resident source probes, but other sectors keep their colours until the next relightAll.
  void relightSector(SectorKey key, const RelightInput& in);

  // Redistributes `in.lights` and relights only the slots whose lit sources (the sources with a
  // light share, and their shares) differ from those of the slot's own last relight, plus any slot
  // never relit; returns those slots in slot order. A light reaches a slot only through its LPRT
  // sources, so a slot none of whose sources a moved light's old or new shares land on keeps its
  // colours. Precondition: the rest of `in` (sky, sun, components) is that of every slot's last
  // relight; then every slot's colours equal relightAll(in)'s bit for bit (the same sums in the
  // same order). This also catches slots whose sources' shares changed because a sector streamed
  // in or left (which relightSector leaves stale).
  std::vector<int> relightChangedLights(const RelightInput& in);
  // Slot relights done so far by relightAll, relightSector and relightChangedLights (for tests
  // and benchmarks of "relight only what the lights reach").
  uint64_t slotRelightCount() const;
  // Local lights' sums done so far (a slot relight whose lit sources and shares were those of its
  // last relight adds the kept sum instead; for tests and benchmarks of that).
  uint64_t localSumCount() const;

  // The shares of `lights` on resident LPRT source probes (see the header comment).
  std::vector<LightShare> distributeLights(std::span<const PointLight> lights) const;
  // How many LPRT sources of resident sectors name resident probe `p` (0: it takes no light).
  // Kept incrementally as sectors arrive and leave; for tests of that.
  int sourcesNaming(ProbeRef p) const;

  // Largest relit colour component of one slot / of all slots (0 when nothing is resident).
  float maxColour(int slot) const;
  float maxColour() const;

  // Converts relit colours to RGBA8 texels with `hdr_scale` (> 0): kFc3, byte = round(255 min(1,
  // colour / hdr_scale)); kShL1 as representation.h. The fallback colours (what a volume texel
  // with no probe holds) are packed too.
  void pack(float hdr_scale);
  // One slot with the scale of the last pack(); returns the probes whose packed texels changed
  // (the only ones whose nearest-fill volume texels change).
  std::bitset<kSlotProbes> packSlot(int slot);
  // The world box (metres) of the index-grid cells of used `slot` that name a probe in `probes`:
  // the texels whose nearest fill takes one of them. z is open below (-inf) when the grid's bottom
  // layer names one and above (+inf) when its top layer does (look-ups clamp into the grid). Empty
  // (lo.x > hi.x) when no cell names one. O(probes): each probe's cell bounds are kept.
  struct WorldBox {
    glm::dvec3 lo{0.0}, hi{-1.0};
    bool empty() const { return lo.x > hi.x; }
  };
  WorldBox cellsNaming(int slot, const std::bitset<kSlotProbes>& probes) const;
  float packedScale() const;
  Representation representation() const;
  void setFallback(const BasisColours& colours);
  const BasisColours& fallback() const;
  const std::array<uint32_t, 3>& packedFallback() const;

  // ---- Read access (for the volume fill, queries and tests) ----
  struct SlotView {
    SectorKey key;
    int probe_count = 0;
    glm::dvec2 origin_m{0.0};             // world x, y of the sector's min corner
    float grid_z_min_m = 0.f, grid_cell_height_m = 1.f;
    const uint8_t* nearest = nullptr;     // 16^3 [z][y][x]: the grid with 255 resolved to the
                                          // nearest probe of the sector (all 255 if no probes),
                                          // cells in interiors filled from the nearest outside
                                          // cell at their height (setInteriorBoxes)
    const float* colour = nullptr;        // 12 planes: colour[(c * 4 + b) * colour_stride + probe]
    int colour_stride = 0;                // floats between planes (probe count rounded up to 16)
    const uint32_t* packed = nullptr;     // [probe][channel]: RGBA8 = bases 0..3
  };
  // Precondition: 0 <= slot < maxSectors() and the slot is used (bugs otherwise).
  SlotView slot(int slot) const;
  bool slotUsed(int slot) const;

  // The interior volumes' boxes (world min, max): an index cell whose centre lies in one fills
  // the volume's texels from the nearest cell outside every one in its layer (face neighbours,
  // breadth first; a layer wholly inside: the first cell above it outside; SlotView::nearest), since
  // the points inside read the designated probe and the texels there only reach the points
  // outside (a roof's top, a wall's outer face) through the trilinear filter. probeAt and the
  // lights' sources keep the index grid's own cells. Resident sectors are remapped at once; the
  // caller refills the volume. Not thread-safe with relights.
  void setInteriorBoxes(std::vector<std::pair<glm::dvec3, glm::dvec3>> boxes);

  BasisColours colours(ProbeRef p) const;
  glm::dvec3 worldPosition(ProbeRef p) const;
  uint16_t flags(ProbeRef p) const;
  uint16_t interior(ProbeRef p) const;
  float heightAboveGround(ProbeRef p) const;
  glm::vec4 skyVisibility(ProbeRef p) const;

  // The probe the index grid names for world position `pos` (cell z clamped into the grid; 255
  // resolved to the sector's nearest probe) — the talk's closest probe for transparencies.
  // Invalid ProbeRef when the sector is not resident, has no probes, or `pos` is not finite.
  ProbeRef probeAt(const glm::dvec3& pos) const;
  // The probe a nearest volume fill gives the texel at `pos` (SlotView::nearest): probeAt's, except
  // in the cells of interior volumes, which take the nearest cell outside (setInteriorBoxes).
  // Invalid as probeAt's.
  ProbeRef filledAt(const glm::dvec3& pos) const;
  // The resident probe nearest to `pos` by Euclidean distance (brute force; for tools and
  // interiors). Invalid when nothing is resident.
  ProbeRef nearestProbe(const glm::dvec3& pos) const;
  // The fine level's colours at world `position` for a surface facing `normal` (unit): the resident
  // covered probes within o.radius_m of position + normal x o.normal_bias_m, weighted by
  // (1 - (r/R)^2)^2 x (((dot(to probe, n) + 1) / 2)^2 + 0.2) x the visibility test, weights under
  // 0.2 crushed as w^3 / 0.04 (DDGI's rules, [1] of visibility.h), a visibility under
  // o.min_visibility giving 0. weight = min(1, sum of weights / o.full_weight).
  // A zero sample when no covered probe is in range or none sees the point.
  FineSample fineLookup(const glm::dvec3& position, const glm::vec3& normal, const FineOptions& o) const;
  // One resident covered probe (the fine level's), as visitCoveredProbes visits it.
  struct CoveredProbe {
    glm::dvec3 position;                  // world metres
    std::span<const uint8_t> visibility;  // its map, kVisValuesPerProbe bytes (visibility.h)
    BasisColours colours;                 // its colours of the last relight
  };
  // Calls `visit` for each resident covered probe inside [lo, hi] (world metres), slot by slot in
  // probe order: what fine_shader.h packs for the shaders.
  void visitCoveredProbes(const glm::dvec3& lo, const glm::dvec3& hi, const std::function<void(const CoveredProbe&)>& visit) const;
  // The probe an interior volume [lo, hi] takes its light from: the resident probe flagged
  // kProbeInterior of interior `index` (ProbeData::interior, 1-based) nearest `designated`, else
  // the resident probe inside the box nearest `designated`; invalid when neither is resident.
  // Flagged probes come from a per-slot list; the fallback visits only the slots whose probes'
  // bounds meet the box, so an interior far from the camera costs next to nothing.
  ProbeRef interiorProbe(uint16_t index, const glm::dvec3& designated, const glm::dvec3& lo, const glm::dvec3& hi) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace drtv::runtime
