// drtv/formats/sector.h — one 64 m x 64 m sector: its probes, nearest-probe index grid, the
// ground heights its distant-occlusion tile needs, and optionally its LPRT block.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slides 17, 22-24, 58.
//  [2] Kristensen, Akenine-Moeller, Jensen, "Precomputed Local Radiance Transfer for Real-Time
//      Lighting Design", SIGGRAPH 2005 (LPRT).
//
// Encoded sector (version 1; all integers and floats little-endian; offsets in bytes):
//
//    0   4  char    magic "DRTS"
//    4   2  uint16  version (1)
//    6   2  uint16  header size (64)
//    8   4  int32   ix              sector key: the sector covers x in [64 ix, 64 ix + 64)
//   12   4  int32   iy                                         and y in [64 iy, 64 iy + 64)
//   16   2  uint16  probe count     0..255
//   18   2  uint16  LPRT sources    0..128; 0 = no LPRT block at all
//   20   4  uint32  flags           kSectorHasGround | kSectorLprtOnBases; others rejected
//   24   4  float32 grid z min      world height of the index grid's bottom face, metres, |z| <= 1e6
//   28   4  float32 grid cell height metres, in [0.01, 1e5] (horizontal cells are 64/16 = 4 m)
//   32   4  float32 ground z min    range of the ground-height map, metres: |z| <= 1e6,
//   36   4  float32 ground z max    min <= max (checked when kSectorHasGround)
//   40   1  uint8   sun samples     K in 0..8; 0 = no sun-transfer block
//   41   1  uint8   reserved        zero
//   42   2  uint16  covered probes  C: the probes flagged kProbeCovered, each with a visibility map
//   44  20  uint8   reserved        zero
//   64        probes      probe count x 152 bytes (probe.h)
//   ..  4096  index grid  uint8 cells[z][y][x], 16^3, the index of the nearest probe; 255 = none
//   .. (128)  ground      uint16 unorm [y][x], 8x8: ground height at each 8 m cell centre, as
//                         z min + q/65535 (z max - z min); present iff kSectorHasGround
//   ..        LPRT, present iff LPRT sources > 0:
//               sources  S x 4 bytes: int8 dx, int8 dy (sector offset of the source probe's
//                        sector, in [-8, 8]), uint8 probe index, uint8 zero
//               coeffs   probe count x S x 3 x 4 int16, [probe][source][channel][k], snorm16 x
//                        that probe's lprt_range. With kSectorLprtOnBases, k indexes the four
//                        transfer bases: the bounced irradiance at a surface facing B_k from a
//                        unit white point light at the source (the runtime does one multiply per
//                        source and basis). Without it, k is the SH4 of the incoming radiance.
//   ..        sun transfer, present iff sun samples K > 0 (sh-l1 bakes; SunBlock below):
//               directions K x 3 float32: unit vectors towards the sun along the baked sun path,
//                          in path order, z >= -0.05
//               ranges     probe count x float32, each in [1e-30, 1e4]
//               coeffs     probe count x K x 3 x 4 int8, [probe][sample][channel][SH4], snorm8 x
//                          that probe's range (-128 never written)
//   ..        visibility, present iff C > 0 (visibility.h): C x kVisTexels x 2 uint8, the maps of
//             the covered probes in probe order, [probe][texel y * kVisDim + x][mean, deviation]
//   No trailing bytes.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "drtv/formats/error.h"
#include "drtv/formats/probe.h"
#include "drtv/formats/visibility.h"

namespace drtv {

inline constexpr double kSectorSizeM = 64.0;
inline constexpr int kMaxProbesPerSector = 255;
inline constexpr int kMaxLprtSources = 128;
inline constexpr int kGridDim = 16;                    // cells per axis
inline constexpr int kGridCells = kGridDim * kGridDim * kGridDim;
inline constexpr double kGridCellSizeM = kSectorSizeM / kGridDim;  // 4 m horizontally
inline constexpr uint8_t kNoProbe = 255;
// Grid cell height range, metres (the baker writes >= 1 m): a thinner cell, down to a denormal,
// would put every height at +-Inf cells; a taller one spans more than any world is high.
inline constexpr float kMinGridCellHeightM = 0.01f;
inline constexpr float kMaxGridCellHeightM = 1e5f;
inline constexpr int kGroundDim = 8;                   // 8 m cells
inline constexpr uint16_t kSectorVersion = 1;
inline constexpr size_t kSectorHeaderBytes = 64;

enum SectorFlag : uint32_t {
  kSectorHasGround = 1u << 0,
  kSectorLprtOnBases = 1u << 1,
};

struct SectorKey {
  int32_t ix = 0, iy = 0;
  friend bool operator==(const SectorKey&, const SectorKey&) = default;
  friend auto operator<=>(const SectorKey&, const SectorKey&) = default;
};
// "(3,-1)"
std::string toString(SectorKey key);
// The sector containing world position (x, y): floor(x / 64), floor(y / 64), clamped to the
// int32 range (NaN gives 0): total for any input.
SectorKey sectorAt(double x, double y);

// An inclusive range of sector keys, [x0, x1] x [y0, y1]; empty when either end is below the
// other.
struct SectorRange {
  int32_t x0 = 0, x1 = -1, y0 = 0, y1 = -1;
  bool empty() const { return x1 < x0 || y1 < y0; }
  size_t count() const { return empty() ? 0 : size_t(x1 - x0 + 1) * size_t(y1 - y0 + 1); }
  bool contains(SectorKey k) const { return k.ix >= x0 && k.ix <= x1 && k.iy >= y0 && k.iy <= y1; }
};

// Per-sector 16x16x16 nearest-probe grid [1, slide 17]. Cell (x, y, z) covers sector-relative
// [4x, 4x+4) x [4y, 4y+4) and world height [z_min_m + z h, z_min_m + (z+1) h), h = cell_height_m.
struct IndexGrid {
  float z_min_m = 0.f;
  float cell_height_m = 1.f;
  std::array<uint8_t, kGridCells> cells;  // [z][y][x]
  IndexGrid() { cells.fill(kNoProbe); }
  static constexpr int cellIndex(int x, int y, int z) { return (z * kGridDim + y) * kGridDim + x; }
  uint8_t at(int x, int y, int z) const { return cells[cellIndex(x, y, z)]; }
};

struct LprtSource {
  int8_t dx = 0, dy = 0;  // sector of the source probe, relative to this sector
  uint8_t probe = 0;      // its index in that sector
};

// Local radiance transfer for up to 128 source probes [2]; see the byte table above.
struct LprtBlock {
  // Each probe's snorm16 range is its ProbeRecord::lprt_range (no copy here: memory budget).
  std::vector<LprtSource> sources;      // S <= 128
  std::vector<int16_t> coeffs;          // probe count x S x 3 x 4 (k: Sector::lprt_on_bases)

  size_t index(size_t probe, size_t source, int channel, int k) const {
    return ((probe * sources.size() + source) * 3 + channel) * 4 + k;
  }
};

// The sun's first bounce along the baked sun path (issue 13; representation.h, "sh-l1 sun
// transfer"): for each of K sun directions d_k, per probe and channel, the SH4 of the bounced
// radiance arriving at the probe per unit of sun irradiance that the band-1 transfer's linear sun
// lobe gets wrong: the exact first bounce (each surface point's sun visibility traced along d_k)
// less what M L_sun(d_k) gives for it. The runtime adds the correction interpolated between the
// two samples nearest the sun's direction. 8 samples at most.
inline constexpr int kMaxSunSamples = 8;
struct SunBlock {
  std::vector<glm::vec3> directions;  // K unit vectors towards the sun, in path order
  std::vector<float> ranges;          // per probe: the snorm8 range of its coefficients
  std::vector<int8_t> coeffs;         // probe count x K x 3 x 4

  size_t samples() const { return directions.size(); }
  size_t index(size_t probe, size_t sample, int channel, int k) const {
    return ((probe * directions.size() + sample) * 3 + channel) * 4 + k;
  }
};

// An owning pointer to an optional block (SunBlock, VisibilityBlock) that copies it with the
// sector (so that Sector stays a value type), 8 bytes: a sector without one stays within the
// talk's 15 KB for 70 probes and the streamer's 51 within its 760 KiB.
template <class T>
class BlockPtr {
 public:
  BlockPtr() = default;
  BlockPtr(std::unique_ptr<T> p) : p_(std::move(p)) {}  // NOLINT: implicit, as unique_ptr's
  BlockPtr(const BlockPtr& o) : p_(o.p_ ? std::make_unique<T>(*o.p_) : nullptr) {}
  BlockPtr& operator=(const BlockPtr& o) {
    if (this != &o) p_ = o.p_ ? std::make_unique<T>(*o.p_) : nullptr;
    return *this;
  }
  BlockPtr(BlockPtr&&) noexcept = default;
  BlockPtr& operator=(BlockPtr&&) noexcept = default;
  explicit operator bool() const { return p_ != nullptr; }
  const T& operator*() const { return *p_; }
  const T* operator->() const { return p_.get(); }
  T* get() { return p_.get(); }

 private:
  std::unique_ptr<T> p_;
};
using SunBlockPtr = BlockPtr<SunBlock>;

// The visibility maps of the probes flagged kProbeCovered, in probe order: kVisBytesPerProbe
// each (visibility.h).
struct VisibilityBlock {
  std::vector<uint8_t> values;
};
using VisibilityBlockPtr = BlockPtr<VisibilityBlock>;

// A sector in memory: the decoded form of the bytes above. Value type.
struct Sector {
  SectorKey key;
  std::vector<ProbeRecord> probes;        // <= 255
  IndexGrid grid;
  bool has_ground = false;
  bool lprt_on_bases = true;              // LPRT k indexes transfer bases (true) or SH4 (false)
  float ground_z_min_m = 0.f, ground_z_max_m = 0.f;
  std::array<uint16_t, kGroundDim * kGroundDim> ground{};  // [y][x] unorm in the range above
  LprtBlock lprt;                         // empty sources = no LPRT
  SunBlockPtr sun;                        // null = no sun transfer
  VisibilityBlockPtr visibility;          // null = no probe is covered (kProbeCovered)

  bool hasLprt() const { return !lprt.sources.empty(); }
  // Bytes this sector occupies in memory: the struct plus the capacity of its vectors.
  size_t memoryBytes() const;
  // Ground height at 8 m cell (x, y), world metres.
  float groundHeight(int x, int y) const;
};

// Size of the encoded form of a sector with `probes` probes, `sources` LPRT sources,
// `sun_samples` sun-transfer samples and `covered` probes with visibility maps.
size_t encodedSectorBytes(size_t probes, size_t sources, bool has_ground, size_t sun_samples = 0, size_t covered = 0);
// The covered probes of `s`: those flagged kProbeCovered (each has a visibility map).
size_t coveredProbes(const Sector& s);
// The largest encoded sector (255 probes, 128 sources, ground map): a bound for readers.
size_t maxEncodedSectorBytes();
// The sun-transfer samples of a sector whose encoded form has `raw_bytes` with these counts (0
// for none), or nullopt when no sector of these counts has that size.
std::optional<size_t> sunSamplesOfEncodedSize(size_t raw_bytes, size_t probes, size_t sources, size_t covered = 0);

// The talk's sector without LPRT, "a little under 15 KB" for about 70 probes [slide 22], as
// encoded before zstd. A representation whose probes carry a sun transfer (sh-l1 of archive
// version 3) is allowed that transfer on top, for the same 70 probes: issue 13 allows the default
// probe record 1.5x the talk's 152 B, and 152 + 4 + 6 x 12 = 228 B is that record plus a 6-sample
// transfer. kTalkSectorBytes + sunTransferAllowanceBytes(6) = 20,392 B (docs/formats.md).
inline constexpr size_t kTalkSectorBytes = 15000;
inline constexpr size_t kTalkProbesPerSector = 70;
inline constexpr size_t sunTransferAllowanceBytes(size_t sun_samples) {
  return sun_samples == 0 ? 0 : sun_samples * 12 + kTalkProbesPerSector * (4 + sun_samples * 12);
}

// Encodes `sector`. Preconditions (bugs if broken, checked): probes <= 255, sources <= 128,
// coeffs sized to match, lprt_range 0 on every probe when there is no LPRT, grid indices < probe count or 255. Thread-safe.
std::vector<uint8_t> encodeSector(const Sector& sector);

// Decodes untrusted bytes. `where` names the source for messages (e.g. "island.drtv: sector
// (3,-1)"); every error reads "<where>: byte <offset>: <what>". Never aborts, never allocates
// more than the byte count allows. Thread-safe.
Result<Sector> decodeSector(std::span<const uint8_t> bytes, const std::string& where);

// Reads only the version field (after checking the magic).
Result<uint16_t> peekSectorVersion(std::span<const uint8_t> bytes, const std::string& where);

}  // namespace drtv
