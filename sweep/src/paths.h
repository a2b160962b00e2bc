// The paths the sweep gathers along (sweep.h, sweep.cpp): for each of the 26 directions, the 5
// taps of a cell's gather (the source one level up and its 4 smoothing neighbours) and the
// material cells each tap's path crosses between source and target, with the length it crosses
// in each. Geometry only, computed once. Private to drtv::sweep.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "drtv/sweep/directions.h"

namespace drtv::sweep::detail {

inline constexpr int kPad = kNearHorizontalStep + 1;  // the farthest source: 4 sideways + 1 smoothing tap
inline constexpr int kTaps = 5;

// A material cell a gathered path crosses between its source and its target: offset from the
// target, on the target's level (src_level false) or the source's, and the length in cell units.
struct Crossed {
  int dx, dy;
  bool src_level;
  float len;
  int len_id = -1;  // its length's factor plane (Sweeper::crossed_len_)
};
// The most material cells one tap's path crosses (pathGeometry; checked in Sweeper::setUp).
inline constexpr int kMaxCrossed = 8;
// Bit of a crossed cell's factor row in a gathered row's mask of rows with material (Sweeper::
// gather): rows dy = -kPad..kPad of the target's level, then of the source's.
inline constexpr int kRowBits = 2 * kPad + 1;
struct Tap {
  int ox, oy;  // source offset from the target, cells
  float w;
  std::vector<Crossed> crossed;
  // The crossed cells flattened for the gather (Sweeper::setUp): their factor rows (the index in a
  // level's table of factor rows, LevelFactors::rows, less the target's row j) and columns (the
  // offset from the target's padded column), row bits, and the union of those bits.
  std::array<int, kMaxCrossed> row{};
  std::array<int, kMaxCrossed> column{};
  std::array<uint8_t, kMaxCrossed> bit{};
  std::array<uint8_t, kMaxCrossed> src_level{};
  uint32_t mask = 0;
};
struct BinPath {
  int bin;
  std::array<Tap, kTaps> taps;
  float target_len;      // the path length the target cell itself attenuates
  int target_len_id = -1;  // Sweeper::target_len_
};

// The paths of direction `bin` (sweep_step of directions()[bin]) without their weights (w 0; the
// crossed cells and lengths do not depend on the smoothing, the weights do: the source's is the
// smoothing, each neighbour's (1 - smoothing) / 4). Computed once. Thread-safe (a function-local
// static).
const BinPath& pathGeometry(int bin);

}  // namespace drtv::sweep::detail
