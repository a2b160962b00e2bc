// drtv/formats/sh.h — the one definition of drtv's spherical-harmonics conventions.
//
// References
//  [1] Sloan, "Stupid Spherical Harmonics (SH) Tricks", GDC 2008 (real SH, band 0-1 constants).
//  [2] Ramamoorthi & Hanrahan, "An Efficient Representation for Irradiance Environment Maps",
//      SIGGRAPH 2001 (the clamped-cosine convolution: A0 = pi, A1 = 2pi/3).
//  [3] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012 (the transfer basis and
//      the shading weights), ../shared/seeds/000.
//
// Conventions (DESIGN.md; binding everywhere in drtv):
//  - World space is right-handed, Z up. Directions are unit vectors (x, y, z).
//  - Real SH, bands 0 and 1, four coefficients in the order [Y00, Y1-1, Y10, Y11], orthonormal
//    over the sphere, with NO Condon-Shortley phase:
//        Y00 = 0.282095, Y1-1 = 0.488603 y, Y10 = 0.488603 z, Y11 = 0.488603 x.
//    (Seed 002 uses another sign convention; do not mix them.)
//  - An Sh4 holding *radiance* L(w) is the projection c_i = integral of L(w) Y_i(w) dw.
//    Irradiance at normal n is dot(cosineLobe(n), c), i.e. the clamped cosine is convolved at
//    use, never stored: every stored SH in drtv is radiance (or a transfer vector that is dotted
//    with radiance, see the probe record), never pre-convolved irradiance.
//  - The clamped-cosine lobe about n is [0.886227, 1.023327 n.y, 1.023327 n.z, 1.023327 n.x]
//    (= pi*Y00 and 2pi/3*0.488603 [2]); dot(cosineLobe(n), evaluate(w)) = 0.25 + 0.5 cos(theta).
#pragma once

#include <array>
#include <functional>

#include <glm/glm.hpp>

namespace drtv::sh {

// Four SH coefficients in the order [Y00, Y1-1, Y10, Y11]. glm::vec4 so that dot() is one line.
using Sh4 = glm::vec4;
// One Sh4 per colour channel (R, G, B).
using Sh4Rgb = std::array<Sh4, 3>;

inline constexpr float kY0 = 0.282094792f;   // 1 / (2 sqrt(pi))
inline constexpr float kY1 = 0.488602512f;   // sqrt(3) / (2 sqrt(pi))
inline constexpr float kCosineLobe0 = 0.886226925f;  // pi * kY0
inline constexpr float kCosineLobe1 = 1.023326708f;  // (2 pi / 3) * kY1
inline constexpr float kPi = 3.14159265358979f;

// The SH basis functions at unit direction `dir`. Thread-safe, pure.
inline Sh4 evaluate(const glm::vec3& dir) { return {kY0, kY1 * dir.y, kY1 * dir.z, kY1 * dir.x}; }

// The SH projection of the clamped cosine max(0, dot(n, w)) about unit normal `n`.
inline Sh4 cosineLobe(const glm::vec3& n) {
  return {kCosineLobe0, kCosineLobe1 * n.y, kCosineLobe1 * n.z, kCosineLobe1 * n.x};
}

// Irradiance [W/m^2-like units] at unit normal `n` from radiance SH `radiance` [per sr].
inline float irradiance(const Sh4& radiance, const glm::vec3& n) { return glm::dot(cosineLobe(n), radiance); }

// Radiance [per sr] reconstructed in direction `dir` from radiance SH.
inline float radiance(const Sh4& sh, const glm::vec3& dir) { return glm::dot(evaluate(dir), sh); }

// SH of a uniform radiance `L` over the whole sphere: [L * sqrt(4 pi), 0, 0, 0].
inline Sh4 uniform(float L) { return {L * 3.544907702f, 0.f, 0.f, 0.f}; }

// SH of a directional (delta) light of irradiance `E` at normal incidence arriving from unit
// direction `dir`: the projection of E * delta(w - dir). Unwindowed: a band-1 delta rings (it is
// negative on the far side); the runtime decides whether to window it.
inline Sh4 directional(const glm::vec3& dir, float E) { return evaluate(dir) * E; }

// Projects f over the sphere by midpoint quadrature on an (n_theta x 2 n_theta) grid in
// (cos theta, phi): deterministic and slow, for references and tests. Thread-safe if f is.
Sh4 projectNumerically(const std::function<float(const glm::vec3&)>& f, int n_theta = 256);

// ---- Transfer basis and shading weights [3] ------------------------------------------------

// Three orthonormal upward directions and one straight down (DESIGN.md, "Transfer basis").
inline constexpr int kBasisCount = 4;
inline const std::array<glm::vec3, kBasisCount> kBasis = {
    glm::vec3(-0.408248f, -0.707107f, 0.577350f),
    glm::vec3(-0.408248f, 0.707107f, 0.577350f),
    glm::vec3(0.816497f, 0.f, 0.577350f),
    glm::vec3(0.f, 0.f, -1.f),
};

// The talk's shading weights for unit normal `n`: w_i = dot(n, B_i); w_3 = 0.5 w_3 + 0.5 (the
// down basis wraps); w_{0..2} *= saturate(w_{0..2}). ambient = sum_i w_i * colour_i.
glm::vec4 shadingWeights(const glm::vec3& n);

}  // namespace drtv::sh
