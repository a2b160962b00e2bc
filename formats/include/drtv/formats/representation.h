// drtv/formats/representation.h — the directional representation a world was baked in: what a
// probe record's transfer block, a relit probe's twelve colours and a volume texel's four bytes
// mean. Chosen at bake time, stored in the archive manifest (archive.h), followed by every stage
// downstream (relighting, volume fill, shaders, tools).
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slides 22-32, 40-44.
//  [2] Ramamoorthi & Hanrahan, "An Efficient Representation for Irradiance Environment Maps",
//      SIGGRAPH 2001 (band-1 irradiance: E(n) = pi c0 Y0 + 2pi/3 c1..3 Y1(n), exact for any
//      lighting whose irradiance is linear in n, e.g. a uniform upper or lower hemisphere).
//
// kFc3 (code 0) — the talk's four transfer bases [1] (sh.h kBasis):
//   probe:  prt[c][b][k] = T[c][b], the SH4 transfer of bounced irradiance on a surface facing B_b;
//           sky_vis[b] = cosine-weighted sky visibility about B_b.
//   colour: colour[c][b] = irradiance on a surface facing B_b (>= 0).
//   texel:  four unorm8 basis intensities x HDR scale; ambient = sum_b w_b(n) colour_b with the
//           talk's shading weights (sh::shadingWeights).
// kShL1 (code 1) — band-1 SH irradiance [2]:
//   probe:  prt[c][i][j] = M[c][i][j], a 4x4 transfer per channel from lighting SH L (radiance,
//           coefficient j) to the SH of the bounced radiance arriving at the probe (coefficient i):
//           R_bounce[c] = M[c] L[c]. sky_vis[b] as for kFc3 (distant occlusion reads it).
//           The direct sky, archive version 3 (flag kProbeSkyFit, probe.h): a and b, the
//           band-1 fit of the six axis irradiances per unit horizon radiance and per unit
//           sqrt(z) gradient, e_direct = H a + (Z - H) b, exact at the six axes in the
//           least-squares sense for the world's sky model. Version 2 (kProbeSkyMoments, still
//           read): sky_vis_sh = SH of the 0/1 visibility V and (3 / 4pi) integral of
//           (y z, z z, x z) V dw, which mask the band-1 projection of the sky (lighting_sh.h):
//           0.117 pi |Z - H| too bright on open ground under a zenith darker than the horizon
//           (docs/accuracy.md).
//           The sun, version 3: the linear lobe below through M, plus the sector's sun transfer
//           (sector.h SunBlock): the exact first bounce along the world's sun path less the
//           lobe's, interpolated between the samples nearest the sun.
//   colour: colour[c][i] = irradiance SH e = [pi Y0 R0, 2pi/3 Y1 R1, 2pi/3 Y1 R2, 2pi/3 Y1 R3] of
//           the arriving radiance R (bounce + direct sky + local lights), so that
//           E(n) = max(0, e0 + e1 n.y + e2 n.z + e3 n.x). e0 >= 0; e1..3 signed.
//   texel:  byte 0 = unorm8 e0 / HDR scale; bytes 1..3 = e1..3 as 128 + round(127 e / HDR scale)
//           (offset binary, exact zero at 128, decoded as (byte - 128) / 127 x HDR scale), so that
//           the hardware's unorm trilinear filter followed by the affine decode equals filtering
//           the decoded values. (An snorm8 e0 would spend one of its bits on a sign it never has;
//           the two encodings have not been compared by measurement yet.)
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace drtv {

enum class Representation : uint32_t {
  kFc3 = 0,   // the talk's four bases (archives without the field are fc3)
  kShL1 = 1,  // band-1 SH irradiance (what new worlds bake: baker::TransferSettings)
};
inline constexpr uint32_t kRepresentationCount = 2;

// "fc3" or "sh-l1".
const char* representationName(Representation r);
// The representation named `name` ("fc3", "sh-l1"), or nullopt.
std::optional<Representation> parseRepresentation(std::string_view name);
// "fc3, sh-l1": for messages.
std::string representationNames();

}  // namespace drtv
