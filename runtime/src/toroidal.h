// The volume's toroidal addressing (volume.h, "Toroidal addressing"): a world texel's physical
// texel is its coordinate floorMod the period, wherever the volume has scrolled. Private to
// drtv::runtime.
#pragma once

namespace drtv::runtime::detail {

// a mod n in [0, n) for n > 0, a of any sign; floorDiv its quotient, rounded down.
inline int floorMod(int a, int n) {
  const int r = a % n;
  return r < 0 ? r + n : r;
}
inline int floorDiv(int a, int n) { return (a - floorMod(a, n)) / n; }

}  // namespace drtv::runtime::detail
