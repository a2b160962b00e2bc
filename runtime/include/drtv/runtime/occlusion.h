// drtv/runtime/occlusion.h — top-down occlusion tiles and the distant ambient they modulate.
//
// References
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slide 58: beyond the
//      volumes, sky ambient is modulated by a low-resolution top-down occlusion texture, one tile
//      per sector, generated from the probes' sky visibility when the sector streams in; it also
//      stores the probes' heights "so we can darken less the objects that are high above the
//      ground".
//
// A tile has 8 x 8 texels of 8 m (the sector's ground-map cells), [y][x], x east, y north, texel
// (x, y) centred at sector-relative (8x + 4, 8y + 4) m. It is built once per load, on the
// streamer's I/O thread (or by Runtime::addSector when no tile is handed over), and is compact
// (272 B) because the streamer counts it in its resident budget. Each texel holds the
// Gaussian-weighted mean (sigma kOcclusionSplatSigmaM, horizontal distance) over the sector's
// probes of
//  - sky_visibility: the probe's mean up-basis visibility (v0 + v1 + v2) / 3 over open ground's
//    kOpenGroundSkyVisibility, at most 1 (cosine-weighted openness of the sky above the horizon;
//    B3 looks down and sees no sky), unorm8;
//  - occluder_height: the probe's height above the terrain below it (the ground map when the
//    sector has one, else the probe's own height_cm), unorm8 over kOcclusionHeightRangeM;
// and ground: the sector's ground map copied as is (unorm16 over ground_z_min_m..max), or,
// without one, the same Gaussian mean of the probes' bases (z - height). A texel farther than
// ~3.5 sigma from every probe takes the nearest probe's values; a sector without probes is open
// sky (visibility 1, height 0).
// At a point at height z, the texel's occlusion is mix(visibility, 1, t) with
// t = saturate((z - ground) / max(height, kMinOccluderHeightM)): full occlusion on the ground,
// none at and above the probes' height. Tiles are bilinearly blended between texel centres;
// missing tiles read as open sky (1).
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
// Occluder heights are stored as unorm8 over [0, kOcclusionHeightRangeM]: 64 m covers the jungle
// canopy and most buildings; taller occluders saturate (their shadow is then too short).
inline constexpr float kOcclusionHeightRangeM = 64.f;
// Gaussian radius (sigma) of a probe's footprint in the tile: one texel, so that the ~70 probes of
// a sector (one per ~60 m^2) cover every texel without blurring a clearing away.
inline constexpr float kOcclusionSplatSigmaM = 8.f;
// An occluder is taken as at least this tall, so that t's divisor is never 0 (a texel of bare
// ground with its probe on the ground still fades to open sky over 2 m).
inline constexpr float kMinOccluderHeightM = 2.f;
// Sky visibility of an upward basis over open flat ground: the ground hides the part of its
// hemisphere below the horizon, (1 + cos 54.74 deg) / 2 = (1 + 1/sqrt 3) / 2. The tile divides the
// probes' mean upward visibility by it, so that open ground reads as open sky: the sky SH that
// distantAmbient masks has no light below the horizon already (lighting_sh.h, "Direct sky").
inline constexpr float kOpenGroundSkyVisibility = 0.5f * (1.f + 0.57735027f);

struct OcclusionTile {
  static constexpr int kTexels = kOcclusionTileDim * kOcclusionTileDim;
  SectorKey key;
  float ground_z_min_m = 0.f, ground_z_max_m = 0.f;  // the range `ground` is quantised over
  std::array<uint8_t, kTexels> sky_visibility{};     // unorm8, 255 = open sky
  std::array<uint8_t, kTexels> occluder_height{};    // unorm8 x kOcclusionHeightRangeM / 255 m
  std::array<uint16_t, kTexels> ground{};            // unorm16 over [ground_z_min_m, ground_z_max_m]

  float visibility(int x, int y) const { return float(sky_visibility[y * kOcclusionTileDim + x]) / 255.f; }
  float heightM(int x, int y) const { return float(occluder_height[y * kOcclusionTileDim + x]) * (kOcclusionHeightRangeM / 255.f); }
  float groundM(int x, int y) const {
    return ground_z_min_m + float(ground[y * kOcclusionTileDim + x]) / 65535.f * (ground_z_max_m - ground_z_min_m);
  }
  // RGBA8 form for a GPU atlas: R = visibility, G = occluder height, B, A = 0 (the ground height
  // stays on the CPU or in a separate height atlas). [y][x].
  std::array<uint32_t, kTexels> toRgba8() const;
};
static_assert(sizeof(OcclusionTile) == 272, "compact: the streamer counts it in its resident budget");

// Builds `sector`'s tile (see above). The streamer calls it on its I/O threads for every load.
// Thread-safe, pure, no allocation; ~64 x probes multiply-adds.
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
