// topdown.cpp — see drtv/eval/topdown.h.
#include "drtv/eval/topdown.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "drtv/formats/sector.h"

namespace drtv::eval {
using namespace worlds;
namespace {

uint8_t toSrgb8(float linear) {
  const float c = std::clamp(linear, 0.f, 1.f);
  const float s = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
  return static_cast<uint8_t>(std::lround(s * 255.f));
}

glm::vec3 classTint(InstanceClass c) {
  switch (c) {
    case InstanceClass::kTerrain: return glm::vec3(1.f);
    case InstanceClass::kStatic: return glm::vec3(1.f);
    case InstanceClass::kVegetation: return glm::vec3(0.8f, 1.1f, 0.8f);
    case InstanceClass::kDynamic: return glm::vec3(1.2f, 1.0f, 1.2f);
  }
  return glm::vec3(1.f);
}

}  // namespace

image::RgbImage renderTopDown(const World& world, const TopDownOptions& o) {
  image::RgbImage img;
  const Bounds b = world.bounds();
  if (b.empty()) {
    img.width = img.height = 1;
    img.pixels.assign(3, 0);
    return img;
  }
  const double span_x = std::max(b.max.x - b.min.x, 1e-3), span_y = std::max(b.max.y - b.min.y, 1e-3);
  const double px_per_m = o.max_size_px / std::max(span_x, span_y);
  img.width = std::max(1, int(std::ceil(span_x * px_per_m)));
  img.height = std::max(1, int(std::ceil(span_y * px_per_m)));
  img.pixels.assign(size_t(img.width) * img.height * 3, 0);
  std::vector<float> depth(size_t(img.width) * img.height, -std::numeric_limits<float>::infinity());
  std::vector<glm::vec3> colour(depth.size(), glm::vec3(0.02f, 0.05f, 0.12f));  // sea / nothing
  const glm::vec3 light = glm::normalize(glm::vec3(-1.f, 1.f, 2.f));

  for (const Instance& inst : world.instances) {
    const Mesh& mesh = world.meshes[inst.mesh];
    const glm::vec3 base = mesh.albedo * classTint(inst.cls);
    for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      glm::dvec3 w[3];
      for (int k = 0; k < 3; ++k) w[k] = glm::dvec3(inst.transform * glm::dvec4(glm::dvec3(mesh.positions[mesh.indices[t + k]]), 1.0));
      glm::dvec3 n = glm::cross(w[1] - w[0], w[2] - w[0]);
      const double len = glm::length(n);
      if (!(len > 0)) continue;
      n /= len;
      if (n.z < 0) n = -n;  // seen from above, either face
      const float shade = 0.25f + 0.75f * std::max(0.f, glm::dot(glm::vec3(n), light));
      // Pixel-space vertices: x east, y down = north up.
      double sx[3], sy[3];
      for (int k = 0; k < 3; ++k) {
        sx[k] = (w[k].x - b.min.x) * px_per_m;
        sy[k] = (b.max.y - w[k].y) * px_per_m;
      }
      const double area = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sx[2] - sx[0]) * (sy[1] - sy[0]);
      if (std::fabs(area) < 1e-12) continue;
      const int x0 = std::max(0, int(std::floor(std::min({sx[0], sx[1], sx[2]}))));
      const int x1 = std::min(img.width - 1, int(std::ceil(std::max({sx[0], sx[1], sx[2]}))));
      const int y0 = std::max(0, int(std::floor(std::min({sy[0], sy[1], sy[2]}))));
      const int y1 = std::min(img.height - 1, int(std::ceil(std::max({sy[0], sy[1], sy[2]}))));
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const double px = x + 0.5, py = y + 0.5;
          const double l0 = ((sx[1] - px) * (sy[2] - py) - (sx[2] - px) * (sy[1] - py)) / area;
          const double l1 = ((sx[2] - px) * (sy[0] - py) - (sx[0] - px) * (sy[2] - py)) / area;
          const double l2 = 1.0 - l0 - l1;
          if (l0 < 0 || l1 < 0 || l2 < 0) continue;
          const float z = float(l0 * w[0].z + l1 * w[1].z + l2 * w[2].z);
          const size_t i = size_t(y) * img.width + x;
          if (z <= depth[i]) continue;
          depth[i] = z;
          colour[i] = base * shade;
        }
    }
  }
  // Sea level (z = 0) is not geometry: show what lies below it under water, deeper is darker.
  for (size_t i = 0; i < colour.size(); ++i)
    if (std::isfinite(depth[i]) && depth[i] < 0.f) {
      const float t = std::clamp(-depth[i] / 8.f, 0.f, 1.f);
      colour[i] = glm::mix(colour[i] * 0.6f + glm::vec3(0.05f, 0.2f, 0.35f), glm::vec3(0.01f, 0.04f, 0.15f), t);
    }
  for (size_t i = 0; i < colour.size(); ++i) {
    img.pixels[i * 3 + 0] = toSrgb8(colour[i].r);
    img.pixels[i * 3 + 1] = toSrgb8(colour[i].g);
    img.pixels[i * 3 + 2] = toSrgb8(colour[i].b);
  }
  auto toPx = [&](double x, double y) { return glm::ivec2(int((x - b.min.x) * px_per_m), int((b.max.y - y) * px_per_m)); };
  if (o.sector_grid) {
    for (double x = std::ceil(b.min.x / kSectorSizeM) * kSectorSizeM; x <= b.max.x; x += kSectorSizeM)
      for (int y = 0; y < img.height; y += 2) img.set(toPx(x, 0).x, y, 255, 255, 255);
    for (double y = std::ceil(b.min.y / kSectorSizeM) * kSectorSizeM; y <= b.max.y; y += kSectorSizeM)
      for (int x = 0; x < img.width; x += 2) img.set(x, toPx(0, y).y, 255, 255, 255);
  }
  if (o.interiors)
    for (const InteriorVolume& v : world.interiors) {
      const glm::ivec2 a = toPx(v.min.x, v.max.y), c = toPx(v.max.x, v.min.y);
      for (int x = a.x; x <= c.x; ++x) img.set(x, a.y, 255, 220, 0), img.set(x, c.y, 255, 220, 0);
      for (int y = a.y; y <= c.y; ++y) img.set(a.x, y, 255, 220, 0), img.set(c.x, y, 255, 220, 0);
    }
  return img;
}

}  // namespace drtv::eval
