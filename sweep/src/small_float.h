// The unsigned small floats of R11G11B10 (grid.h [2]), inline and branch-free so that the sweep's
// row loops can pack a row at a time; grid.cpp's packR11G11B10 / unpackR11G11B10 are these, so
// there is one definition of the rounding. Pure.
#pragma once

#include <bit>
#include <cstdint>

namespace drtv::sweep::detail {

// One unsigned small float: `kMant` mantissa bits, 5 exponent bits, bias 15, from a float's bits.
// Round to nearest (ties up); below 2^-14 (6.1e-5), negative and NaN: 0; above the largest
// (65024 for 11 bits, 64512 for 10): the largest.
template <int kMant>
inline uint32_t packSmall(float v) {
  constexpr int kShift = 23 - kMant;
  constexpr int32_t kMax = (30 << kMant) | ((1 << kMant) - 1);
  // Rebias the exponent (127 -> 15) and round the mantissa. For v >= 2^-14 (up to +inf) the
  // result is below 2^15, so the signed compare below is exact; other v are discarded by the
  // select, and unsigned arithmetic keeps them defined.
  const uint32_t b = std::bit_cast<uint32_t>(v);
  const int32_t r = int32_t(((b - (112u << 23)) + (1u << (kShift - 1))) >> kShift);
  const int32_t clamped = r < kMax ? r : kMax;
  return v >= 6.103515625e-05f ? uint32_t(clamped) : 0u;
}

template <int kMant>
inline float unpackSmall(uint32_t s) {
  if (s == 0) return 0.f;
  constexpr int kShift = 23 - kMant;
  return std::bit_cast<float>((s << kShift) + (112u << 23));
}

inline uint32_t packR11G11B10(float r, float g, float b) {
  return packSmall<6>(r) | (packSmall<6>(g) << 11) | (packSmall<5>(b) << 22);
}

}  // namespace drtv::sweep::detail
