// drtv/runtime/occlusion.h — top-down occlusion tiles and the distant ambient they modulate.
//
// References
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slide 58: beyond the
//      volumes, sky ambient is modulated by a low-resolution top-down occlusion texture, one tile
//      per sector, generated from the probes' sky visibility when the sector streams in; it also
//      stores the probes' heights "so we can darken less the objects that are high above the
//      ground".
//
// A tile has 8 x 8 texels of 8 m (the sector's ground-map cells). Each texel holds:
//  - sky_visibility: the mean over the texel's probes of the mean up-basis visibility
//    (v0 + v1 + v2) / 3 / kOpenGroundSkyVisibility, at most 1 (cosine-weighted openness of the
//    sky above the horizon), or, for a texel without probes,
//    the mean of the sector's probes weighted by 1 / (d^2 + (8 m)^2) (d horizontal distance to the
//    texel centre); 1 (open sky) for a sector without probes;
//  - ground_m: Sector::groundHeight when the sector has a ground map, else the lowest probe base
//    (z - height above ground) of the texel's probes (or of the sector), else the grid's z min;
//  - top_m: the highest probe of the texel (or, without one, the weighted mean height above
//    ground of the sector's probes plus the ground), at least ground_m + kMinOccluderHeightM.
// At a point at height z, the texel's occlusion is mix(sky_visibility, 1, t) with
// t = saturate((z - ground_m) / (top_m - ground_m)): full occlusion on the ground, none at and
// above the probe tops. Tiles are bilinearly blended between texel centres; missing tiles read
// as open sky (1).
//
// Thread-safety: makeOcclusionTile is pure. OcclusionMap: one writer; const members concurrently.
#pragma once

#include <array>
#include <map>

#include <glm/glm.hpp>

#include "drtv/formats/sector.h"
#include "drtv/formats/sh.h"

namespace drtv::runtime {

inline constexpr int kOcclusionTileDim = kGroundDim;  // 8 texels of 8 m per sector side
inline constexpr double kOcclusionTexelM = kSectorSizeM / kOcclusionTileDim;
// An occluder is taken as at least this tall, so that t's divisor is never 0 (a texel of bare
// ground with its probe on the ground still fades to open sky over 2 m).
inline constexpr float kMinOccluderHeightM = 2.f;
// Sky visibility of an upward basis over open flat ground: the ground hides the part of its
// hemisphere below the horizon, (1 + cos 54.74 deg) / 2 = (1 + 1/sqrt 3) / 2. The tile divides the
// probes' mean upward visibility by it, so that open ground reads as open sky: the sky SH that
// distantAmbient masks has no light below the horizon already (lighting_sh.h, "Direct sky").
inline constexpr float kOpenGroundSkyVisibility = 0.5f * (1.f + 0.57735027f);

struct OcclusionTile {
  SectorKey key;
  std::array<float, kOcclusionTileDim * kOcclusionTileDim> sky_visibility{};  // [y][x] in [0, 1]
  std::array<float, kOcclusionTileDim * kOcclusionTileDim> ground_m{};        // world z
  std::array<float, kOcclusionTileDim * kOcclusionTileDim> top_m{};           // world z
  // RGBA8 form for a GPU atlas: R = visibility, G = (top - ground) / 64 m, B, A = 0 (the ground
  // height stays on the CPU or in a separate height atlas). [y][x].
  std::array<uint32_t, kOcclusionTileDim * kOcclusionTileDim> toRgba8() const;
};

// Builds `sector`'s tile from its probes' sky visibility and heights and its ground map. Called
// by the streamer on each load. Thread-safe, pure.
OcclusionTile makeOcclusionTile(const Sector& sector);

// The resident tiles, looked up by world position.
class OcclusionMap {
 public:
  void add(OcclusionTile tile);  // replaces a tile with the same key
  bool remove(SectorKey key);
  size_t size() const { return tiles_.size(); }
  const OcclusionTile* find(SectorKey key) const;
  // Occlusion in [0, 1] (1 = open sky) at world `position` (see the header). Finite for any input.
  float occlusion(const glm::dvec3& position) const;

 private:
  std::map<SectorKey, OcclusionTile> tiles_;
};

// Distant ambient [1]: the sky's irradiance for `normal`, dot(cosineLobe(n), SkySH), clamped to
// >= 0, times the occlusion at `position`. Linear RGB.
glm::vec3 distantAmbient(const OcclusionMap& map, const sh::Sh4Rgb& sky_sh, const glm::dvec3& position,
                         const glm::vec3& normal);

}  // namespace drtv::runtime
