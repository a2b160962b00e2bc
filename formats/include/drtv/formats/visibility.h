// drtv/formats/visibility.h — what a covered probe can see: the distance to the first surface in
// every direction, as an octahedral map of depth moments, so that the runtime's fine level never
// takes light from a probe on the other side of a wall (issue 35).
//
//  [1] Majercik, Guertin, Nowrouzezahrai, McGuire, "Dynamic Diffuse Global Illumination with
//      Ray-Traced Irradiance Fields", JCGT 8(2), 2019: sections 4-5 (depth moments per probe, the
//      Chebyshev test, the normal bias).
//  [2] Cigolle, Donow, Evangelakos, Mara, McGuire, Meyer, "A Survey of Efficient Representations
//      for Independent Unit Vectors", JCGT 3(2), 2014 (the octahedral map).
//
// The map: kVisDim x kVisDim texels over the octahedral projection of the sphere [2] (Z up: the
// upper hemisphere is the inner diamond). Texel t holds the mean and the standard deviation of the
// distance, from the probe, of the first static surface along the directions about its centre
// direction c_t, weighted by max(0, dot(c_t, d))^kVisSharpness [1]; a ray that meets nothing within
// kVisRangeM counts as kVisRangeM. A bake may end a ray earlier, where it leaves the covered air
// through an opening (baker/visibility_bake.h, BakeSettings::visibility_openings): the runtime reads
// any distance alike. Two bytes: the mean as 255 sqrt(mean / kVisRangeM) (steps of
// 1.6 cm at 0.5 m, 6 cm at 8 m), the deviation as 255 sigma / kVisMaxSigmaM.
// 8 x 8 texels (30 degrees each) were measured first: read bilinearly, a direction between a texel
// on a ceiling 1.6 m away and one on a wall 3.5 m away read 2.5 m, and a lamp's light reached a
// roof's top from the room under it (tests/reference/local_lights_test.cpp); 16 x 16 does not.
//
// Visibility of a point at distance r in direction d from the probe (visibilityWeight): with the
// moments m1 = mean, m2 = mean^2 + sigma^2 read bilinearly at d, 1 when r <= m1, else Chebyshev's bound on the chance that the
// surface lies beyond r, var / (var + (r - m1)^2), var = max(m2 - m1^2, kVisMinVariance), cubed
// (sharper, as [1]). A point behind a wall, wall-thickness beyond the mean, reads ~0.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include <glm/glm.hpp>

namespace drtv {

inline constexpr int kVisDim = 16;                         // texels per side of the octahedral map
inline constexpr int kVisTexels = kVisDim * kVisDim;
inline constexpr size_t kVisValuesPerProbe = size_t(kVisTexels) * 2;  // mean, deviation per texel
inline constexpr size_t kVisBytesPerProbe = kVisValuesPerProbe;       // 512
inline constexpr float kVisRangeM = 16.f;                  // farthest distance stored (metres)
inline constexpr float kVisMaxSigmaM = 8.f;                // the largest deviation of distances in [0, 16]
inline constexpr float kVisSharpness = 50.f;               // the filter lobe's exponent [1]
inline constexpr float kVisMinVariance = 1e-3f;            // m^2: (3 cm)^2, the quantisation's noise

// Unit direction <-> [0, 1]^2 on the octahedral map [2]; Z up.
glm::vec2 octEncode(const glm::vec3& d);
glm::vec3 octDecode(const glm::vec2& uv);
// The centre direction of texel (x, y).
glm::vec3 visTexelDirection(int x, int y);

// One texel's two bytes from its mean and deviation (metres), and back.
std::array<uint8_t, 2> encodeVisTexel(double mean, double sigma);
glm::vec2 decodeVisTexel(uint8_t mean, uint8_t sigma);  // (mean, sigma), metres

// The moments (mean, mean^2 + sigma^2) at direction `d` (unit) from one probe's
// kVisValuesPerProbe bytes, bilinear between texel centres (clamped at the map's edge).
glm::vec2 visMoments(std::span<const uint8_t> probe_values, const glm::vec3& d);
// The chance, by the test above, that a point `r` metres from the probe along `d` sees it.
float visibilityWeight(std::span<const uint8_t> probe_values, const glm::vec3& d, float r);

}  // namespace drtv
