// drtv/sweep/material_codec.h — a material grid (grid.h) kept compact between the offline
// voxelising and the sweeps that read it: lossless, so that a grid swept from the decoded
// material is the grid swept from the original, word for word.
//
// What it is for: the sweep technique voxelises every sector of a world once (offline, Embree) and
// keeps each sector's 1 m material grid in this form; its streaming workers decode a sector's grid
// when the sector comes near the camera and sweep it (grid_streamer.h). A 64 x 64 x 32 grid is
// 2.1 MB of floats; mostly air (zeros) and ground (density 1, a few albedos), it compresses ~20-60x.
//
// Layout (little-endian; an in-memory form, not a file format: nothing versioned on disk holds it):
//
//   offset  size  field
//    0      4     magic "DSMG"
//    4      4     u32 version = 1
//    8      24    f64 origin x, y, z (world metres, the grid's min corner)
//   32      8     f64 cell_m
//   40      12    i32 size x, y, z (each in [1, 4096], cells <= kMaxMaterialCells)
//   52      4     u32 ground_z count (0 or size.x * size.y)
//   56      8     u64 raw payload bytes (= 4 x (4 cells + ground_z count))
//   64      ...   one zstd frame of the payload: f32 planes density[cells], r[cells], g[cells],
//                 b[cells], ground_z[count], cell-major in GridShape::index order
//
// Thread-safety: pure functions.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "drtv/formats/error.h"
#include "drtv/sweep/grid.h"

namespace drtv::sweep {

inline constexpr size_t kMaterialHeaderBytes = 64;
// Cells a decoded grid may hold (decodeMaterial's bound before it allocates): 2^26, 1 GiB of
// planes; a 64 m sector at 1 m with 512 levels is 2^21.
inline constexpr size_t kMaxMaterialCells = size_t(1) << 26;

// The compact form of `material`. `zstd_level` as zstd's (3: its default; 1 is ~2x faster to
// encode and ~10 % larger on the island). Precondition (bug): a consistent grid (planes of
// cellCount() entries, ground_z empty or one per column, sizes within the bounds above).
std::vector<uint8_t> encodeMaterial(const MaterialGrid& material, int zstd_level = 3);

// The grid back, bit for bit. Errors (bad bytes are input, not bugs): a wrong magic or version,
// a size out of bounds, a payload length that does not match, a bad or truncated zstd frame,
// trailing bytes; each message names the byte offset.
Result<MaterialGrid> decodeMaterial(std::span<const uint8_t> bytes);

}  // namespace drtv::sweep
