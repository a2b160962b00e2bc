// The sweep's gather paths (paths.h).
#include "paths.h"

#include <algorithm>

#include <glm/glm.hpp>

namespace drtv::sweep::detail {
namespace {

BinPath makePath(int bin, float smoothing) {
  const glm::ivec3 st = directions()[size_t(bin)].sweep_step;
  static constexpr int kTx[kTaps] = {0, 1, -1, 0, 0}, kTy[kTaps] = {0, 0, 0, 1, -1};
  BinPath p;
  p.bin = bin;
  for (int j = 0; j < kTaps; ++j) {
    Tap& t = p.taps[size_t(j)];
    t.ox = -st.x + kTx[j];
    t.oy = -st.y + kTy[j];
    t.w = j == 0 ? smoothing : (1.f - smoothing) / 4.f;
    // The segment between the centres, sampled at 512 midpoints: a cell's length is its samples'.
    const glm::dvec3 a(t.ox, t.oy, -st.z);
    constexpr int kSamples = 512;
    const double step_len = glm::length(a) / kSamples;
    for (int m = 0; m < kSamples; ++m) {
      const glm::dvec3 q = a * (1.0 - (m + 0.5) / kSamples);
      const glm::ivec3 c(glm::floor(q + 0.5));
      if (c == glm::ivec3(a) || c == glm::ivec3(0)) continue;
      auto it = std::find_if(t.crossed.begin(), t.crossed.end(),
                             [&](const Crossed& x) { return x.dx == c.x && x.dy == c.y && x.src_level == (c.z != 0); });
      if (it == t.crossed.end()) t.crossed.push_back({c.x, c.y, c.z != 0, 0.f}), it = t.crossed.end() - 1;
      it->len += float(step_len);
    }
  }
  float crossed = 0;
  for (const Crossed& c : p.taps[0].crossed) crossed += c.len;
  p.target_len = float(glm::length(glm::dvec3(st))) - crossed;
  return p;
}

}  // namespace

const BinPath& pathGeometry(int bin) {
  static const std::array<BinPath, kDirections> paths = [] {
    std::array<BinPath, kDirections> a;
    for (int b = 0; b < kDirections; ++b) a[size_t(b)] = makePath(b, 0.f);
    return a;
  }();
  return paths[size_t(bin)];
}

}  // namespace drtv::sweep::detail
