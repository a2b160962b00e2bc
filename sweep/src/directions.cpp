// The 26 bins by quadrature: kRows x kCols equal-area samples (z at row midpoints, azimuth at
// column midpoints), each assigned to the nearest bin source direction of its hemisphere.
#include "drtv/sweep/directions.h"

#include <cmath>
#include <numbers>
#include <vector>

namespace drtv::sweep {
namespace {

// 256 x 512 samples of 96 usr each: a bin of ~0.5 sr holds ~5000 of them; the sun disc of 3
// degrees ~90. The midpoint rule in z integrates the cosine exactly whatever the count.
constexpr int kRows = 256;
constexpr int kCols = 512;

struct Tables {
  std::array<Direction, kDirections> dirs;
  // Per row (z) and bin: the solid angle of the row's samples in that bin (the sky depends on z
  // alone, so the sky's integral per bin is a sum over rows).
  std::vector<std::array<float, kDirections>> row_omega;
  std::vector<uint8_t> bin;  // per sample, row-major
};

glm::dvec3 sampleDir(int i, int j) {
  const double z = -1.0 + (i + 0.5) * 2.0 / kRows;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = (j + 0.5) * 2.0 * std::numbers::pi / kCols;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

Tables build() {
  Tables t;
  const int order[3] = {-1, 0, 1};
  int k = 0;
  for (int dy : order)
    for (int dx : order) t.dirs[size_t(k++)].step = {dx, dy, -1};
  for (int dy : order)
    for (int dx : order)
      if (dx || dy) t.dirs[size_t(k++)].step = {dx, dy, 0};
  for (int dy : order)
    for (int dx : order) t.dirs[size_t(k++)].step = {dx, dy, 1};
  std::array<glm::dvec3, kDirections> from;
  for (int b = 0; b < kDirections; ++b) {
    Direction& d = t.dirs[size_t(b)];
    d.sweep_step = d.step;
    if (d.step.z == 0) d.sweep_step = {kNearHorizontalStep * d.step.x, kNearHorizontalStep * d.step.y, -1};
    from[size_t(b)] = -glm::normalize(glm::dvec3(d.sweep_step));
  }
  const double d_omega = 4.0 * std::numbers::pi / (double(kRows) * kCols);
  std::array<double, kDirections> omega{};
  std::array<glm::dvec3, kDirections> sum{};
  t.row_omega.assign(kRows, {});
  t.bin.resize(size_t(kRows) * kCols);
  for (int i = 0; i < kRows; ++i) {
    std::array<double, kDirections> row{};
    for (int j = 0; j < kCols; ++j) {
      const glm::dvec3 w = sampleDir(i, j);
      const int lo = w.z > 0 ? 0 : kSwept, hi = w.z > 0 ? kSwept : kDirections;
      int best = lo;
      for (int b = lo + 1; b < hi; ++b)
        if (glm::dot(w, from[size_t(b)]) > glm::dot(w, from[size_t(best)])) best = b;
      t.bin[size_t(i) * kCols + size_t(j)] = uint8_t(best);
      row[size_t(best)] += d_omega;
      sum[size_t(best)] += w * d_omega;
    }
    for (int b = 0; b < kDirections; ++b) {
      omega[size_t(b)] += row[size_t(b)];
      t.row_omega[size_t(i)][size_t(b)] = float(row[size_t(b)]);
    }
  }
  for (int b = 0; b < kDirections; ++b) {
    Direction& d = t.dirs[size_t(b)];
    d.solid_angle_sr = float(omega[size_t(b)]);
    const glm::dvec3 m = sum[size_t(b)] / omega[size_t(b)];
    d.mean_from = glm::vec3(m);
    d.travel = glm::vec3(-glm::normalize(m));
  }
  return t;
}

const Tables& tables() {
  static const Tables t = build();
  return t;
}

}  // namespace

const std::array<Direction, kDirections>& directions() { return tables().dirs; }

glm::vec3 irradiance(const LightVector& phi, const glm::vec3& n) {
  const auto& d = directions();
  glm::vec3 e(0.f);
  for (int k = 0; k < kDirections; ++k) e += phi[size_t(k)] * std::max(0.f, glm::dot(n, d[size_t(k)].mean_from));
  return e;
}

LightVector skyLight(const Sky& sky, double hour) {
  const Tables& t = tables();
  std::array<glm::dvec3, kDirections> acc{};
  for (int i = 0; i < kRows; ++i) {
    const double z = -1.0 + (i + 0.5) * 2.0 / kRows;
    const glm::dvec3 l(sky.skyRadiance({std::sqrt(std::max(0.0, 1.0 - z * z)), 0.0, z}, hour));
    for (int b = 0; b < kDirections; ++b) acc[size_t(b)] += l * double(t.row_omega[size_t(i)][size_t(b)]);
  }
  LightVector out;
  for (int b = 0; b < kDirections; ++b) out[size_t(b)] = glm::vec3(acc[size_t(b)]);
  return out;
}

LightVector sunLight(const Sky& sky, double hour, double disc_radius_rad) {
  LightVector out{};
  const glm::dvec3 s = sky.sunDirection(hour);
  if (!(s.z > 0)) return out;
  const glm::vec3 e = sky.sun_irradiance.at(hour);
  const Tables& t = tables();
  const double cos_r = std::cos(disc_radius_rad);
  std::array<double, kDirections> share{};
  double total = 0;
  for (int i = 0; i < kRows; ++i)
    for (int j = 0; j < kCols; ++j)
      if (glm::dot(sampleDir(i, j), s) >= cos_r) {
        share[t.bin[size_t(i) * kCols + size_t(j)]] += 1;
        total += 1;
      }
  if (total == 0) {  // a disc below the quadrature's resolution: the nearest bin takes it all
    int best = 0;
    for (int b = 1; b < kSwept; ++b)
      if (glm::dot(s, glm::dvec3(t.dirs[size_t(b)].mean_from)) > glm::dot(s, glm::dvec3(t.dirs[size_t(best)].mean_from))) best = b;
    share[size_t(best)] = total = 1;
  }
  for (int b = 0; b < kDirections; ++b) out[size_t(b)] = e * float(share[size_t(b)] / total);
  return out;
}

}  // namespace drtv::sweep
