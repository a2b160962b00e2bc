#include "drtv/formats/sh.h"

#include <cmath>

namespace drtv::sh {

Sh4 projectNumerically(const std::function<float(const glm::vec3&)>& f, int n_theta) {
  // Uniform in cos(theta) and phi gives equal-area cells, so each cell's weight is 4pi / cells.
  const int n_phi = 2 * n_theta;
  const double cell_sr = 4.0 * M_PI / (double(n_theta) * n_phi);
  glm::dvec4 acc(0.0);
  for (int i = 0; i < n_theta; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n_theta;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    for (int j = 0; j < n_phi; ++j) {
      const double phi = 2.0 * M_PI * (j + 0.5) / n_phi;
      const glm::vec3 w(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
      acc += glm::dvec4(evaluate(w)) * double(f(w));
    }
  }
  return Sh4(acc * cell_sr);
}

glm::vec4 shadingWeights(const glm::vec3& n) {
  glm::vec4 w(glm::dot(n, kBasis[0]), glm::dot(n, kBasis[1]), glm::dot(n, kBasis[2]), glm::dot(n, kBasis[3]));
  w.w = 0.5f * w.w + 0.5f;
  for (int i = 0; i < 3; ++i) w[i] *= glm::clamp(w[i], 0.f, 1.f);
  return w;
}

}  // namespace drtv::sh
