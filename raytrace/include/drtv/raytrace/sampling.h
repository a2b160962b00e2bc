// drtv/baker/sampling.h — deterministic random numbers and direction sampling for the bake.
//
//  [1] Pharr, Jakob, Humphreys, "Physically Based Rendering", 4th ed. (pbrt-v4), 2023: sec. A.5
//      (concentric disk mapping, Malley's cosine-weighted hemisphere), sec. 8.2 (Cranley-Patterson
//      rotation of a low-discrepancy pattern).
//  [2] Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 6(1), 2017.
//  [3] Roberts, "The Unreasonable Effectiveness of Quasirandom Sequences" (2018): the R2 sequence.
//  [4] Steele, Lea, Flood, "Fast Splittable Pseudorandom Number Generators" (SplitMix64), 2014.
//
// Determinism (STYLE.md): every random number is a pure function of a key such as
// (seed, sector, probe, sample) — never of the thread or the time — so a bake on 1 thread and on
// N threads is byte-identical. All functions are pure and thread-safe.
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace drtv::raytrace {

// SplitMix64's finaliser [4]: a bijective 64-bit mix.
inline uint64_t mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// A hash of a key tuple; order matters.
inline uint64_t hashKey(uint64_t a, uint64_t b = 0, uint64_t c = 0, uint64_t d = 0) {
  return mix64(mix64(mix64(mix64(a) ^ b) ^ c) ^ d);
}

// The top 24 bits of `bits` as a float in [0, 1).
inline float unitFloat(uint64_t bits) { return float(bits >> 40) * (1.f / 16777216.f); }

// Point i of the R2 sequence [3] shifted by `shift` modulo 1 (Cranley-Patterson rotation [1]):
// a well-spread 2D pattern whose shift is keyed per probe so that probes do not share artefacts.
inline glm::vec2 r2Point(uint32_t i, glm::vec2 shift) {
  constexpr double kA1 = 0.7548776662466927, kA2 = 0.5698402909980532;  // 1/g, 1/g^2, g^3 = g + 1
  const double u = double(shift.x) + kA1 * double(i + 1), v = double(shift.y) + kA2 * double(i + 1);
  glm::vec2 p(float(u - std::floor(u)), float(v - std::floor(v)));
  // float rounding of a value just under 1 can give exactly 1.
  if (p.x >= 1.f) p.x = 0.f;
  if (p.y >= 1.f) p.y = 0.f;
  return p;
}

// Cosine-weighted direction on the +Z hemisphere from u in [0,1)^2 (Malley's method on the
// concentric disk [1]); pdf = cos(theta) / pi.
inline glm::vec3 cosineHemisphere(glm::vec2 u) {
  const float a = 2.f * u.x - 1.f, b = 2.f * u.y - 1.f;
  float r = 0.f, phi = 0.f;
  constexpr float kQuarterPi = 0.785398163f;
  if (a != 0.f || b != 0.f) {
    if (std::abs(a) > std::abs(b)) {
      r = a;
      phi = kQuarterPi * (b / a);
    } else {
      r = b;
      phi = 2.f * kQuarterPi - kQuarterPi * (a / b);
    }
  }
  const float x = r * std::cos(phi), y = r * std::sin(phi);
  return {x, y, std::sqrt(std::max(0.f, 1.f - x * x - y * y))};
}

// Uniform direction on the unit sphere from u in [0,1)^2; pdf = 1 / (4 pi).
inline glm::vec3 uniformSphere(glm::vec2 u) {
  const float z = 1.f - 2.f * u.x, r = std::sqrt(std::max(0.f, 1.f - z * z));
  const float phi = 6.28318530718f * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// An orthonormal frame whose third axis is the unit vector n [2].
struct Frame {
  glm::vec3 t, b, n;
  explicit Frame(const glm::vec3& nn) : n(nn) {
    const float sign = std::copysign(1.f, n.z);
    const float a = -1.f / (sign + n.z), bb = n.x * n.y * a;
    t = glm::vec3(1.f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    b = glm::vec3(bb, sign + n.y * n.y * a, -n.y);
  }
  glm::vec3 toWorld(const glm::vec3& v) const { return v.x * t + v.y * b + v.z * n; }
};

// n cosine-weighted directions about a normal: the R2 points [3] under a Cranley-Patterson
// shift [1], mapped with the polar map (r = sqrt(u1), phi = 2 pi u2; pdf = cos/pi). The shift of
// u2 is a rotation about the normal, so the per-point sin/cos are tabulated once and each call
// costs two square roots and a handful of multiplies per ray (the concentric map [1] costs a
// sin/cos per ray, 15% of a bake's CPU time when it was used here). Immutable after construction;
// thread-safe.
class CosineSampler {
 public:
  explicit CosineSampler(uint32_t n) : u1_(n), cos_(n), sin_(n) {
    for (uint32_t i = 0; i < n; ++i) {
      const glm::vec2 p = r2Point(i, glm::vec2(0.f));
      u1_[i] = p.x;
      cos_[i] = std::cos(6.28318530718f * p.y);
      sin_[i] = std::sin(6.28318530718f * p.y);
    }
  }
  uint32_t size() const { return uint32_t(u1_.size()); }
  // Writes size() directions about frame.n; `shift` in [0,1)^2 keys the pattern.
  void generate(const Frame& frame, glm::vec2 shift, std::span<glm::vec3> out) const {
    const float c = std::cos(6.28318530718f * shift.y), s = std::sin(6.28318530718f * shift.y);
    for (size_t i = 0; i < u1_.size(); ++i) {
      float u = u1_[i] + shift.x;
      if (u >= 1.f) u -= 1.f;
      const float r = std::sqrt(u), z = std::sqrt(std::max(0.f, 1.f - u));
      const float cp = cos_[i] * c - sin_[i] * s, sp = sin_[i] * c + cos_[i] * s;
      out[i] = frame.toWorld(glm::vec3(r * cp, r * sp, z));
    }
  }

 private:
  std::vector<float> u1_, cos_, sin_;
};

}  // namespace drtv::raytrace
