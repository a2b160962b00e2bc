// Catmull-Rom flight paths (flight_path.h).
#include "drtv/fly/flight_path.h"

#include <algorithm>
#include <cmath>
#include <fstream>

#include <nlohmann/json.hpp>

namespace drtv::fly {
namespace {

// Arc-length table resolution: 64 chords per segment keep the length error of a 200 m segment
// with a 90 degree turn under 1 cm, far below a frame's travel at 100 m/s (1.7 m).
constexpr int kSamples = 64;

}  // namespace

Result<CatmullRomPath> CatmullRomPath::create(std::vector<glm::dvec3> pts, bool closed) {
  if (pts.size() < (closed ? 3u : 2u)) return fail("path: needs at least " + std::string(closed ? "3" : "2") + " waypoints");
  for (size_t i = 0; i < pts.size(); ++i) {
    if (!std::isfinite(pts[i].x) || !std::isfinite(pts[i].y) || !std::isfinite(pts[i].z))
      return fail("path: waypoint " + std::to_string(i) + ": not finite");
    if (std::fabs(pts[i].x) > kMaxPathCoordinateM || std::fabs(pts[i].y) > kMaxPathCoordinateM ||
        std::fabs(pts[i].z) > kMaxPathCoordinateM)
      return fail("path: waypoint " + std::to_string(i) + ": beyond +-" + std::to_string(int(kMaxPathCoordinateM / 1000)) +
                  " km of the origin");
    const size_t j = (i + 1) % pts.size();
    if ((j != 0 || closed) && glm::length(pts[j] - pts[i]) < 1e-3)
      return fail("path: waypoint " + std::to_string(j) + ": same as waypoint " + std::to_string(i));
  }
  CatmullRomPath p;
  p.points_ = std::move(pts);
  p.closed_ = closed;
  p.segments_ = closed ? p.points_.size() : p.points_.size() - 1;
  p.table_s_.resize(p.segments_ * kSamples + 1);
  double s = 0.0;
  glm::dvec3 prev = p.at(0, 0.0);
  p.table_s_[0] = 0.0;
  for (size_t seg = 0; seg < p.segments_; ++seg)
    for (int k = 1; k <= kSamples; ++k) {
      const glm::dvec3 q = p.at(seg, double(k) / kSamples);
      s += glm::length(q - prev);
      prev = q;
      p.table_s_[seg * kSamples + size_t(k)] = s;
    }
  p.length_m_ = s;
  return p;
}

glm::dvec3 CatmullRomPath::at(size_t seg, double t) const {
  const auto n = int64_t(points_.size());
  auto point = [&](int64_t i) {
    if (closed_) return points_[size_t(((i % n) + n) % n)];
    if (i < 0) return 2.0 * points_[0] - points_[1];  // mirrored neighbour: zero curvature at ends
    if (i >= n) return 2.0 * points_[size_t(n - 1)] - points_[size_t(n - 2)];
    return points_[size_t(i)];
  };
  const int64_t i = int64_t(seg);
  const glm::dvec3 p0 = point(i - 1), p1 = point(i), p2 = point(i + 1), p3 = point(i + 2);
  const double t2 = t * t, t3 = t2 * t;
  return 0.5 * ((2.0 * p1) + (-p0 + p2) * t + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2 + (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * t3);
}

glm::dvec3 CatmullRomPath::tangentAt(size_t seg, double t) const {
  constexpr double h = 1e-4;
  const double a = std::max(0.0, t - h), b = std::min(1.0, t + h);
  const glm::dvec3 d = at(seg, b) - at(seg, a);
  const double len = glm::length(d);
  return len > 0 ? d / len : glm::dvec3(1, 0, 0);
}

double CatmullRomPath::paramAt(double s, size_t& seg) const {
  if (closed_) {
    s = std::fmod(s, length_m_);
    if (s < 0) s += length_m_;
  } else {
    s = std::clamp(s, 0.0, length_m_);
  }
  auto it = std::upper_bound(table_s_.begin(), table_s_.end(), s);
  size_t k = it == table_s_.begin() ? 0 : size_t(it - table_s_.begin()) - 1;
  k = std::min(k, table_s_.size() - 2);
  const double s0 = table_s_[k], s1 = table_s_[k + 1];
  const double f = s1 > s0 ? (s - s0) / (s1 - s0) : 0.0;
  seg = k / kSamples;
  return (double(k % kSamples) + f) / kSamples;
}

glm::dvec3 CatmullRomPath::position(double s) const {
  size_t seg = 0;
  const double t = paramAt(s, seg);
  return at(seg, t);
}

glm::dvec3 CatmullRomPath::direction(double s) const {
  size_t seg = 0;
  const double t = paramAt(s, seg);
  return tangentAt(seg, t);
}

CatmullRomPath defaultFlightPath(const Manifest& m, bool loop) {
  glm::dvec3 lo = m.bounds_min, hi = m.bounds_max;
  for (int a = 0; a < 2; ++a)
    if (!(hi[a] - lo[a] >= 1.0)) hi[a] = lo[a] + 1.0;
  const double z = 0.5 * (lo.z + hi.z);
  auto at = [&](double fx, double fy) { return glm::dvec3(lo.x + fx * (hi.x - lo.x), lo.y + fy * (hi.y - lo.y), z); };
  std::vector<glm::dvec3> pts;
  if (loop)
    pts = {at(0.2, 0.2), at(0.5, 0.15), at(0.8, 0.2), at(0.85, 0.5), at(0.8, 0.8), at(0.5, 0.85), at(0.2, 0.8), at(0.15, 0.5)};
  else
    pts = {at(0.05, 0.1), at(0.3, 0.6), at(0.5, 0.3), at(0.7, 0.8), at(0.95, 0.9)};
  auto p = CatmullRomPath::create(std::move(pts), loop);
  DRTV_CHECK(p.has_value());  // distinct finite points by construction
  return std::move(*p);
}

Result<CatmullRomPath> loadFlightPath(const std::filesystem::path& path) {
  std::ifstream f(path);
  if (!f) return fail(path.string() + ": cannot open");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f);
  } catch (const nlohmann::json::exception& e) {
    return fail(path.string() + ": " + e.what());
  }
  if (!j.is_object() || !j.contains("waypoints") || !j["waypoints"].is_array())
    return fail(path.string() + ": expected {\"loop\": bool, \"waypoints\": [[x, y, z], ...]}");
  if (j.contains("loop") && !j["loop"].is_boolean()) return fail(path.string() + ": \"loop\": expected true or false");
  const bool loop = j.value("loop", false);
  std::vector<glm::dvec3> pts;
  for (size_t i = 0; i < j["waypoints"].size(); ++i) {
    const auto& w = j["waypoints"][i];
    if (!w.is_array() || w.size() != 3 || !w[0].is_number() || !w[1].is_number() || !w[2].is_number())
      return fail(path.string() + ": waypoints[" + std::to_string(i) + "]: expected [x, y, z] in metres");
    pts.push_back({w[0].get<double>(), w[1].get<double>(), w[2].get<double>()});
  }
  auto p = CatmullRomPath::create(std::move(pts), loop);
  if (!p) return std::unexpected(p.error().context(path.string()));
  return p;
}

}  // namespace drtv::fly
