#include "ground_blend.h"

#include <limits>

namespace drtv::eval {

double GroundMap::heightAt(double x, double y) const {
  if (empty()) return std::numeric_limits<double>::quiet_NaN();
  const double fx = std::clamp((x - origin.x) / cell_m - 0.5, 0.0, double(nx - 1));
  const double fy = std::clamp((y - origin.y) / cell_m - 0.5, 0.0, double(ny - 1));
  const int i0 = std::min(int(fx), nx - 1), j0 = std::min(int(fy), ny - 1);
  const int i1 = std::min(i0 + 1, nx - 1), j1 = std::min(j0 + 1, ny - 1);
  const double tx = fx - i0, ty = fy - j0;
  auto at = [&](int i, int j) { return double(z[size_t(i) + size_t(nx) * size_t(j)]); };
  const double a = at(i0, j0) + (at(i1, j0) - at(i0, j0)) * tx;
  const double b = at(i0, j1) + (at(i1, j1) - at(i0, j1)) * tx;
  return a + (b - a) * ty;  // NaN if any corner is
}

glm::vec3 GroundMap::normalAt(double x, double y) const {
  const double c = cell_m;
  const double dx = (heightAt(x + c, y) - heightAt(x - c, y)) / (2 * c);
  const double dy = (heightAt(x, y + c) - heightAt(x, y - c)) / (2 * c);
  if (!std::isfinite(dx) || !std::isfinite(dy)) return {0.f, 0.f, 1.f};
  return glm::vec3(glm::normalize(glm::dvec3(-dx, -dy, 1.0)));
}

}  // namespace drtv::eval
