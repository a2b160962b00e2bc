// noise.h (private) — small seeded hash noise for terrain, islands and scattering.
//
// Everything is keyed by (seed, integer coordinates / indices), never by time or thread
// (STYLE.md, "Determinism"). References:
//  [1] Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 2020 (pcg-style hashing).
//  [2] Perlin, "Improving Noise", SIGGRAPH 2002 (quintic fade used for value noise here).
//  [3] Musgrave, "Fractal Brownian motion", in Texturing & Modeling, 3rd ed. (fBm octave sum).
#pragma once

#include <cmath>
#include <cstdint>

namespace drtv::worlds::noise {

// A 64-bit mixing hash (splitmix64's finaliser): every input bit affects every output bit.
inline uint64_t mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// Hash of a seed and up to three integers.
inline uint64_t hash(uint64_t seed, uint64_t a, uint64_t b = 0, uint64_t c = 0) {
  return mix64(mix64(mix64(seed ^ mix64(a)) ^ b) ^ mix64(c + 0x632be59bd9b4e019ull));
}

// Uniform double in [0,1) from (seed, a, b, c); 53 random bits.
inline double uniform01(uint64_t seed, uint64_t a, uint64_t b = 0, uint64_t c = 0) {
  return double(hash(seed, a, b, c) >> 11) * (1.0 / 9007199254740992.0);
}

// Uniform in [lo, hi).
inline double uniform(uint64_t seed, uint64_t a, uint64_t b, uint64_t c, double lo, double hi) {
  return lo + (hi - lo) * uniform01(seed, a, b, c);
}

// Value noise in [-1, 1] at (x, y) in lattice units, quintic-faded bilinear blend [2].
inline double valueNoise2(uint64_t seed, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  const double tx = x - fx, ty = y - fy;
  auto fade = [](double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); };
  auto lattice = [&](int64_t i, int64_t j) {
    return 2.0 * uniform01(seed, static_cast<uint64_t>(i), static_cast<uint64_t>(j)) - 1.0;
  };
  const double u = fade(tx), v = fade(ty);
  const double a = lattice(ix, iy), b = lattice(ix + 1, iy);
  const double c = lattice(ix, iy + 1), d = lattice(ix + 1, iy + 1);
  return (a + (b - a) * u) + ((c + (d - c) * u) - (a + (b - a) * u)) * v;
}

// Fractal Brownian motion [3]: `octaves` octaves of value noise, each at twice the frequency
// and `gain` times the amplitude of the last; normalised to about [-1, 1].
inline double fbm2(uint64_t seed, double x, double y, int octaves, double gain = 0.5) {
  double sum = 0, amplitude = 1, norm = 0;
  for (int o = 0; o < octaves; ++o) {
    sum += amplitude * valueNoise2(mix64(seed + static_cast<uint64_t>(o)), x, y);
    norm += amplitude;
    amplitude *= gain;
    x *= 2.0;
    y *= 2.0;
  }
  return sum / norm;
}

}  // namespace drtv::worlds::noise
