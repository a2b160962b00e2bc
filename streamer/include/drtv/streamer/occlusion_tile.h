// drtv/streamer/occlusion_tile.h — one sector's tile of the top-down distant-occlusion texture.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slide 58: "a
//      low-resolution, top-down 2D occlusion texture ... generated from the visibility
//      information stored in the probes ... divided in tiles, each of which represents a sector
//      ... regenerated when the light probes for that sector are streamed into memory ... also
//      stores the height of the probes, so we can darken less the objects that are high above
//      the ground."
//
// The streamer builds a tile on the I/O thread for every sector it loads and drops it when the
// sector is evicted. The builder is a hook (StreamerOptions::occlusion_tile): the runtime may
// supply its own; buildOcclusionTile below is the default and the reference the tests use.
//
// Tile layout: 8 x 8 texels of 8 m (the sector's ground-map cells), [y][x], x east, y north,
// texel (x, y) centred at sector-relative (8x + 4, 8y + 4) metres.
#pragma once

#include <array>
#include <cstdint>

#include "drtv/formats/sector.h"

namespace drtv::streamer {

inline constexpr int kOcclusionTileDim = kGroundDim;           // 8 texels per side
inline constexpr double kOcclusionTexelM = kSectorSizeM / kOcclusionTileDim;  // 8 m
// Occluder heights are stored as unorm8 over [0, kOcclusionHeightRangeM]: 64 m covers the
// jungle canopy and most buildings; taller occluders saturate (their shadow is then too short).
inline constexpr float kOcclusionHeightRangeM = 64.f;
// Gaussian radius (sigma) of a probe's footprint in the tile, metres: one texel, so that the ~70 probes
// of a sector (one per ~60 m^2) cover every texel without blurring a clearing away.
inline constexpr float kOcclusionSplatSigmaM = 8.f;

struct OcclusionTile {
  SectorKey key;
  // Cosine-weighted sky visibility of the upper hemisphere at the probes over this texel, unorm8
  // (255 = open sky, 0 = fully covered): the factor that modulates distant sky ambient.
  std::array<uint8_t, kOcclusionTileDim * kOcclusionTileDim> sky_visibility{};
  // Height above the ground up to which the occlusion applies, unorm8 x kOcclusionHeightRangeM/255
  // metres: the probes' height over the terrain (probes sit on canopies and roofs). Objects above
  // it are darkened less.
  std::array<uint8_t, kOcclusionTileDim * kOcclusionTileDim> occluder_height{};

  float visibility(int x, int y) const { return float(sky_visibility[y * kOcclusionTileDim + x]) / 255.f; }
  float heightM(int x, int y) const {
    return float(occluder_height[y * kOcclusionTileDim + x]) * (kOcclusionHeightRangeM / 255.f);
  }
};
static_assert(sizeof(OcclusionTile) == 8 + 2 * 64, "a tile lives inline in its residency slot");

// Builds the tile of `sector` [1]: each texel takes the Gaussian-weighted (sigma
// kOcclusionSplatSigmaM, horizontal distance) mean over the sector's probes of
//   visibility = mean of sky_vis[B0..B2] (the three upward bases cover the upper hemisphere
//                symmetrically; B3 looks down and sees no sky) over open ground's
//                runtime::kOpenGroundSkyVisibility, at most 1
//   height     = probe z - terrain height below it (the ground map when the sector has one,
//                else the probe's own height_cm above the surface below it)
// A sector without probes (sea, a hole in the bake) is open sky at height 0. Pure, thread-safe,
// no allocation; ~64 x probes multiply-adds.
OcclusionTile buildOcclusionTile(const Sector& sector);

}  // namespace drtv::streamer
