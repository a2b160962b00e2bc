// The propagation's matrices (lpv.h, "Propagation"): what a cell re-emits, per SH coefficient,
// of the light a face neighbour sends it, one sparse 4 x 4 matrix per direction. Private to
// drtv::lpv.
#pragma once

#include <array>

#include "cascade.h"

namespace drtv::lpv::detail {

// The sparse propagation matrix of one direction (lpv.h, "Propagation"): with a the axis's
// coefficient and o1, o2 the other two band-1 ones,
//   dst0 += m00 s0 + m0a sa;  dsta += ma0 s0 + maa sa;  dst_o += moo s_o.
// By the symmetry of the 5 faces about the axis every other entry is 0 (checked at build).
struct DirMatrix {
  int a = 0, o1 = 0, o2 = 0;
  float m00 = 0, m0a = 0, ma0 = 0, maa = 0, moo = 0;
};

// The matrices of the kDirs directions (dirVector), built once, on the first call (thread-safe:
// a function-local static), from sh.h's cosine lobe and the face solid angles of lpv.h. The
// build checks the sparsity above (DRTV_CHECK): CascadedLpv::create calls this first.
const std::array<DirMatrix, kDirs>& matrices();

}  // namespace drtv::lpv::detail
