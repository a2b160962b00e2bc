// drtv/formats/probe.h — the 152-byte probe record (talk [1] slide 22; DESIGN.md "What a probe
// holds"). On disk and in memory alike; little-endian; no padding.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012.
//
//  byte  size  field
//  ----  ----  ---------------------------------------------------------------------------------
//     0    12  float32 position[3]     sector-relative metres: x, y from the sector's min corner
//                                      (in [0, 64)), z the world height (sectors span all z)
//    12     2  uint16  flags           ProbeFlag bits; unknown bits are rejected on read
//    14     2  uint16  interior        0 = outside; k = inside World::interiors[k - 1]
//    16     4  float32 prt_range       R in [1e-30, 1e4]: dequantisation range of every prt coefficient
//    20    96  int16   prt[3][4][4]    [channel R,G,B][basis B0..B3][SH Y00,Y1-1,Y10,Y11],
//                                      snorm16 x R. Bounced irradiance at a virtual surface
//                                      with normal B_b = dot(L_sh[c], T[c][b]) (sun and sky)
//   116     8  uint16  sky_vis[4]      unorm16: cosine-weighted sky visibility about B0..B3
//   124     8  int16   sky_vis_sh[4]   snorm16 x 4: SH of the 0/1 sky-visibility function
//                                      (|c0| <= sqrt(4 pi) = 3.545, so the range 4 suffices);
//                                      with kProbeSkyFit the direct sky's a (below) instead
//   132     4  float32 lprt_range      dequantisation range of this probe's LPRT row, [1e-30, 1e4]; 0 = none
//   136     2  uint16  backface_frac   unorm16: fraction of bake rays that hit back faces
//   138     2  uint16  height_cm       height above the surface below the probe, centimetres
//                                      (0 .. 655.35 m), for the distant-occlusion tile
//   140     4  float32 mean_hit_m      mean distance to the first hit of the bake rays that hit, [0, 1e7] m
//   144     8  int16   sky_terms[4]    kProbeSkyMoments: snorm16 x 1, (3/4pi) integral of
//                                      (y z, z z, x z) V dw, the sky visibility's second moments,
//                                      and a zero (representation.h, sh-l1 archives of version 2);
//                                      kProbeSkyFit: snorm16 x 4, the direct sky's b (below);
//                                      zero without either flag, else rejected
//   152
//
// The direct sky with kProbeSkyFit (sh-l1 from archive version 3; representation.h): for the
// world's sky L(w) = H + (Z - H) sqrt(w.z) above the horizon and H below (the horizon colour
// continued, lighting_sh.h), the direct-sky irradiance SH is e = H a + (Z - H) b with
//   a_i = integral K_i(w) V(w) dw,  b_i = integral over w.z > 0 of K_i(w) sqrt(w.z) V(w) dw,
// K(w) = M^-1 sum_a w_a phi_a max(0, a.w), phi_a = [1, a.y, a.z, a.x], M = sum_a w_a phi_a phi_a^T:
// the weighted least-squares band-1 fit of the irradiance at the six axis normals a, so that
// E(n) = e0 + e1 n.y + e2 n.z + e3 n.x. The bake weighs each axis by the share of the probe's
// nearby receivers facing it (baker/src/transfer.cpp, kSkyFitReceiverWeight); with equal weights
// K = [(|x| + |y| + |z|) / 6, y / 2, z / 2, x / 2]. The runtime reads only a and b.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"
#include "drtv/formats/quantize.h"
#include "drtv/formats/sh.h"

namespace drtv {

enum ProbeFlag : uint16_t {
  kProbeRelocated = 1u << 0,     // placement moved it out of geometry
  kProbeVegetation = 1u << 1,    // placed on a vegetation bounding box
  kProbeInterior = 1u << 2,      // the designated probe of an interior volume
  kProbeManual = 1u << 3,        // added by hand rather than by placement rays
  kProbeSkyMoments = 1u << 4,    // sky_terms hold the visibility moments (an sh-l1 bake of archive version 2)
  kProbeSkyFit = 1u << 5,        // sky_vis_sh and sky_terms hold the direct sky's a and b (sh-l1, version 3)
  kProbeCovered = 1u << 6,       // under static geometry (a roof, a storey, an overhang): carries a visibility map (visibility.h)
  kProbeLightSource = 1u << 7,   // an LPRT source where a still light under a roof stands: no index cell names it, no lookup reads it
  kProbeStacked = 1u << 8,       // covered, placed up a space taller than a storey above its floor's probe (placement.h, covered_stack_m): starts no storey of its own
};
inline constexpr uint16_t kProbeKnownFlags = 0x01ff;
// Snorm range of the direct sky's b with kProbeSkyFit (|b_i| <= 0.8 pi / 2 + ... < 1.3).
inline constexpr float kSkyFitRange = 4.f;

// Snorm range of sky_vis_sh (see the table above).
inline constexpr float kSkyVisShRange = 4.f;

// Value ranges of the record's floats (docs/formats.md "Value ranges"), checked by validateProbe.
// Dequantisation ranges: a transfer coefficient is bounced irradiance per unit of lighting; with
// albedo <= 1 and up to 64 bounces it stays below ~100 (baked worlds: prt_range <= ~2, LPRT
// <= 1 since the point-light irradiance is clamped at 1 m, kLprtMinDistance2), so 1e4 leaves a
// wide margin while colour (<= kMaxColourValue, 1e9) x range x 4 x 128 terms stays ~1e16, finite.
// Below 1e-30 a range is a denormal or corruption: every coefficient would decode to ~0 (a probe
// silently black), so it is refused too (packProbe never writes one).
inline constexpr float kMinQuantizationRange = 1e-30f;
inline constexpr float kMaxPrtRange = 1e4f;
inline constexpr float kMaxLprtRange = 1e4f;
// mean_hit_m in [0, 1e7] m (a bake ray is never longer than the world is wide).
inline constexpr float kMaxMeanHitM = 1e7f;
// Heights: |position z| < 1e6 m, x and y in [0, 64] (sector-relative).
inline constexpr float kMaxProbeHeightM = 1e6f;

struct ProbeRecord {
  float position[3];
  uint16_t flags;
  uint16_t interior;
  float prt_range;
  int16_t prt[3][4][4];
  uint16_t sky_vis[4];
  int16_t sky_vis_sh[4];
  float lprt_range;
  uint16_t backface_frac;
  uint16_t height_cm;
  float mean_hit_m;
  int16_t sky_terms[4];
};
static_assert(sizeof(ProbeRecord) == 152, "probe record is 152 bytes (talk slide 22)");
static_assert(offsetof(ProbeRecord, prt) == 20 && offsetof(ProbeRecord, sky_vis) == 116 &&
                  offsetof(ProbeRecord, lprt_range) == 132 && offsetof(ProbeRecord, sky_terms) == 144,
              "byte layout as drawn above");

// The unpacked, float form of a probe: what the baker produces and the runtime reads.
struct ProbeData {
  glm::vec3 position{0.f};                       // sector-relative, as in the record
  uint16_t flags = 0;
  uint16_t interior = 0;
  std::array<std::array<sh::Sh4, 4>, 3> prt{};   // [channel][basis] transfer vectors
  glm::vec4 sky_vis{0.f};                        // [basis], in [0,1]
  sh::Sh4 sky_vis_sh{0.f};
  float backface_frac = 0.f;                     // [0,1]
  float height_m = 0.f;                          // [0, 655.35]
  float mean_hit_m = 0.f;
  glm::vec3 sky_moments{0.f};                    // (yz, zz, xz) moments in [-1, 1] (with kProbeSkyMoments)
  sh::Sh4 sky_fit_h{0.f};                        // the direct sky's a (with kProbeSkyFit; then sky_vis_sh is 0)
  sh::Sh4 sky_fit_delta{0.f};                    // the direct sky's b (with kProbeSkyFit)
};

// Packs `p`, choosing prt_range as the largest |coefficient| (or 1 when all are 0), kept in
// [kMinQuantizationRange, kMaxPrtRange]. Values are clamped to their documented ranges; NaN
// becomes 0 (a bug upstream; packing stays total).
// lprt_range is set to 0: the LPRT block's packer fills it. sky_moments are written only when
// flags has kProbeSkyMoments, sky_fit_h and sky_fit_delta (in place of sky_vis_sh) only with
// kProbeSkyFit (else those bytes stay zero, as a talk-basis record has them).
ProbeRecord packProbe(const ProbeData& p);

// Unpacks a record. Precondition: the record was validated (validateProbe) or packed here.
ProbeData unpackProbe(const ProbeRecord& r);

// Checks a record read from untrusted bytes: finite position with x, y in [0, 64] and |z| < 1e6,
// known flags, prt_range in [kMinQuantizationRange, kMaxPrtRange], lprt_range 0 or in
// [kMinQuantizationRange, kMaxLprtRange], mean_hit_m in [0, kMaxMeanHitM], zero sky_terms
// without kProbeSkyMoments or kProbeSkyFit (never both), sky_terms[3] zero with kProbeSkyMoments,
// and no int16 -32768 (never written). NaN fails every range. Returns nothing when valid, else an
// error saying what is wrong, naming the field (the caller adds file, sector and byte offset).
Result<void> validateProbe(const ProbeRecord& r);

}  // namespace drtv
