// terrain.cpp — heightfields (see terrain.h).
#include "terrain.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>

#include "drtv/formats/memory_limit.h"
#include "noise.h"

namespace drtv::worlds {
namespace {
// Heights (4 B) kept beside the mesh's positions (12 B) and indices (24 B a cell).
constexpr double kHeightmapMeshBytesPerVertex = 4 + 12 + 24 + 4;
}  // namespace

bool Heightfield::contains(double x, double y) const {
  const double u = (x - origin.x) / spacing_m, v = (y - origin.y) / spacing_m;
  return u >= 0 && v >= 0 && u <= nx - 1 && v <= ny - 1;
}

double Heightfield::heightAt(double x, double y) const {
  if (nx < 2 || ny < 2) return nx && ny ? heights_m[0] : 0.0;
  const double u = std::clamp((x - origin.x) / spacing_m, 0.0, double(nx - 1));
  const double v = std::clamp((y - origin.y) / spacing_m, 0.0, double(ny - 1));
  const auto i = std::min(static_cast<uint32_t>(u), nx - 2), j = std::min(static_cast<uint32_t>(v), ny - 2);
  const double fu = u - i, fv = v - j;
  const double h00 = at(i, j), h10 = at(i + 1, j), h01 = at(i, j + 1), h11 = at(i + 1, j + 1);
  // Same split as heightfieldMesh: triangles (00,10,11) below the diagonal and (00,11,01) above.
  if (fu >= fv) return h00 + (h10 - h00) * fu + (h11 - h10) * fv;
  return h00 + (h01 - h00) * fv + (h11 - h01) * fu;
}

Mesh heightfieldMesh(const Heightfield& hf, std::string name, glm::vec3 albedo) {
  Mesh m;
  m.name = std::move(name);
  m.albedo = albedo;
  if (hf.nx < 2 || hf.ny < 2) return m;
  m.positions.reserve(size_t(hf.nx) * hf.ny);
  for (uint32_t j = 0; j < hf.ny; ++j)
    for (uint32_t i = 0; i < hf.nx; ++i)
      m.positions.emplace_back(float(i * hf.spacing_m), float(j * hf.spacing_m), hf.at(i, j));
  m.indices.reserve(size_t(hf.nx - 1) * (hf.ny - 1) * 6);
  for (uint32_t j = 0; j + 1 < hf.ny; ++j)
    for (uint32_t i = 0; i + 1 < hf.nx; ++i) {
      const uint32_t a = j * hf.nx + i, b = a + 1, c = a + hf.nx + 1, d = a + hf.nx;
      m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
    }
  return m;
}

Heightfield noiseHeightfield(double size_m, double resolution_m, double height_m, double feature_m, uint64_t seed) {
  Heightfield hf;
  const auto cells = static_cast<uint32_t>(std::max(1.0, std::round(size_m / resolution_m)));
  hf.nx = hf.ny = cells + 1;
  hf.spacing_m = size_m / cells;
  hf.origin = glm::dvec2(-0.5 * size_m);
  hf.heights_m.resize(size_t(hf.nx) * hf.ny);
  for (uint32_t j = 0; j < hf.ny; ++j)
    for (uint32_t i = 0; i < hf.nx; ++i) {
      const double x = i * hf.spacing_m / feature_m, y = j * hf.spacing_m / feature_m;
      hf.heights_m[size_t(j) * hf.nx + i] = float(height_m * 0.5 * (1.0 + noise::fbm2(seed, x, y, 4)));
    }
  return hf;
}

Result<Heightfield> loadHeightmapPng(const std::filesystem::path& path, double size_m, double height_m,
                                     double resolution_m) {
  const std::string file = path.string();
  // Only a regular file has an end: a world naming /dev/zero or a FIFO would read forever.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return fail(file + ": cannot open heightmap: not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(file + ": cannot open heightmap");
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  int w = 0, h = 0, channels = 0;
  std::vector<uint16_t> pixels;
  std::string error;
  // The decode holds 16-bit channels twice (stb's buffer and our copy); the mesh then takes
  // kHeightmapMeshBytesPerVertex per vertex. Refuse what cannot fit before decoding a byte.
  if (peekImageSize(bytes.data(), bytes.size(), w, h, channels)) {
    const double texels = double(w) * double(h);
    const double vertices = resolution_m > 0 ? std::pow(std::round(size_m / resolution_m) + 1, 2) : texels;
    const auto estimate = uint64_t(texels * channels * 4.0 + vertices * kHeightmapMeshBytesPerVertex);
    if (auto ok = checkMemory(estimate, file, "a " + std::to_string(w) + " x " + std::to_string(h) + " heightmap"); !ok)
      return std::unexpected(ok.error());
  }
  if (!decodeImage16(bytes.data(), bytes.size(), w, h, channels, pixels, error))
    return fail(file + ": cannot decode heightmap: " + error);
  if (w < 2 || h < 2) return fail(file + ": heightmap must be at least 2x2 texels, is " + std::to_string(w) + "x" + std::to_string(h));
  // The terrain is a square (docs/world-format.md): a non-square image would have to be
  // stretched or cropped, and either guess would surprise someone. Say so instead.
  if (w != h)
    return fail(file + ": heightmap is " + std::to_string(w) + "x" + std::to_string(h) +
                " texels: it must be square (the terrain is a square size_m wide)");
  // Grayscale (with or without alpha) is read as is. An RGB(A) image is accepted only when it is
  // grey in fact (R = G = B in every texel, as some tools save grayscale); a coloured one would be
  // taken by its red channel alone, which is never what was meant.
  if (channels >= 3) {
    for (size_t t = 0; t < size_t(w) * size_t(h); ++t) {
      const uint16_t* px = &pixels[t * size_t(channels)];
      if (px[0] != px[1] || px[0] != px[2])
        return fail(file + ": heightmap texel (" + std::to_string(t % size_t(w)) + ", " + std::to_string(t / size_t(w)) +
                    ") is coloured (R, G, B differ): expected a grayscale image");
    }
  }
  // Texel (0,0) is the image's top-left: put it at the north-west corner (+y up the image).
  auto texel = [&](double u, double v) {  // u, v in texels, bilinear
    u = std::clamp(u, 0.0, double(w - 1));
    v = std::clamp(v, 0.0, double(h - 1));
    const int i = std::min(int(u), w - 2), j = std::min(int(v), h - 2);
    const double fu = u - i, fv = v - j;
    auto p = [&](int a, int b) { return double(pixels[(size_t(b) * w + a) * channels]); };
    return (p(i, j) * (1 - fu) + p(i + 1, j) * fu) * (1 - fv) + (p(i, j + 1) * (1 - fu) + p(i + 1, j + 1) * fu) * fv;
  };
  Heightfield hf;
  if (resolution_m <= 0) {
    hf.nx = uint32_t(w);
    hf.ny = uint32_t(h);
  } else {
    const auto cells = static_cast<uint32_t>(std::max(1.0, std::round(size_m / resolution_m)));
    hf.nx = hf.ny = cells + 1;
  }
  hf.spacing_m = size_m / (hf.nx - 1);
  hf.origin = glm::dvec2(-0.5 * size_m);
  hf.heights_m.resize(size_t(hf.nx) * hf.ny);
  for (uint32_t j = 0; j < hf.ny; ++j)
    for (uint32_t i = 0; i < hf.nx; ++i) {
      const double u = double(i) * (w - 1) / (hf.nx - 1);
      const double v = double(hf.ny - 1 - j) * (h - 1) / (hf.ny - 1);
      hf.heights_m[size_t(j) * hf.nx + i] = float(texel(u, v) / 65535.0 * height_m);
    }
  return hf;
}

}  // namespace drtv::worlds
