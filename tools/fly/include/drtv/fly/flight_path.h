// drtv/streamer/flight_path.h — deterministic camera flights for `drtv fly` and the tests:
// uniform Catmull-Rom splines through waypoints, parametrised by arc length.
//
//  [1] Catmull & Rom, "A class of local interpolating splines", Computer Aided Geometric Design,
//      1974 (the uniform spline, tangent (p[i+1] - p[i-1]) / 2 at each waypoint).
//
// World metres, Z up. An open path passes through every waypoint (end tangents mirror the
// neighbour); a closed path (a loop) wraps around.
#pragma once

#include <filesystem>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/archive.h"
#include "drtv/formats/error.h"

namespace drtv::fly {

// Waypoints farther from the origin than this are an error: 10,000 km is far beyond any world the
// baker accepts, and keeps sector keys (coordinate / 64 m) and path lengths well inside int32
// and float precision limits.
inline constexpr double kMaxPathCoordinateM = 1e7;

class CatmullRomPath {
 public:
  // At least 2 waypoints (3 for a loop), finite, consecutive ones distinct (> 1 mm apart).
  // Error otherwise, naming the waypoint.
  // Errors: fewer than 2 (open) or 3 (closed) waypoints, a waypoint not finite or beyond
  // kMaxPathCoordinateM, two consecutive waypoints closer than 1 mm.
  static Result<CatmullRomPath> create(std::vector<glm::dvec3> waypoints, bool closed);

  double lengthM() const { return length_m_; }
  bool closed() const { return closed_; }
  const std::vector<glm::dvec3>& waypoints() const { return points_; }
  // Position at arc length `s_m`: clamped to [0, length] on an open path, wrapped on a loop.
  glm::dvec3 position(double s_m) const;
  // Unit tangent (direction of travel) at arc length `s_m`.
  glm::dvec3 direction(double s_m) const;

 private:
  glm::dvec3 at(size_t segment, double t) const;       // segment's spline at t in [0, 1]
  glm::dvec3 tangentAt(size_t segment, double t) const;
  double paramAt(double s_m, size_t& segment) const;  // arc length -> (segment, t)
  std::vector<glm::dvec3> points_;
  bool closed_ = false;
  size_t segments_ = 0;
  std::vector<double> table_s_;  // arc length at kSamples steps per segment
  double length_m_ = 0.0;
};

// A flight across the manifest's bounds: open, five waypoints from one corner region to the
// opposite one, weaving across the world; closed (`loop`), a rounded circuit inset by 20 %.
// Height: the middle of the bounds' z range. Bounds narrower than 1 m on x or y are widened.
CatmullRomPath defaultFlightPath(const Manifest& manifest, bool loop);

// Reads a path file: {"loop": false, "waypoints": [[x, y, z], ...]} (world metres). Errors name
// the file and the waypoint.
Result<CatmullRomPath> loadFlightPath(const std::filesystem::path& path);

}  // namespace drtv::fly
