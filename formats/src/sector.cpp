#include "drtv/formats/sector.h"

#include <algorithm>
#include <bitset>
#include <bit>
#include <climits>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "bytes.h"

namespace drtv {
namespace {

// Byte reductions of decodeSector's checks, kept out of line: inside that function (~5 KB of
// code) GCC 12 left them scalar, a compare and a conditional move per byte, 4,096 for a grid and
// ~4,600 for an island sector's sun transfer: ~1/4 of its time. On their own they vectorise.
[[gnu::noinline]] uint8_t maxPlusOne(const uint8_t* p, size_t n) {  // max of uint8_t(p[i] + 1)
  uint8_t m = 0;
  for (size_t i = 0; i < n; ++i) {
    const uint8_t v = uint8_t(p[i] + 1u);
    m = v > m ? v : m;
  }
  return m;
}
[[gnu::noinline]] int8_t leastByte(const int8_t* p, size_t n) {  // min(0, p[i])
  int8_t m = 0;
  for (size_t i = 0; i < n; ++i) m = p[i] < m ? p[i] : m;
  return m;
}


using detail::ByteReader;
using detail::ByteWriter;

constexpr char kSectorMagic[4] = {'D', 'R', 'T', 'S'};
constexpr uint32_t kKnownSectorFlags = kSectorHasGround | kSectorLprtOnBases;
constexpr size_t kProbeBytes = sizeof(ProbeRecord);
constexpr size_t kGroundBytes = kGroundDim * kGroundDim * 2;
constexpr size_t kLprtSourceBytes = 4;

void writeProbe(ByteWriter& w, const ProbeRecord& r) {
  const size_t start = w.size();
  for (float v : r.position) w.put(v);
  w.put(r.flags);
  w.put(r.interior);
  w.put(r.prt_range);
  for (const auto& c : r.prt)
    for (const auto& b : c)
      for (int16_t v : b) w.put(v);
  for (uint16_t v : r.sky_vis) w.put(v);
  for (int16_t v : r.sky_vis_sh) w.put(v);
  w.put(r.lprt_range);
  w.put(r.backface_frac);
  w.put(r.height_cm);
  w.put(r.mean_hit_m);
  for (int16_t v : r.sky_terms) w.put(v);
  DRTV_CHECK_EQ(w.size() - start, kProbeBytes);
}

// Field by field: the big-endian path (decodeSector copies the records whole on little-endian hosts).
[[maybe_unused]] void readProbe(ByteReader& rd, ProbeRecord& r) {
  for (float& v : r.position) rd.get(v);
  rd.get(r.flags);
  rd.get(r.interior);
  rd.get(r.prt_range);
  for (auto& c : r.prt)
    for (auto& b : c)
      for (int16_t& v : b) rd.get(v);
  for (uint16_t& v : r.sky_vis) rd.get(v);
  for (int16_t& v : r.sky_vis_sh) rd.get(v);
  rd.get(r.lprt_range);
  rd.get(r.backface_frac);
  rd.get(r.height_cm);
  rd.get(r.mean_hit_m);
  for (int16_t& v : r.sky_terms) rd.get(v);
}

std::unexpected<Error> failAt(const std::string& where, size_t offset, const std::string& what) {
  return fail(where + ": byte " + std::to_string(offset) + ": " + what);
}

}  // namespace

std::string toString(SectorKey key) { return "(" + std::to_string(key.ix) + "," + std::to_string(key.iy) + ")"; }

SectorKey sectorAt(double x, double y) {
  // Clamped so that the cast is defined for any input (NaN reads as 0).
  auto key = [](double v) {
    const double k = std::floor(v / kSectorSizeM);
    if (!(k == k)) return int32_t{0};
    return static_cast<int32_t>(std::clamp(k, double(INT32_MIN), double(INT32_MAX)));
  };
  return {key(x), key(y)};
}

size_t Sector::memoryBytes() const {
  return sizeof(Sector) + probes.capacity() * sizeof(ProbeRecord) + lprt.sources.capacity() * sizeof(LprtSource) +
         lprt.coeffs.capacity() * sizeof(int16_t) +
         (sun ? sizeof(SunBlock) + sun->directions.capacity() * sizeof(glm::vec3) +
                    sun->ranges.capacity() * sizeof(float) + sun->coeffs.capacity()
              : 0) +
         (visibility ? sizeof(VisibilityBlock) + visibility->values.capacity() : 0);
}

float Sector::groundHeight(int x, int y) const {
  const uint16_t q = ground[y * kGroundDim + x];
  return ground_z_min_m + dequantizeUnorm16(q) * (ground_z_max_m - ground_z_min_m);
}

size_t coveredProbes(const Sector& s) {
  size_t n = 0;
  for (const ProbeRecord& r : s.probes) n += (r.flags & kProbeCovered) != 0;
  return n;
}

size_t encodedSectorBytes(size_t probes, size_t sources, bool has_ground, size_t sun_samples, size_t covered) {
  size_t n = kSectorHeaderBytes + probes * kProbeBytes + kGridCells + covered * kVisBytesPerProbe;
  if (has_ground) n += kGroundBytes;
  if (sources > 0) n += sources * kLprtSourceBytes + probes * sources * 3 * 4 * sizeof(int16_t);
  if (sun_samples > 0) n += sun_samples * 12 + probes * (4 + sun_samples * 12);
  return n;
}

size_t maxEncodedSectorBytes() {
  return encodedSectorBytes(kMaxProbesPerSector, kMaxLprtSources, true, kMaxSunSamples, kMaxProbesPerSector);
}

std::optional<size_t> sunSamplesOfEncodedSize(size_t raw_bytes, size_t probes, size_t sources, size_t covered) {
  // A bake writes a sun block of 2..8 samples (validate in bake.cpp), or none.
  for (size_t sun = 0; sun <= size_t(kMaxSunSamples); sun += sun == 0 ? 2 : 1)
    if (raw_bytes == encodedSectorBytes(probes, sources, false, sun, covered) ||
        raw_bytes == encodedSectorBytes(probes, sources, true, sun, covered))
      return sun;
  return std::nullopt;
}

std::vector<uint8_t> encodeSector(const Sector& s) {
  const size_t n_probes = s.probes.size();
  const size_t n_sources = s.lprt.sources.size();
  DRTV_CHECK_LE(n_probes, size_t(kMaxProbesPerSector));
  DRTV_CHECK_LE(n_sources, size_t(kMaxLprtSources));
  if (n_sources > 0) {
    DRTV_CHECK_EQ(s.lprt.coeffs.size(), n_probes * n_sources * 12);
  }
  const size_t n_sun = s.sun ? s.sun->samples() : 0;
  DRTV_CHECK_LE(n_sun, size_t(kMaxSunSamples));
  if (s.sun) {
    DRTV_CHECK(n_sun > 0);
    DRTV_CHECK_EQ(s.sun->ranges.size(), n_probes);
    DRTV_CHECK_EQ(s.sun->coeffs.size(), n_probes * n_sun * 12);
  }
  for (uint8_t c : s.grid.cells) DRTV_CHECK(c == kNoProbe || c < n_probes);
  const size_t n_covered = coveredProbes(s);
  DRTV_CHECK_EQ(s.visibility ? s.visibility->values.size() : 0, n_covered * kVisValuesPerProbe);
  DRTV_CHECK(!s.visibility || n_covered > 0);

  std::vector<uint8_t> out;
  out.reserve(encodedSectorBytes(n_probes, n_sources, s.has_ground, n_sun, n_covered));
  ByteWriter w(out);
  w.bytes(kSectorMagic, 4);
  w.put<uint16_t>(kSectorVersion);
  w.put<uint16_t>(kSectorHeaderBytes);
  w.put<int32_t>(s.key.ix);
  w.put<int32_t>(s.key.iy);
  w.put<uint16_t>(static_cast<uint16_t>(n_probes));
  w.put<uint16_t>(static_cast<uint16_t>(n_sources));
  uint32_t flags = 0;
  if (s.has_ground) flags |= kSectorHasGround;
  if (n_sources > 0 && s.lprt_on_bases) flags |= kSectorLprtOnBases;
  w.put<uint32_t>(flags);
  w.put<float>(s.grid.z_min_m);
  w.put<float>(s.grid.cell_height_m);
  w.put<float>(s.ground_z_min_m);
  w.put<float>(s.ground_z_max_m);
  w.put<uint8_t>(static_cast<uint8_t>(n_sun));
  w.put<uint8_t>(0);
  w.put<uint16_t>(static_cast<uint16_t>(n_covered));
  w.zeros(kSectorHeaderBytes - w.size());
  for (const ProbeRecord& r : s.probes) {
    DRTV_CHECK(n_sources > 0 || r.lprt_range == 0.f);
    writeProbe(w, r);
  }
  w.bytes(s.grid.cells.data(), kGridCells);
  if (s.has_ground)
    for (uint16_t q : s.ground) w.put(q);
  if (n_sources > 0) {
    for (const LprtSource& src : s.lprt.sources) {
      w.put(src.dx);
      w.put(src.dy);
      w.put(src.probe);
      w.put<uint8_t>(0);
    }
    for (int16_t v : s.lprt.coeffs) w.put(v);
  }
  if (n_sun > 0) {
    for (const glm::vec3& d : s.sun->directions) {
      w.put(d.x);
      w.put(d.y);
      w.put(d.z);
    }
    for (float r : s.sun->ranges) w.put(r);
    for (int8_t v : s.sun->coeffs) w.put(v);
  }
  if (s.visibility) w.bytes(s.visibility->values.data(), s.visibility->values.size());
  DRTV_CHECK_EQ(out.size(), encodedSectorBytes(n_probes, n_sources, s.has_ground, n_sun, n_covered));
  return out;
}

Result<uint16_t> peekSectorVersion(std::span<const uint8_t> bytes, const std::string& where) {
  ByteReader rd(bytes);
  char magic[4];
  if (!rd.bytes(magic, 4)) return failAt(where, 0, "truncated: " + std::to_string(bytes.size()) + " bytes, no sector header");
  if (std::memcmp(magic, kSectorMagic, 4) != 0) return failAt(where, 0, "bad magic: not a drtv sector");
  uint16_t version;
  if (!rd.get(version)) return failAt(where, 4, "truncated before the version");
  return version;
}

Result<Sector> decodeSector(std::span<const uint8_t> bytes, const std::string& where) {
  auto version = peekSectorVersion(bytes, where);
  if (!version) return std::unexpected(version.error());
  if (*version != kSectorVersion)
    return failAt(where, 4, "version " + std::to_string(*version) + " unsupported (this build reads " +
                                std::to_string(kSectorVersion) + ")");
  if (bytes.size() < kSectorHeaderBytes)
    return failAt(where, bytes.size(), "truncated header: " + std::to_string(bytes.size()) + " of " +
                                           std::to_string(kSectorHeaderBytes) + " bytes");
  ByteReader rd(bytes);
  rd.skip(6);
  uint16_t header_bytes, n_probes, n_sources;
  uint32_t flags;
  Sector s;
  rd.get(header_bytes);
  if (header_bytes != kSectorHeaderBytes)
    return failAt(where, 6, "header size " + std::to_string(header_bytes) + ", expected " + std::to_string(kSectorHeaderBytes));
  rd.get(s.key.ix);
  rd.get(s.key.iy);
  rd.get(n_probes);
  rd.get(n_sources);
  rd.get(flags);
  rd.get(s.grid.z_min_m);
  rd.get(s.grid.cell_height_m);
  rd.get(s.ground_z_min_m);
  rd.get(s.ground_z_max_m);
  if (n_probes > kMaxProbesPerSector)
    return failAt(where, 16, "probe count " + std::to_string(n_probes) + " exceeds " + std::to_string(kMaxProbesPerSector));
  if (n_sources > kMaxLprtSources)
    return failAt(where, 18, "LPRT source count " + std::to_string(n_sources) + " exceeds " + std::to_string(kMaxLprtSources));
  if (flags & ~kKnownSectorFlags) return failAt(where, 20, "unknown flag bits " + std::to_string(flags & ~kKnownSectorFlags));
  if (n_sources == 0 && (flags & kSectorLprtOnBases)) return failAt(where, 20, "LPRT flag set without an LPRT block");
  if (!std::isfinite(s.grid.z_min_m) || std::fabs(s.grid.z_min_m) > 1e6f) return failAt(where, 24, "grid z min is not a sane height");
  if (!(s.grid.cell_height_m >= kMinGridCellHeightM && s.grid.cell_height_m <= kMaxGridCellHeightM))
    return failAt(where, 28, "grid cell height " + std::to_string(s.grid.cell_height_m) + " m outside [0.01, 1e5] m");
  s.has_ground = flags & kSectorHasGround;
  if (s.has_ground && !(std::isfinite(s.ground_z_min_m) && std::isfinite(s.ground_z_max_m) &&
                        s.ground_z_min_m <= s.ground_z_max_m && std::fabs(s.ground_z_min_m) <= 1e6f &&
                        std::fabs(s.ground_z_max_m) <= 1e6f))
    return failAt(where, 32, "ground height range is not finite and ordered");
  const size_t n_sun = bytes[40];
  if (n_sun > kMaxSunSamples)
    return failAt(where, 40, "sun sample count " + std::to_string(n_sun) + " exceeds " + std::to_string(kMaxSunSamples));
  const size_t n_covered = size_t(bytes[42]) | size_t(bytes[43]) << 8;
  if (n_covered > n_probes)
    return failAt(where, 42, "covered probe count " + std::to_string(n_covered) + " exceeds the probe count " + std::to_string(n_probes));
  for (size_t i = 41; i < kSectorHeaderBytes; ++i)
    if (bytes[i] != 0 && i != 42 && i != 43) return failAt(where, i, "reserved header byte is not zero");

  // The counts are now bounded, so the expected size is too: compare before any allocation.
  const size_t expected = encodedSectorBytes(n_probes, n_sources, s.has_ground, n_sun, n_covered);
  if (bytes.size() < expected)
    return failAt(where, bytes.size(), "truncated: " + std::to_string(bytes.size()) + " bytes, the header promises " +
                                           std::to_string(expected));
  if (bytes.size() > expected)
    return failAt(where, expected, std::to_string(bytes.size() - expected) + " trailing bytes");

  rd.skip(kSectorHeaderBytes - rd.offset());
  s.probes.resize(n_probes);
  // The record's memory layout is the file's (probe.h asserts every offset and the size, no
  // padding): on a little-endian host the probes are one copy, the rest is validation.
  const size_t probes_at = rd.offset();
  if constexpr (std::endian::native == std::endian::little) {
    static_assert(std::is_trivially_copyable_v<ProbeRecord>);
    rd.bytes(s.probes.data(), size_t(n_probes) * sizeof(ProbeRecord));
  } else {
    for (ProbeRecord& r : s.probes) readProbe(rd, r);
  }
  for (size_t i = 0; i < n_probes; ++i) {
    const size_t at = probes_at + i * sizeof(ProbeRecord);
    if (auto ok = validateProbe(s.probes[i]); !ok)
      return failAt(where, at, "probe " + std::to_string(i) + ": " + ok.error().message);
    if (n_sources == 0 && s.probes[i].lprt_range != 0.f)
      return failAt(where, at + 132, "probe " + std::to_string(i) + ": lprt_range set without an LPRT block");
  }
  if (const size_t flagged = coveredProbes(s); flagged != n_covered)
    return failAt(where, 42, "covered probe count " + std::to_string(n_covered) + ", but " + std::to_string(flagged) +
                                 " probes are flagged covered");
  const size_t grid_at = rd.offset();
  rd.bytes(s.grid.cells.data(), kGridCells);
  // One max reduction (maxPlusOne); the offending cell is searched for only on failure. c + 1
  // wraps kNoProbe (255) to 0, so the max is 1 + the largest probe index any cell names.
  static_assert(kNoProbe == 255);
  auto bad_cell = [n_probes](uint8_t c) { return c != kNoProbe && c >= n_probes; };
  const uint8_t max_named = maxPlusOne(s.grid.cells.data(), s.grid.cells.size());
  if (max_named > n_probes) {
    const int i = int(std::find_if(s.grid.cells.begin(), s.grid.cells.end(), bad_cell) - s.grid.cells.begin());
    return failAt(where, grid_at + i, "index grid cell names probe " + std::to_string(s.grid.cells[i]) + " of " +
                                          std::to_string(n_probes));
  }
  // A light source (kProbeLightSource) stands where a lamp does, often against its fitting: no
  // cell may name it.
  std::bitset<kMaxProbesPerSector> light_sources;
  for (size_t i = 0; i < n_probes; ++i) light_sources[i] = (s.probes[i].flags & kProbeLightSource) != 0;
  if (light_sources.any())
    for (size_t i = 0; i < kGridCells; ++i)
      if (s.grid.cells[i] != kNoProbe && light_sources[s.grid.cells[i]])
        return failAt(where, grid_at + i, "index grid cell names probe " + std::to_string(s.grid.cells[i]) +
                                              ", a light source (which no lookup reads)");
  if (s.has_ground)
    for (uint16_t& q : s.ground) rd.get(q);
  if (n_sources > 0) {
    s.lprt_on_bases = flags & kSectorLprtOnBases;
    s.lprt.sources.resize(n_sources);
    for (size_t j = 0; j < n_sources; ++j) {
      const size_t at = rd.offset();
      LprtSource& src = s.lprt.sources[j];
      uint8_t zero;
      rd.get(src.dx);
      rd.get(src.dy);
      rd.get(src.probe);
      rd.get(zero);
      if (src.dx < -8 || src.dx > 8 || src.dy < -8 || src.dy > 8)
        return failAt(where, at, "LPRT source " + std::to_string(j) + ": sector offset outside [-8, 8]");
      if (src.probe == kNoProbe) return failAt(where, at + 2, "LPRT source " + std::to_string(j) + ": probe index 255");
      if (zero != 0) return failAt(where, at + 3, "LPRT source " + std::to_string(j) + ": reserved byte is not zero");
    }
    s.lprt.coeffs.resize(size_t(n_probes) * n_sources * 12);
    const size_t coeff_at = rd.offset();
    for (size_t i = 0; i < s.lprt.coeffs.size(); ++i) {
      rd.get(s.lprt.coeffs[i]);
      if (s.lprt.coeffs[i] == -32768)
        return failAt(where, coeff_at + 2 * i, "LPRT coefficient -32768 is never written");
    }
  }
  if (n_sun > 0) {
    auto sun = std::make_unique<SunBlock>();
    sun->directions.resize(n_sun);
    for (size_t k = 0; k < n_sun; ++k) {
      const size_t at = rd.offset();
      glm::vec3& d = sun->directions[k];
      rd.get(d.x);
      rd.get(d.y);
      rd.get(d.z);
      // NaN fails both comparisons.
      if (!(std::fabs(glm::length(d) - 1.f) <= 1e-3f && d.z >= -0.05f))
        return failAt(where, at, "sun sample " + std::to_string(k) + ": not a unit vector at or above the horizon");
    }
    sun->ranges.resize(n_probes);
    for (size_t i = 0; i < n_probes; ++i) {
      const size_t at = rd.offset();
      rd.get(sun->ranges[i]);
      if (!(sun->ranges[i] >= kMinQuantizationRange && sun->ranges[i] <= kMaxPrtRange))
        return failAt(where, at, "probe " + std::to_string(i) + ": sun-transfer range outside [1e-30, 1e4]");
    }
    sun->coeffs.resize(size_t(n_probes) * n_sun * 12);
    const size_t coeff_at = rd.offset();
    rd.bytes(sun->coeffs.data(), sun->coeffs.size());
    // A reduction (leastByte); the offending byte is searched for only on failure.
    if (leastByte(sun->coeffs.data(), sun->coeffs.size()) == -128) {
      const size_t i = size_t(std::find(sun->coeffs.begin(), sun->coeffs.end(), int8_t(-128)) - sun->coeffs.begin());
      return failAt(where, coeff_at + i, "sun-transfer coefficient -128 is never written");
    }
    s.sun = std::move(sun);
  }
  if (n_covered > 0) {
    // Any two bytes are a mean and a deviation (visibility.h): nothing to refuse.
    auto vis = std::make_unique<VisibilityBlock>();
    vis->values.resize(n_covered * kVisBytesPerProbe);
    rd.bytes(vis->values.data(), vis->values.size());
    s.visibility = std::move(vis);
  }
  DRTV_CHECK(rd.ok());
  DRTV_CHECK_EQ(rd.offset(), bytes.size());
  return s;
}

}  // namespace drtv
