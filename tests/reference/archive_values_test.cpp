// Values, not only types (issue 17): every float an archive carries has a range, checked on load,
// so that no archive that passes validation makes the runtime produce NaN, Inf or a silently black
// probe. A property test over edited archives: a small world is baked once; each float of the
// manifest (bounds, sun path, sky and sun gradients, lights, interiors) and of a sector (header
// heights, probe positions, ranges, mean hit distance) is set to extreme values, the checksums are
// recomputed so that only the value checks stand between the edit and the runtime, and either the
// reader refuses it, naming the file and the field, or the runtime's ambient is finite at every
// point, normal and hour sampled and no probe lit before the edit is black after it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <xxhash.h>
#include <zstd.h>

#include "drtv/eval/accuracy.h"
#include "drtv/formats/archive.h"
#include "drtv/runtime/runtime.h"
#include "drtv/worlds/load.h"

namespace drtv {
namespace {

// A terrain inside sector (0,0), a box, a point light (LPRT is baked) and an interior.
constexpr const char* kWorld = R"({
  "name": "values",
  "terrain": {"kind": "noise", "size_m": 60, "resolution_m": 2, "height_m": 1, "seed": 2, "translation": [32, 32, 0]},
  "primitives": [{"shape": "box", "translation": [40, 30, 1], "scale": [4, 4, 2]}],
  "lights": [{"position": [24, 30, 3], "intensity": [5, 4, 3], "radius_m": 20}],
  "interiors": [{"min": [8, 8, 0], "max": [16, 16, 4], "probe": [12, 12, 2]}],
  "sky": {"sun_irradiance": [[5.5, 0, 0, 0], [12, 3, 2.9, 2.6], [18.5, 0, 0, 0]],
          "sky_zenith": [[0, 0.01, 0.01, 0.02], [12, 0.12, 0.22, 0.45]],
          "sky_horizon": [[0, 0.01, 0.01, 0.02], [12, 0.35, 0.42, 0.55]]}
})";
constexpr const char* kFile = "edited.drtv";

struct Baked {
  Manifest manifest;
  std::vector<Sector> sectors;
  std::vector<uint8_t> file;  // the archive's bytes
};

// The world baked in `representation`: fc3 (archive version 1) or sh-l1 (version 3: the fitted
// direct sky and the sectors' sun transfer, sector.h SunBlock).
Baked bake(Representation representation) {
    Baked out;
    auto world = worlds::parseWorldJson(kWorld, ".", "values.json");
    EXPECT_TRUE(world.has_value()) << world.error().message;
    baker::BakeSettings settings = baker::BakeSettings::forQuality(baker::Quality::kDraft, 1);
    settings.transfer.representation = representation;
    auto bake = baker::bakeInMemory(*world, "values.json", settings, raytrace::SectorRange{0, 0, 0, 0});
    EXPECT_TRUE(bake.has_value()) << bake.error().message;
    out.manifest = bake->manifest;
    out.sectors = bake->sectors;
    const std::string path = ::testing::TempDir() + "drtv_archive_values_" + std::to_string(::getpid()) + ".drtv";
    auto writer = ArchiveWriter::create(path);
    EXPECT_TRUE(writer.has_value());
    for (const Sector& s : out.sectors) EXPECT_TRUE(writer->addSector(s).has_value());
    EXPECT_TRUE(writer->finish(out.manifest).has_value());
    FILE* f = std::fopen(path.c_str(), "rb");
    EXPECT_NE(f, nullptr);
    std::fseek(f, 0, SEEK_END);
    out.file.resize(size_t(std::ftell(f)));
    std::fseek(f, 0, SEEK_SET);
    EXPECT_EQ(std::fread(out.file.data(), 1, out.file.size(), f), out.file.size());
    std::fclose(f);
    std::remove(path.c_str());
    return out;
}
const Baked& baked(Representation representation = Representation::kFc3) {
  static const Baked fc3 = bake(Representation::kFc3);
  if (representation == Representation::kFc3) return fc3;
  static const Baked sh_l1 = bake(Representation::kShL1);
  return sh_l1;
}

// A float field of the bytes: where it is, its width, and what a refusal must name.
struct Field {
  std::string name;  // fragment the reader's message must contain
  size_t offset = 0;
  bool f64 = false;
};

template <class T>
T readAt(const std::vector<uint8_t>& b, size_t at) {
  T v;
  std::memcpy(&v, b.data() + at, sizeof v);
  return v;
}

// Every float of the manifest, walked by the layout archive.h draws.
std::vector<Field> manifestFloats(const std::vector<uint8_t>& file) {
  std::vector<Field> out;
  size_t at = readAt<uint64_t>(file, 16);
  for (int i = 0; i < 6; ++i, at += 8) out.push_back({"manifest bounds", at, true});
  at += 8 + 4;  // sector size (checked to be exactly 64), effects
  if (readAt<uint32_t>(file, 8) != kArchiveVersionTalkBasis) at += 4;  // the representation code
  const uint32_t settings = readAt<uint32_t>(file, at);
  at += 4;
  for (uint32_t i = 0; i < settings; ++i) {
    at += 2 + readAt<uint16_t>(file, at);
    at += 4 + readAt<uint32_t>(file, at);
  }
  out.push_back({"sky.latitude_rad", at, true});
  out.push_back({"sky.declination_rad", at + 8, true});
  out.push_back({"sky.north_rad", at + 16, true});
  out.push_back({"sky.ground_radiance_scale", at + 24, false});
  at += 28;
  for (const char* g : {"sky.sun_irradiance", "sky.sky_zenith", "sky.sky_horizon"}) {
    const uint32_t keys = readAt<uint32_t>(file, at);
    at += 4;
    for (uint32_t k = 0; k < keys; ++k)
      for (int c = 0; c < 4; ++c, at += 4) out.push_back({std::string(g) + "[" + std::to_string(k) + "]", at, false});
  }
  const uint32_t lights = readAt<uint32_t>(file, at);
  at += 4;
  for (uint32_t i = 0; i < lights; ++i) {
    const std::string l = "lights[" + std::to_string(i) + "]";
    at += 2 + readAt<uint16_t>(file, at);
    for (int a = 0; a < 3; ++a, at += 8) out.push_back({l + ".position", at, true});
    for (int c = 0; c < 3; ++c, at += 4) out.push_back({l + ".intensity", at, false});
    out.push_back({l + ".radius_m", at, false});
    at += 4;
  }
  const uint32_t interiors = readAt<uint32_t>(file, at);
  at += 4;
  for (uint32_t i = 0; i < interiors; ++i) {
    const std::string v = "interiors[" + std::to_string(i) + "]";
    at += 2 + readAt<uint16_t>(file, at);
    for (int a = 0; a < 9; ++a, at += 8) out.push_back({v, at, true});
    out.push_back({v + ".blend_distance_m", at, false});
    at += 4;
  }
  return out;
}

// Every float of an encoded sector's header and of the probes `which` (sector.h, probe.h), and
// of its sun transfer (the first and last sample directions, those probes' ranges) when it has one
// (`sun_at`: where its block starts, `samples` its K).
std::vector<Field> sectorFloats(size_t probes, std::initializer_list<size_t> which, size_t sun_at = 0, size_t samples = 0) {
  std::vector<Field> out{{"grid z min", 24}, {"grid cell height", 28}, {"ground height range", 32}, {"ground height range", 36}};
  if (samples > 0) {
    for (size_t k : {size_t(0), samples - 1})
      for (size_t a = 0; a < 3; ++a) out.push_back({"sun sample " + std::to_string(k), sun_at + 12 * k + 4 * a});
    for (size_t p : which)
      if (p < probes) out.push_back({"probe " + std::to_string(p) + ": sun-transfer range", sun_at + 12 * samples + 4 * p});
  }
  for (size_t p : which) {
    if (p >= probes) continue;
    const size_t base = kSectorHeaderBytes + p * sizeof(ProbeRecord);
    const std::string name = "probe " + std::to_string(p) + ": ";
    out.push_back({name + "position", base + 0});
    out.push_back({name + "position", base + 4});
    out.push_back({name + "position", base + 8});
    out.push_back({name + "prt_range", base + 16});
    out.push_back({name + "lprt_range", base + 132});
    out.push_back({name + "mean_hit_m", base + 140});
  }
  return out;
}

// The extremes tried on every field: huge of both signs, NaN, infinities, a denormal, and zero.
const std::vector<double> kExtremes{3e38, -3e38, std::numeric_limits<double>::quiet_NaN(), INFINITY, -INFINITY, 1e-40, -1e-40,
                                    1e30, 0.0};

void writeValue(std::vector<uint8_t>& bytes, const Field& f, double v) {
  if (f.f64) {
    std::memcpy(bytes.data() + f.offset, &v, 8);
  } else {
    const float x = float(v);  // 3e38 stays finite as a float; 1e-40 is a float denormal
    std::memcpy(bytes.data() + f.offset, &x, 4);
  }
}

// What the runtime gives for `manifest` + `sectors` at a lattice of points and normals over
// sector (0,0), at four hours: the count of non-finite components (0 is the contract).
int nonFiniteAmbient(const Manifest& manifest, const std::vector<Sector>& sectors, std::string& first_bad) {
  runtime::RuntimeOptions options = runtime::optionsForEffects(manifest.effects);
  options.representation = manifest.representation;  // as runtimeForArchive takes it
  auto rt = std::make_unique<runtime::Runtime>(options);
  if (auto r = rt->setLighting(manifest.sky, manifest.lights, manifest.interiors); !r) {
    first_bad = "setLighting refused what the reader accepted: " + r.error().message;
    return 1;
  }
  for (const Sector& s : sectors)
    if (auto r = rt->addSector(s); !r) {
      first_bad = "addSector refused what the reader accepted: " + r.error().message;
      return 1;
    }
  const glm::vec3 normals[] = {{0, 0, 1}, {1, 0, 0}, {0, -1, 0}, glm::normalize(glm::vec3(1, 1, 1)), {0, 0, -1}};
  int bad = 0;
  for (double hour : {6.5, 12.0, 17.9, 23.0}) {
    EXPECT_TRUE(rt->setTime(hour).has_value());
    rt->update(glm::dvec3(32, 32, 3));
    for (double x = 2; x < 64; x += 6)
      for (double y = 2; y < 64; y += 6)
        for (double z : {0.5, 2.5, 6.0})
          for (const glm::vec3& n : normals) {
            const glm::vec3 e = rt->ambient(glm::dvec3(x, y, z), n).irradiance;
            if (std::isfinite(e.r) && std::isfinite(e.g) && std::isfinite(e.b)) continue;
            if (bad++ == 0)
              first_bad = "ambient (" + std::to_string(e.r) + ", " + std::to_string(e.g) + ", " + std::to_string(e.b) + ") at (" +
                          std::to_string(x) + ", " + std::to_string(y) + ", " + std::to_string(z) + ") hour " + std::to_string(hour);
          }
  }
  return bad;
}

// Each probe of sector (0,0), relit at noon: the sum of its basis colours (0 = black).
std::vector<float> probeColourSums(const Manifest& manifest, const std::vector<Sector>& sectors) {
  runtime::RuntimeOptions options = runtime::optionsForEffects(manifest.effects);
  options.representation = manifest.representation;
  auto rt = std::make_unique<runtime::Runtime>(options);
  EXPECT_TRUE(rt->setLighting(manifest.sky, manifest.lights, manifest.interiors).has_value());
  EXPECT_TRUE(rt->setTime(12.0).has_value());
  for (const Sector& s : sectors) EXPECT_TRUE(rt->addSector(s).has_value());
  rt->update(glm::dvec3(32, 32, 3));
  std::vector<float> sums;
  const int slot = rt->cache().slotOf(SectorKey{0, 0});
  for (size_t i = 0; slot >= 0 && i < sectors[0].probes.size(); ++i) {
    float sum = 0.f;
    for (const glm::vec3& c : rt->cache().colours(runtime::ProbeRef{slot, int(i)})) sum += c.r + c.g + c.b;
    sums.push_back(sum);
  }
  return sums;
}

std::string describe(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

TEST(ArchiveValues, TheUneditedArchiveGivesFiniteAmbientEverywhere) {
  const Baked& b = baked();
  ASSERT_FALSE(b.sectors.empty());
  ASSERT_FALSE(b.manifest.lights.empty());
  ASSERT_FALSE(b.manifest.interiors.empty());
  ASSERT_TRUE(b.sectors[0].hasLprt());
  std::string why;
  EXPECT_EQ(nonFiniteAmbient(b.manifest, b.sectors, why), 0) << why;
  // The ranges leave a wide margin over what a bake writes (probe.h says why they are safe).
  float prt = 0.f, lprt = 0.f;
  for (const Sector& s : b.sectors)
    for (const ProbeRecord& r : s.probes) prt = std::max(prt, r.prt_range), lprt = std::max(lprt, r.lprt_range);
  EXPECT_LT(prt, kMaxPrtRange / 100) << "largest baked prt_range";
  EXPECT_LT(lprt, kMaxLprtRange / 100) << "largest baked lprt_range";
  std::printf("largest baked prt_range %g, lprt_range %g\n", prt, lprt);
}

void editEveryManifestFloat(const Baked& b) {
  const std::vector<Field> fields = manifestFloats(b.file);
  ASSERT_GT(fields.size(), 40u);
  const uint64_t manifest_at = readAt<uint64_t>(b.file, 16), manifest_bytes = readAt<uint64_t>(b.file, 24);
  // The walk lands exactly on the sector count: the field offsets follow the drawn layout.
  ASSERT_EQ(decodeArchiveHeaderAndManifest(b.file, kFile).has_value(), true);
  int refused = 0, accepted = 0;
  for (const Field& f : fields)
    for (double v : kExtremes) {
      std::vector<uint8_t> bytes = b.file;
      writeValue(bytes, f, v);
      const uint64_t hash = XXH3_64bits(bytes.data() + manifest_at, manifest_bytes);  // the checksum, recomputed
      std::memcpy(bytes.data() + 32, &hash, 8);
      auto m = decodeArchiveHeaderAndManifest(bytes, kFile);
      if (!m) {
        ++refused;
        EXPECT_EQ(m.error().message.rfind(std::string(kFile) + ": byte ", 0), 0u) << m.error().message;
        EXPECT_NE(m.error().message.find(f.name), std::string::npos)
            << f.name << " = " << describe(v) << ": " << m.error().message;
        continue;
      }
      ++accepted;
      std::string why;
      EXPECT_EQ(nonFiniteAmbient(*m, b.sectors, why), 0) << f.name << " at byte " << f.offset << " = " << describe(v) << ": " << why;
    }
  // Both outcomes happen: the test exercises the checks and the runtime alike.
  EXPECT_GT(refused, 0);
  EXPECT_GT(accepted, 0);
}

TEST(ArchiveValues, AnEditedManifestFloatIsRefusedNamingFileAndFieldOrGivesFiniteAmbient) { editEveryManifestFloat(baked()); }
TEST(ArchiveValues, AnEditedShL1ManifestFloatIsRefusedNamingFileAndFieldOrGivesFiniteAmbient) {
  ASSERT_EQ(readAt<uint32_t>(baked(Representation::kShL1).file, 8), kArchiveVersion);
  editEveryManifestFloat(baked(Representation::kShL1));
}

TEST(ArchiveValues, TheIssuesCasesAreRefused) {
  // Sun and sky colours of 3e38 (a NaN total in drtv query) and a probe range of 3e38 (a probe
  // silently black) were accepted before the ranges.
  const Baked& b = baked();
  Manifest m = b.manifest;
  m.sky.sun_irradiance.keys[1].value = glm::vec3(3e38f);
  ASSERT_FALSE(validateLighting(m.sky, m.lights, m.interiors));
  EXPECT_NE(validateLighting(m.sky, m.lights, m.interiors).error().message.find("sky.sun_irradiance[1].value"), std::string::npos);
  ProbeRecord r = b.sectors[0].probes[0];
  r.prt_range = 3e38f;
  ASSERT_FALSE(validateProbe(r));
  EXPECT_NE(validateProbe(r).error().message.find("prt_range"), std::string::npos);
}

void editEverySectorFloat(const Baked& b) {
  const Sector& original = b.sectors[0];
  const std::vector<uint8_t> encoded = encodeSector(original);
  const size_t n = original.probes.size();
  const std::string where = std::string(kFile) + ": sector " + toString(original.key);
  ASSERT_EQ(original.key, (SectorKey{0, 0}));
  const std::vector<float> lit = probeColourSums(b.manifest, b.sectors);
  ASSERT_EQ(lit.size(), n);
  int refused = 0, accepted = 0;
  const size_t samples = original.sun ? original.sun->samples() : 0;
  // The sun block, then the covered probes' visibility maps (sector.h).
  const size_t sun_at = encoded.size() - (samples ? samples * 12 + n * (4 + samples * 12) : 0) - coveredProbes(original) * kVisBytesPerProbe;
  for (const Field& f : sectorFloats(n, {0, n / 2, n - 1}, sun_at, samples))
    for (double v : kExtremes) {
      std::vector<uint8_t> bytes = encoded;
      writeValue(bytes, f, v);
      // Recompressed and re-hashed, as a tool that edits an archive would.
      std::vector<uint8_t> frame(ZSTD_compressBound(bytes.size()));
      frame.resize(ZSTD_compress(frame.data(), frame.size(), bytes.data(), bytes.size(), 3));
      SectorEntry e;
      e.key = original.key;
      e.offset = kArchiveHeaderBytes;
      e.compressed_bytes = uint32_t(frame.size());
      e.raw_bytes = uint32_t(bytes.size());
      e.hash = XXH3_64bits(frame.data(), frame.size());
      e.probes = uint16_t(n);
      e.lprt_sources = uint16_t(original.lprt.sources.size());
      e.covered = uint16_t(coveredProbes(original));
      auto s = decodeSectorPayload(e, frame, where);
      if (!s) {
        ++refused;
        EXPECT_EQ(s.error().message.rfind(where + ": byte ", 0), 0u) << s.error().message;
        EXPECT_NE(s.error().message.find(f.name), std::string::npos) << f.name << " = " << describe(v) << ": " << s.error().message;
        continue;
      }
      ++accepted;
      std::vector<Sector> sectors = b.sectors;
      sectors[0] = std::move(*s);
      std::string why;
      EXPECT_EQ(nonFiniteAmbient(b.manifest, sectors, why), 0) << f.name << " = " << describe(v) << ": " << why;
      // Nor silently black: a probe lit before the edit is lit after it (the direct sky term does
      // not depend on any edited float; an overflow to Inf - Inf = NaN, clamped to 0, would be).
      const std::vector<float> now = probeColourSums(b.manifest, sectors);
      for (size_t p = 0; p < n; ++p) {
        if (!(lit[p] > 0.f)) continue;
        EXPECT_TRUE(now[p] > 0.f && std::isfinite(now[p]))
            << f.name << " = " << describe(v) << ": probe " << p << " colour sum " << now[p] << ", before the edit " << lit[p];
      }
    }
  EXPECT_GT(refused, 0);
  EXPECT_GT(accepted, 0);
}

TEST(ArchiveValues, AnEditedSectorFloatIsRefusedNamingFileAndFieldOrGivesFiniteAmbient) { editEverySectorFloat(baked()); }
// sh-l1 of version 3: its probes' fitted direct sky and the sector's sun transfer too.
TEST(ArchiveValues, AnEditedShL1SectorFloatIsRefusedNamingFileAndFieldOrGivesFiniteAmbient) {
  ASSERT_TRUE(baked(Representation::kShL1).sectors.at(0).sun) << "the sh-l1 bake has a sun transfer to edit";
  editEverySectorFloat(baked(Representation::kShL1));
}

TEST(ArchiveValues, TheLargestAcceptedValuesKeepTheAmbientFinite) {
  // Every colour and intensity at its maximum, every probe's ranges at theirs with saturated
  // coefficients: the bounds themselves must leave the runtime's sums finite.
  const Baked& b = baked();
  Manifest m = b.manifest;
  for (Gradient* g : {&m.sky.sun_irradiance, &m.sky.sky_zenith, &m.sky.sky_horizon})
    for (ColorKey& k : g->keys) k.value = glm::vec3(kMaxColourValue);
  m.sky.ground_radiance_scale = 1.f;
  for (PointLight& l : m.lights) {
    l.intensity = glm::vec3(kMaxColourValue);
    l.radius_m = kMaxLightRadiusM;
  }
  ASSERT_TRUE(validateLighting(m.sky, m.lights, m.interiors));
  std::vector<Sector> sectors = b.sectors;
  for (Sector& s : sectors) {
    for (size_t p = 0; p < s.probes.size(); ++p) {
      ProbeRecord& r = s.probes[p];
      r.prt_range = kMaxPrtRange;
      for (auto& channel : r.prt)
        for (auto& basis : channel)
          for (int16_t& q : basis) q = (p % 2) ? 32767 : -32767;
      if (s.hasLprt()) r.lprt_range = kMaxLprtRange;
      ASSERT_TRUE(validateProbe(r));
    }
    for (int16_t& q : s.lprt.coeffs) q = 32767;
  }
  std::string why;
  EXPECT_EQ(nonFiniteAmbient(m, sectors, why), 0) << why;
}

}  // namespace
}  // namespace drtv
