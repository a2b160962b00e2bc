#include "drtv/formats/archive.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <system_error>

#include <xxhash.h>
#define ZSTD_STATIC_LINKING_ONLY  // ZSTD_estimateDCtxSize (exported by the shared library too)
#include <zstd.h>

#include "bytes.h"

namespace drtv {
namespace {

using detail::ByteReader;
using detail::ByteWriter;

constexpr char kArchiveMagic[8] = {'D', 'R', 'T', 'V', 'A', 'R', 'C', '\0'};
// A manifest holds at most this many settings; far beyond any bake's, small enough to bound work.
constexpr uint32_t kMaxSettings = 4096;
// Sectors in one archive: 2^20 sectors of 64 m cover 4,295 km^2, far beyond any island.
constexpr uint32_t kMaxSectors = 1u << 20;

std::string errnoText() { return std::error_code(errno, std::generic_category()).message(); }

std::unexpected<Error> failAt(const std::string& where, uint64_t offset, const std::string& what) {
  return fail(where + ": byte " + std::to_string(offset) + ": " + what);
}

uint64_t hash64(std::span<const uint8_t> bytes) { return XXH3_64bits(bytes.data(), bytes.size()); }

using Header = ArchiveHeader;

std::vector<uint8_t> encodeHeader(const Header& h) {
  std::vector<uint8_t> out;
  ByteWriter w(out);
  w.bytes(kArchiveMagic, 8);
  w.put<uint32_t>(h.version);
  w.put<uint32_t>(kArchiveHeaderBytes);
  w.put(h.manifest_offset);
  w.put(h.manifest_bytes);
  w.put(h.manifest_hash);
  w.put(h.file_bytes);
  w.zeros(kArchiveHeaderBytes - out.size());
  return out;
}

// Validates the 64-byte header against the actual file size.
Result<Header> parseHeader(std::span<const uint8_t> bytes, uint64_t actual_file_bytes, const std::string& where) {
  ByteReader rd(bytes);
  char magic[8];
  if (!rd.bytes(magic, 8)) return failAt(where, 0, "truncated: " + std::to_string(bytes.size()) + " bytes, not a drtv archive");
  if (std::memcmp(magic, kArchiveMagic, 8) != 0) return failAt(where, 0, "bad magic: not a drtv archive");
  Header h;
  if (!rd.get(h.version)) return failAt(where, 8, "truncated before the version");
  if (h.version != kArchiveVersionTalkBasis && h.version != kArchiveVersionShL1Moments && h.version != kArchiveVersion)
    return failAt(where, 8, "version " + std::to_string(h.version) + " unsupported (this build reads " +
                                std::to_string(kArchiveVersionTalkBasis) + " to " + std::to_string(kArchiveVersion) +
                                "): rebake the world with this build's `drtv bake`");
  uint32_t header_bytes = 0;
  rd.get(header_bytes);
  rd.get(h.manifest_offset);
  rd.get(h.manifest_bytes);
  rd.get(h.manifest_hash);
  rd.get(h.file_bytes);
  if (!rd.ok() || bytes.size() < kArchiveHeaderBytes)
    return failAt(where, bytes.size(), "truncated header: " + std::to_string(bytes.size()) + " of 64 bytes");
  if (header_bytes != kArchiveHeaderBytes) return failAt(where, 12, "header size " + std::to_string(header_bytes) + ", expected 64");
  for (size_t i = 48; i < kArchiveHeaderBytes; ++i)
    if (bytes[i] != 0) return failAt(where, i, "reserved header byte is not zero");
  if (h.file_bytes != actual_file_bytes)
    return failAt(where, 40, "the header says the file has " + std::to_string(h.file_bytes) + " bytes, it has " +
                                 std::to_string(actual_file_bytes) + (actual_file_bytes < h.file_bytes ? " (truncated)" : ""));
  if (h.manifest_offset < kArchiveHeaderBytes || h.manifest_offset > h.file_bytes ||
      h.manifest_bytes != h.file_bytes - h.manifest_offset)
    return failAt(where, 16, "manifest offset " + std::to_string(h.manifest_offset) + " and size " +
                                 std::to_string(h.manifest_bytes) + " do not end the file");
  return h;
}

void writeName(ByteWriter& w, const std::string& name) {
  DRTV_CHECK_LE(name.size(), size_t(UINT16_MAX));
  w.put<uint16_t>(static_cast<uint16_t>(name.size()));
  w.bytes(name.data(), name.size());
}
void writeVec(ByteWriter& w, const glm::dvec3& v) { for (int i = 0; i < 3; ++i) w.put<double>(v[i]); }
void writeVec(ByteWriter& w, const glm::vec3& v) { for (int i = 0; i < 3; ++i) w.put<float>(v[i]); }

void writeLighting(ByteWriter& w, const Manifest& m) {
  w.put<double>(m.sky.latitude_rad);
  w.put<double>(m.sky.declination_rad);
  w.put<double>(m.sky.north_rad);
  w.put<float>(m.sky.ground_radiance_scale);
  for (const Gradient* g : {&m.sky.sun_irradiance, &m.sky.sky_zenith, &m.sky.sky_horizon}) {
    w.put<uint32_t>(static_cast<uint32_t>(g->keys.size()));
    for (const ColorKey& k : g->keys) {
      w.put<float>(k.hour);
      writeVec(w, k.value);
    }
  }
  w.put<uint32_t>(static_cast<uint32_t>(m.lights.size()));
  for (const PointLight& l : m.lights) {
    writeName(w, l.name);
    writeVec(w, l.position);
    writeVec(w, l.intensity);
    w.put<float>(l.radius_m);
  }
  w.put<uint32_t>(static_cast<uint32_t>(m.interiors.size()));
  for (const InteriorVolume& v : m.interiors) {
    writeName(w, v.name);
    writeVec(w, v.min);
    writeVec(w, v.max);
    writeVec(w, v.probe_position);
    w.put<float>(v.blend_distance_m);
  }
}

// Reads a count and checks that `min_item_bytes` per item fit in what is left.
bool readCount(ByteReader& rd, uint32_t& n, size_t min_item_bytes) {
  return rd.get(n) && n <= rd.remaining() / min_item_bytes;
}
bool readName(ByteReader& rd, std::string& name) {
  uint16_t len = 0;
  if (!rd.get(len) || len > rd.remaining()) return false;
  name.resize(len);
  return rd.bytes(name.data(), len);
}
bool readVec(ByteReader& rd, glm::dvec3& v) { return rd.get(v.x) && rd.get(v.y) && rd.get(v.z); }
bool readVec(ByteReader& rd, glm::vec3& v) { return rd.get(v.x) && rd.get(v.y) && rd.get(v.z); }

// Returns "" or what went wrong (the caller adds the offset).
std::string readLighting(ByteReader& rd, Manifest& m) {
  rd.get(m.sky.latitude_rad);
  rd.get(m.sky.declination_rad);
  rd.get(m.sky.north_rad);
  rd.get(m.sky.ground_radiance_scale);
  for (Gradient* g : {&m.sky.sun_irradiance, &m.sky.sky_zenith, &m.sky.sky_horizon}) {
    uint32_t n = 0;
    if (!readCount(rd, n, 16)) return "a gradient's key count exceeds the bytes left";
    g->keys.resize(n);
    for (ColorKey& k : g->keys) {
      rd.get(k.hour);
      readVec(rd, k.value);
    }
  }
  uint32_t n_lights = 0;
  if (!readCount(rd, n_lights, 2 + 24 + 12 + 4)) return "the light count exceeds the bytes left";
  m.lights.resize(n_lights);
  for (PointLight& l : m.lights) {
    if (!readName(rd, l.name)) return "truncated in a light's name";
    readVec(rd, l.position);
    readVec(rd, l.intensity);
    rd.get(l.radius_m);
  }
  uint32_t n_interiors = 0;
  if (!readCount(rd, n_interiors, 2 + 72 + 4)) return "the interior count exceeds the bytes left";
  m.interiors.resize(n_interiors);
  for (InteriorVolume& v : m.interiors) {
    if (!readName(rd, v.name)) return "truncated in an interior's name";
    readVec(rd, v.min);
    readVec(rd, v.max);
    readVec(rd, v.probe_position);
    rd.get(v.blend_distance_m);
  }
  if (!rd.ok()) return "truncated in the lighting";
  if (auto ok = validateLighting(m.sky, m.lights, m.interiors); !ok) return ok.error().message;
  return {};
}

std::vector<uint8_t> encodeManifest(const Manifest& m) {
  std::vector<uint8_t> out;
  ByteWriter w(out);
  for (int i = 0; i < 3; ++i) w.put<double>(m.bounds_min[i]);
  for (int i = 0; i < 3; ++i) w.put<double>(m.bounds_max[i]);
  w.put<double>(m.sector_size_m);
  w.put<uint32_t>(m.effects);
  if (archiveVersionFor(m.representation) != kArchiveVersionTalkBasis) w.put<uint32_t>(static_cast<uint32_t>(m.representation));
  w.put<uint32_t>(static_cast<uint32_t>(m.settings.size()));
  for (const auto& [k, v] : m.settings) {
    DRTV_CHECK_LE(k.size(), size_t(UINT16_MAX));
    w.put<uint16_t>(static_cast<uint16_t>(k.size()));
    w.bytes(k.data(), k.size());
    w.put<uint32_t>(static_cast<uint32_t>(v.size()));
    w.bytes(v.data(), v.size());
  }
  writeLighting(w, m);
  w.put<uint32_t>(static_cast<uint32_t>(m.sectors.size()));
  for (const SectorEntry& e : m.sectors) {
    w.put(e.key.ix);
    w.put(e.key.iy);
    w.put(e.offset);
    w.put(e.compressed_bytes);
    w.put(e.raw_bytes);
    w.put(e.hash);
    w.put(e.probes);
    w.put(e.lprt_sources);
    w.put(e.covered);
    w.put<uint16_t>(0);
  }
  return out;
}

// `base` is the manifest's offset in the file, so that messages give file offsets.
Result<Manifest> parseManifest(std::span<const uint8_t> bytes, uint32_t version, uint64_t base, uint64_t payload_end,
                               const std::string& where) {
  ByteReader rd(bytes);
  Manifest m;
  auto at = [&] { return base + rd.offset(); };
  auto truncated = [&](const char* what) { return failAt(where, at(), std::string("manifest truncated in ") + what); };
  for (int i = 0; i < 3; ++i) rd.get(m.bounds_min[i]);
  for (int i = 0; i < 3; ++i) rd.get(m.bounds_max[i]);
  if (!rd.ok()) return truncated("the bounds");
  for (int i = 0; i < 3; ++i)
    if (!(std::fabs(m.bounds_min[i]) <= kMaxWorldCoordinateM && std::fabs(m.bounds_max[i]) <= kMaxWorldCoordinateM) ||
        m.bounds_min[i] > m.bounds_max[i])
      return failAt(where, base + 8 * i, "manifest bounds are not ordered and within [-1e8, 1e8] m");
  const uint64_t size_at = at();
  if (!rd.get(m.sector_size_m)) return truncated("the sector size");
  if (m.sector_size_m != kSectorSizeM)
    return failAt(where, size_at, "sector size " + std::to_string(m.sector_size_m) + " m, this build reads 64 m");
  const uint64_t effects_at = at();
  if (!rd.get(m.effects)) return truncated("the effects");
  if (m.effects & ~kAllEffects) return failAt(where, effects_at, "unknown effect bits " + std::to_string(m.effects & ~kAllEffects));
  m.version = version;
  m.representation = Representation::kFc3;
  if (version != kArchiveVersionTalkBasis) {
    const uint64_t repr_at = at();
    uint32_t code = 0;
    if (!rd.get(code)) return truncated("the representation");
    if (code >= kRepresentationCount)
      return failAt(where, repr_at, "representation " + std::to_string(code) + " unknown (this build reads " + representationNames() +
                                        " = 0.." + std::to_string(kRepresentationCount - 1) +
                                        "): rebake the world with this build's `drtv bake --representation`");
    m.representation = Representation(code);
    if (m.representation == Representation::kFc3)
      return failAt(where, repr_at, "representation fc3 in a version-" + std::to_string(version) + " manifest (fc3 archives are version 1)");
  }
  uint32_t n_settings = 0;
  const uint64_t settings_at = at();
  if (!rd.get(n_settings)) return truncated("the settings count");
  // Each setting takes at least 6 bytes, so the count is bounded by what is left.
  if (n_settings > kMaxSettings || n_settings > rd.remaining() / 6)
    return failAt(where, settings_at, "settings count " + std::to_string(n_settings) + " is absurd for " +
                                          std::to_string(rd.remaining()) + " remaining bytes");
  m.settings.reserve(n_settings);
  for (uint32_t i = 0; i < n_settings; ++i) {
    uint16_t klen = 0;
    uint32_t vlen = 0;
    std::string k, v;
    if (!rd.get(klen) || klen > rd.remaining()) return truncated("a setting's key");
    k.resize(klen);
    rd.bytes(k.data(), klen);
    if (!rd.get(vlen) || vlen > rd.remaining()) return truncated("a setting's value");
    v.resize(vlen);
    rd.bytes(v.data(), vlen);
    m.settings.emplace_back(std::move(k), std::move(v));
  }
  const uint64_t lighting_at = at();
  if (std::string what = readLighting(rd, m); !what.empty()) return failAt(where, lighting_at, "manifest lighting: " + what);
  uint32_t n_sectors = 0;
  const uint64_t count_at = at();
  if (!rd.get(n_sectors)) return truncated("the sector count");
  if (n_sectors > kMaxSectors || uint64_t(n_sectors) * kArchiveSectorEntryBytes != rd.remaining())
    return failAt(where, count_at, "sector count " + std::to_string(n_sectors) + " does not match the " +
                                       std::to_string(rd.remaining()) + " bytes of sector entries");
  m.sectors.resize(n_sectors);
  const uint64_t max_raw = maxEncodedSectorBytes();
  for (uint32_t i = 0; i < n_sectors; ++i) {
    const uint64_t entry_at = at();
    SectorEntry& e = m.sectors[i];
    uint16_t zero = 0;
    rd.get(e.key.ix);
    rd.get(e.key.iy);
    rd.get(e.offset);
    rd.get(e.compressed_bytes);
    rd.get(e.raw_bytes);
    rd.get(e.hash);
    rd.get(e.probes);
    rd.get(e.lprt_sources);
    rd.get(e.covered);
    rd.get(zero);
    const std::string name = "sector " + toString(e.key) + " entry: ";
    if (i > 0 && !(m.sectors[i - 1].key < e.key)) return failAt(where, entry_at, name + "keys are not sorted and unique");
    if (e.offset < kArchiveHeaderBytes || e.offset > payload_end || e.compressed_bytes > payload_end - e.offset)
      return failAt(where, entry_at + 8, name + "payload [" + std::to_string(e.offset) + ", +" +
                                             std::to_string(e.compressed_bytes) + ") lies outside the payload area");
    if (e.compressed_bytes == 0) return failAt(where, entry_at + 16, name + "empty payload");
    if (e.probes > kMaxProbesPerSector || e.lprt_sources > kMaxLprtSources)
      return failAt(where, entry_at + 32, name + "probe or LPRT source count out of range");
    if (e.covered > e.probes) return failAt(where, entry_at + 36, name + "more covered probes than probes");
    // One of the sizes a sector of these counts can have: with or without its ground map, and
    // with a sun-transfer block of 2..8 samples or none.
    const bool fits = sunSamplesOfEncodedSize(e.raw_bytes, e.probes, e.lprt_sources, e.covered).has_value();
    if (!fits || e.raw_bytes > max_raw)
      return failAt(where, entry_at + 20, name + "raw size " + std::to_string(e.raw_bytes) + " does not fit " +
                                              std::to_string(e.probes) + " probes");
    if (zero != 0) return failAt(where, entry_at + 38, name + "reserved field is not zero");
  }
  DRTV_CHECK(rd.ok() && rd.remaining() == 0);
  return m;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

const SectorEntry* Manifest::find(SectorKey key) const {
  auto it = std::lower_bound(sectors.begin(), sectors.end(), key,
                             [](const SectorEntry& e, SectorKey k) { return e.key < k; });
  return it != sectors.end() && it->key == key ? &*it : nullptr;
}

std::string Manifest::setting(const std::string& key) const {
  for (const auto& [k, v] : settings)
    if (k == key) return v;
  return {};
}

Result<std::vector<uint8_t>> zstdDecompress(std::span<const uint8_t> frame, size_t raw_bytes, const std::string& where) {
  const unsigned long long content = ZSTD_getFrameContentSize(frame.data(), frame.size());
  if (content == ZSTD_CONTENTSIZE_ERROR) return fail(where + ": not a zstd frame");
  if (content != ZSTD_CONTENTSIZE_UNKNOWN && content != raw_bytes)
    return fail(where + ": zstd frame holds " + std::to_string(content) + " bytes, the manifest says " + std::to_string(raw_bytes));
  // A reused context decodes a 15 KB sector in ~11 us instead of ~27 us (DESIGN.md).
  thread_local std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> dctx(ZSTD_createDCtx(), ZSTD_freeDCtx);
  std::vector<uint8_t> out(raw_bytes);
  const size_t n = ZSTD_decompressDCtx(dctx.get(), out.data(), out.size(), frame.data(), frame.size());
  if (ZSTD_isError(n)) return fail(where + ": zstd: " + ZSTD_getErrorName(n));
  if (n != raw_bytes) return fail(where + ": zstd frame holds " + std::to_string(n) + " bytes, the manifest says " + std::to_string(raw_bytes));
  return out;
}

size_t zstdContextBytes() { return ZSTD_estimateDCtxSize(); }

Result<ArchiveHeader> decodeArchiveHeader(std::span<const uint8_t> head, uint64_t file_bytes, const std::string& where) {
  return parseHeader(head.first(std::min(head.size(), kArchiveHeaderBytes)), file_bytes, where);
}

Result<Manifest> decodeArchiveManifest(const ArchiveHeader& header, std::span<const uint8_t> manifest, const std::string& where) {
  if (manifest.size() != header.manifest_bytes)
    return failAt(where, header.manifest_offset + manifest.size(), "manifest truncated: " + std::to_string(manifest.size()) + " of " +
                                                                         std::to_string(header.manifest_bytes) + " bytes");
  if (hash64(manifest) != header.manifest_hash) return failAt(where, header.manifest_offset, "manifest hash mismatch (corrupt)");
  return parseManifest(manifest, header.version, header.manifest_offset, header.manifest_offset, where);
}

Result<Manifest> decodeArchiveHeaderAndManifest(std::span<const uint8_t> file, const std::string& where) {
  auto header = decodeArchiveHeader(file, file.size(), where);
  if (!header) return std::unexpected(header.error());
  return decodeArchiveManifest(*header, file.subspan(header->manifest_offset, header->manifest_bytes), where);
}

// ---- reader -----------------------------------------------------------------------------------

struct ArchiveReader::Impl {
  std::filesystem::path path;
  std::string name;  // path as text, for messages
  int fd = -1;
  Manifest manifest;
  ~Impl() {
    if (fd >= 0) ::close(fd);
  }
  // Reads exactly n bytes at offset; false on a short read or error.
  bool readAt(void* dst, size_t n, uint64_t offset) const {
    auto* p = static_cast<uint8_t*>(dst);
    while (n > 0) {
      const ssize_t got = ::pread(fd, p, n, static_cast<off_t>(offset));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) return false;
      p += got;
      n -= size_t(got);
      offset += uint64_t(got);
    }
    return true;
  }
};

ArchiveReader::ArchiveReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ArchiveReader::ArchiveReader(ArchiveReader&&) noexcept = default;
ArchiveReader& ArchiveReader::operator=(ArchiveReader&&) noexcept = default;
ArchiveReader::~ArchiveReader() = default;
const Manifest& ArchiveReader::manifest() const { return impl_->manifest; }
const std::filesystem::path& ArchiveReader::path() const { return impl_->path; }

Result<ArchiveReader> ArchiveReader::open(const std::filesystem::path& path) {
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  impl->name = path.string();
  impl->fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (impl->fd < 0) return fail(impl->name + ": cannot open: " + errnoText());
  const off_t end = ::lseek(impl->fd, 0, SEEK_END);
  if (end < 0) return fail(impl->name + ": cannot seek: " + errnoText());
  const uint64_t file_bytes = uint64_t(end);
  std::vector<uint8_t> head(std::min<uint64_t>(file_bytes, kArchiveHeaderBytes));
  if (!impl->readAt(head.data(), head.size(), 0)) return fail(impl->name + ": cannot read the header: " + errnoText());
  auto header = parseHeader(head, file_bytes, impl->name);
  if (!header) return std::unexpected(header.error());
  // parseHeader bounded manifest_bytes by the real file size: the allocation is safe.
  std::vector<uint8_t> manifest(header->manifest_bytes);
  if (!impl->readAt(manifest.data(), manifest.size(), header->manifest_offset))
    return fail(impl->name + ": cannot read the manifest: " + errnoText());
  auto parsed = decodeArchiveManifest(*header, manifest, impl->name);
  if (!parsed) return std::unexpected(parsed.error());
  impl->manifest = std::move(*parsed);
  return ArchiveReader(std::move(impl));
}

Result<std::vector<uint8_t>> ArchiveReader::readCompressed(SectorKey key) const {
  const std::string where = impl_->name + ": sector " + toString(key);
  const SectorEntry* e = impl_->manifest.find(key);
  if (!e) return fail(where + ": not in this archive");
  std::vector<uint8_t> bytes(e->compressed_bytes);  // bounded by the file size in parseManifest
  if (!impl_->readAt(bytes.data(), bytes.size(), e->offset))
    return fail(where + ": byte " + std::to_string(e->offset) + ": cannot read " + std::to_string(bytes.size()) +
                " bytes: " + (errno ? errnoText() : std::string("file shrank")));
  if (hash64(bytes) != e->hash) return fail(where + ": byte " + std::to_string(e->offset) + ": payload hash mismatch (corrupt)");
  return bytes;
}

Result<std::vector<uint8_t>> ArchiveReader::readSectorBytes(SectorKey key) const {
  auto compressed = readCompressed(key);
  if (!compressed) return std::unexpected(compressed.error());
  const SectorEntry* e = impl_->manifest.find(key);
  return zstdDecompress(*compressed, e->raw_bytes, impl_->name + ": sector " + toString(key));
}

Result<Sector> decodeSectorPayload(const SectorEntry& e, std::span<const uint8_t> compressed, const std::string& where) {
  if (compressed.size() != e.compressed_bytes)
    return fail(where + ": byte " + std::to_string(e.offset + compressed.size()) + ": short read: " + std::to_string(compressed.size()) +
                " of " + std::to_string(e.compressed_bytes) + " bytes");
  if (hash64(compressed) != e.hash) return fail(where + ": byte " + std::to_string(e.offset) + ": payload hash mismatch (corrupt)");
  auto raw = zstdDecompress(compressed, e.raw_bytes, where);
  if (!raw) return std::unexpected(raw.error());
  auto sector = decodeSector(*raw, where);
  if (!sector) return sector;
  if (sector->key != e.key) return fail(where + ": byte 8: payload holds sector " + toString(sector->key));
  if (sector->probes.size() != e.probes || sector->lprt.sources.size() != e.lprt_sources || coveredProbes(*sector) != e.covered)
    return fail(where + ": payload counts differ from the manifest's");
  return sector;
}

Result<Sector> ArchiveReader::readSector(SectorKey key) const {
  auto compressed = readCompressed(key);  // read and hash-checked
  if (!compressed) return std::unexpected(compressed.error());
  return decodeSectorPayload(*impl_->manifest.find(key), *compressed, impl_->name + ": sector " + toString(key));
}

Result<uint32_t> peekArchiveVersion(const std::filesystem::path& path) {
  const std::string name = path.string();
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return fail(name + ": cannot open: " + errnoText());
  uint8_t head[12];
  const ssize_t got = ::pread(fd, head, sizeof head, 0);
  ::close(fd);
  if (got < 12) return failAt(name, std::max<ssize_t>(got, 0), "truncated: not a drtv archive");
  if (std::memcmp(head, kArchiveMagic, 8) != 0) return failAt(name, 0, "bad magic: not a drtv archive");
  ByteReader rd(std::span<const uint8_t>(head + 8, 4));
  uint32_t version = 0;
  rd.get(version);
  return version;
}

// ---- writer -----------------------------------------------------------------------------------

struct ArchiveWriter::Impl {
  std::filesystem::path path, partial;
  int fd = -1;
  int level = 3;
  uint64_t offset = kArchiveHeaderBytes;
  std::vector<SectorEntry> entries;
  ZSTD_CCtx* cctx = nullptr;
  bool finished = false;
  ~Impl() {
    if (cctx) ZSTD_freeCCtx(cctx);
    if (fd >= 0) {
      ::close(fd);
      // No half archive left behind. The non-throwing overload: a destructor must not throw, and
      // a partial file that cannot be removed is only litter (the next create truncates it).
      std::error_code ignored;
      if (!finished) std::filesystem::remove(partial, ignored);
    }
  }
  Result<void> writeAt(const void* data, size_t n, uint64_t at) {
    const auto* p = static_cast<const uint8_t*>(data);
    while (n > 0) {
      const ssize_t put = ::pwrite(fd, p, n, static_cast<off_t>(at));
      if (put < 0 && errno == EINTR) continue;
      if (put <= 0) return fail(partial.string() + ": write failed: " + errnoText());
      p += put;
      n -= size_t(put);
      at += uint64_t(put);
    }
    return {};
  }
};

ArchiveWriter::ArchiveWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ArchiveWriter::ArchiveWriter(ArchiveWriter&&) noexcept = default;
ArchiveWriter& ArchiveWriter::operator=(ArchiveWriter&&) noexcept = default;
ArchiveWriter::~ArchiveWriter() = default;

Result<ArchiveWriter> ArchiveWriter::create(const std::filesystem::path& path, int zstd_level) {
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  impl->partial = path;
  impl->partial += ".partial";
  impl->level = zstd_level;
  impl->fd = ::open(impl->partial.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (impl->fd < 0) return fail(impl->partial.string() + ": cannot create: " + errnoText());
  impl->cctx = ZSTD_createCCtx();
  DRTV_CHECK(impl->cctx != nullptr);
  const std::vector<uint8_t> placeholder(kArchiveHeaderBytes, 0);
  if (auto ok = impl->writeAt(placeholder.data(), placeholder.size(), 0); !ok) return std::unexpected(ok.error());
  return ArchiveWriter(std::move(impl));
}

Result<void> ArchiveWriter::addSector(const Sector& sector) { return addEncodedSector(encodeSector(sector)); }

Result<void> ArchiveWriter::addEncodedSector(std::span<const uint8_t> encoded) {
  Impl& s = *impl_;
  DRTV_CHECK(!s.finished);
  auto decoded = decodeSector(encoded, s.partial.string() + ": new sector");
  if (!decoded) return std::unexpected(decoded.error());
  for (const SectorEntry& e : s.entries)
    if (e.key == decoded->key) return fail(s.path.string() + ": sector " + toString(e.key) + " added twice");
  std::vector<uint8_t> frame(ZSTD_compressBound(encoded.size()));
  const size_t n = ZSTD_compressCCtx(s.cctx, frame.data(), frame.size(), encoded.data(), encoded.size(), s.level);
  if (ZSTD_isError(n)) return fail(s.partial.string() + ": zstd: " + ZSTD_getErrorName(n));
  frame.resize(n);
  if (auto ok = s.writeAt(frame.data(), frame.size(), s.offset); !ok) return ok;
  SectorEntry e;
  e.key = decoded->key;
  e.offset = s.offset;
  e.compressed_bytes = static_cast<uint32_t>(frame.size());
  e.raw_bytes = static_cast<uint32_t>(encoded.size());
  e.hash = hash64(frame);
  e.probes = static_cast<uint16_t>(decoded->probes.size());
  e.lprt_sources = static_cast<uint16_t>(decoded->lprt.sources.size());
  e.covered = static_cast<uint16_t>(coveredProbes(*decoded));
  s.entries.push_back(e);
  s.offset += frame.size();
  return {};
}

Result<void> ArchiveWriter::finish(const Manifest& info) {
  Impl& s = *impl_;
  DRTV_CHECK(!s.finished);
  Manifest m = info;
  m.version = archiveVersionFor(m.representation);
  if (auto what = validateLighting(m.sky, m.lights, m.interiors); !what)
    return std::unexpected(what.error().context(s.path.string() + ": lighting"));
  m.sectors = s.entries;
  std::sort(m.sectors.begin(), m.sectors.end(), [](const SectorEntry& a, const SectorEntry& b) { return a.key < b.key; });
  const std::vector<uint8_t> manifest = encodeManifest(m);
  if (auto ok = s.writeAt(manifest.data(), manifest.size(), s.offset); !ok) return ok;
  Header h;
  h.version = m.version;
  h.manifest_offset = s.offset;
  h.manifest_bytes = manifest.size();
  h.manifest_hash = hash64(manifest);
  h.file_bytes = s.offset + manifest.size();
  const std::vector<uint8_t> header = encodeHeader(h);
  if (auto ok = s.writeAt(header.data(), header.size(), 0); !ok) return ok;
  if (::fsync(s.fd) != 0) return fail(s.partial.string() + ": fsync failed: " + errnoText());
  ::close(s.fd);
  s.fd = -1;
  std::error_code ec;
  std::filesystem::rename(s.partial, s.path, ec);
  if (ec) return fail(s.path.string() + ": cannot publish the archive: " + ec.message());
  s.finished = true;
  return {};
}

}  // namespace drtv
