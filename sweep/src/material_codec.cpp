#include "drtv/sweep/material_codec.h"

#include <cmath>
#include <cstring>
#include <string>

#include <zstd.h>

namespace drtv::sweep {
namespace {

constexpr uint32_t kMagic = 0x474D5344;  // "DSMG" little-endian
constexpr uint32_t kVersion = 1;
constexpr int kMaxAxisCells = 4096;

template <class T>
void put(std::vector<uint8_t>& out, size_t at, const T& v) {
  std::memcpy(out.data() + at, &v, sizeof v);
}
template <class T>
T get(std::span<const uint8_t> in, size_t at) {
  T v;
  std::memcpy(&v, in.data() + at, sizeof v);
  return v;
}

}  // namespace

std::vector<uint8_t> encodeMaterial(const MaterialGrid& m, int zstd_level) {
  const size_t cells = m.shape.cellCount();
  const size_t columns = size_t(m.shape.size.x) * size_t(m.shape.size.y);
  DRTV_CHECK(m.density.size() == cells && m.reflectance.size() == cells);
  DRTV_CHECK(m.ground_z.empty() || m.ground_z.size() == columns);
  DRTV_CHECK(cells >= 1 && cells <= kMaxMaterialCells);
  std::vector<float> raw;
  raw.reserve(4 * cells + m.ground_z.size());
  raw.insert(raw.end(), m.density.begin(), m.density.end());
  for (int c = 0; c < 3; ++c)
    for (const glm::vec3& r : m.reflectance) raw.push_back(r[c]);
  raw.insert(raw.end(), m.ground_z.begin(), m.ground_z.end());
  const size_t raw_bytes = raw.size() * sizeof(float);
  std::vector<uint8_t> out(kMaterialHeaderBytes + ZSTD_compressBound(raw_bytes));
  put(out, 0, kMagic);
  put(out, 4, kVersion);
  for (int a = 0; a < 3; ++a) put(out, 8 + 8 * a, m.shape.origin[a]);
  put(out, 32, m.shape.cell_m);
  for (int a = 0; a < 3; ++a) put(out, 40 + 4 * a, int32_t(m.shape.size[a]));
  put(out, 52, uint32_t(m.ground_z.size()));
  put(out, 56, uint64_t(raw_bytes));
  const size_t z = ZSTD_compress(out.data() + kMaterialHeaderBytes, out.size() - kMaterialHeaderBytes, raw.data(), raw_bytes, zstd_level);
  DRTV_CHECK(!ZSTD_isError(z));  // the bound holds by construction; only out-of-memory is left
  out.resize(kMaterialHeaderBytes + z);
  out.shrink_to_fit();
  return out;
}

Result<MaterialGrid> decodeMaterial(std::span<const uint8_t> in) {
  auto at = [](size_t offset, const std::string& what) { return fail("material grid: byte " + std::to_string(offset) + ": " + what); };
  if (in.size() < kMaterialHeaderBytes) return at(in.size(), "truncated header (" + std::to_string(in.size()) + " of 64 bytes)");
  if (get<uint32_t>(in, 0) != kMagic) return at(0, "bad magic");
  if (const uint32_t v = get<uint32_t>(in, 4); v != kVersion) return at(4, "version " + std::to_string(v) + " unsupported (max 1)");
  GridShape s;
  for (int a = 0; a < 3; ++a) s.origin[a] = get<double>(in, 8 + 8 * a);
  s.cell_m = get<double>(in, 32);
  if (!std::isfinite(s.origin.x) || !std::isfinite(s.origin.y) || !std::isfinite(s.origin.z)) return at(8, "origin not finite");
  if (!(std::isfinite(s.cell_m) && s.cell_m > 0)) return at(32, "cell size not a positive number");
  for (int a = 0; a < 3; ++a) {
    s.size[a] = get<int32_t>(in, 40 + 4 * a);
    if (s.size[a] < 1 || s.size[a] > kMaxAxisCells) return at(40 + 4 * a, "size " + std::to_string(s.size[a]) + " out of [1, 4096]");
  }
  const size_t cells = s.cellCount(), columns = size_t(s.size.x) * size_t(s.size.y);
  if (cells > kMaxMaterialCells) return at(40, std::to_string(cells) + " cells, more than the bound");
  const uint32_t ground = get<uint32_t>(in, 52);
  if (ground != 0 && ground != columns) return at(52, "ground_z count " + std::to_string(ground) + " neither 0 nor the columns");
  const uint64_t raw_bytes = get<uint64_t>(in, 56);
  if (raw_bytes != (4 * cells + ground) * sizeof(float)) return at(56, "payload of " + std::to_string(raw_bytes) + " bytes does not match the sizes");
  const uint8_t* src = in.data() + kMaterialHeaderBytes;
  const size_t src_bytes = in.size() - kMaterialHeaderBytes;
  const size_t frame = ZSTD_findFrameCompressedSize(src, src_bytes);
  if (ZSTD_isError(frame)) return at(kMaterialHeaderBytes, std::string("zstd: ") + ZSTD_getErrorName(frame));
  if (frame != src_bytes) return at(kMaterialHeaderBytes + frame, std::to_string(src_bytes - frame) + " trailing bytes");
  if (ZSTD_getFrameContentSize(src, src_bytes) != raw_bytes) return at(kMaterialHeaderBytes, "zstd frame's content size does not match the payload");
  std::vector<float> raw(raw_bytes / sizeof(float));
  const size_t got = ZSTD_decompress(raw.data(), raw_bytes, src, src_bytes);
  if (ZSTD_isError(got)) return at(kMaterialHeaderBytes, std::string("zstd: ") + ZSTD_getErrorName(got));
  if (got != raw_bytes) return at(kMaterialHeaderBytes, "zstd frame decoded to " + std::to_string(got) + " bytes");
  MaterialGrid m;
  m.shape = s;
  m.density.assign(raw.begin(), raw.begin() + cells);
  m.reflectance.resize(cells);
  for (int c = 0; c < 3; ++c)
    for (size_t i = 0; i < cells; ++i) m.reflectance[i][c] = raw[(1 + c) * cells + i];
  m.ground_z.assign(raw.begin() + 4 * cells, raw.end());
  for (size_t i = 0; i < cells; ++i)
    if (!(m.density[i] >= 0.f && m.density[i] <= 1.f)) return at(kMaterialHeaderBytes, "payload: density of cell " + std::to_string(i) + " outside [0, 1]");
  return m;
}

}  // namespace drtv::sweep
