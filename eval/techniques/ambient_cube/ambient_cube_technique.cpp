// ambient-cube (technique.h): DRTV with the six-axis ambient cube [2] as its directional
// representation, end to end — bake, relight, volume, ambient — held in memory only (no archive
// format stores it: it is the measurement of issue 13 that decides whether one should).
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slides 22-44.
//  [2] McTaggart, "Half-Life 2 / Valve Source Shading", GDC 2004: six axis colours, shaded as
//      ambient(n) = n.x^2 C[+-x] + n.y^2 C[+-y] + n.z^2 C[+-z], the sign of each component
//      choosing the face.
//
// Bake. The drtv bake (placement, index grid, ground map) with the default settings and the fc3
// representation — the accuracy table's default bake, adopted when given (PrepareInput::baked) —
// then baker::bakeCube (cube_bake.h) on the same probes, scenes, rays and surface cache: per probe
// and axis A_a, a bounce transfer C[c][a] (SH4), the direct sky's sky_h[a], sky_delta[a] (the six
// axis values sh-l1 version 3 fits), the exact first sun bounce at the sun path's samples less the
// linear lobe's (as sh-l1 v3's SunBlock) and, with local lights, an LPRT row per source
// (transfer.h, "The ambient cube"). prepare_s is both passes: a cube archive would need one.
//
// Relight (setLighting, then the next update), per probe, axis a and channel c, with the lighting
// of lighting_sh.h at the hour (the linear sun lobe, as sh-l1's):
//   colour[a][c] = dot(SkySH[c], C[c][a])                                  sky bounce
//                + dot(SunSH[c], C[c][a]) + E_sun,c sum_k w_k sun[k][c][a]  sun bounce (w: sunTransferWeights)
//                + H_c sky_h[a] + (Z_c - H_c) sky_delta[a]                  direct sky (the world's sky model)
//                + sum_j light[j][c] lprt[j][c][a]                          local lights (the runtime's shares)
// clamped to [0, kMaxColour] at the end only. Each probe is then converted once to 18 bytes,
// unorm8 x HDR scale (max colour x 1.25, the runtime's headroom).
//
// Volume. 96 x 96 x 16 texels of 2 x 2 x 4 m (RuntimeOptions' defaults) following the camera,
// 18 bytes a texel (six RGB8 colours; the talk's three RGBA8 textures are 12: 1.5 x), world texel
// g stored at g mod size, so that a camera move fills only the slabs that entered. Each texel
// takes the probe the index grid names at its centre (the drtv default, nearest fill), or the sky
// fallback where none is resident; with the world's volume_blur the runtime's 3x3x3 [1 2 1] blur
// is applied to the unblurred neighbours, read from the probes also beyond the window's faces
// (where the runtime repeats the edge texel), so that a slab needs no seam handling and a
// scrolled volume equals one filled whole (tests/eval/ambient_cube_test.cpp).
//
// Ambient, as Runtime::ambient: the sample moves normal_offset_m along the normal, the 8 texels
// around it are blended trilinearly (as the hardware filters unorm8), shaded with [2], and mixed
// with the distant ambient by the volume's coverage (edge_fade_texels); inside an interior the
// designated probe's own colours are blended in over blend_distance_m. Relight and fill run on
// the calling thread.
//
// Parameters:
//   quality            draft | default | high    the bake preset (BakeSettings::forQuality)
//   rays_per_basis     integer >= 1              overrides the preset's transfer rays
//   bounces            integer >= 1              overrides the preset's bounces
//   texel_m            metres in (0, 1e4]        the volume's horizontal texel (vertical twice it)
//   part               all | sun_bounce | sky_bounce | direct_sky | local_lights   one term alone
//   sun_transfer       on | off                  the exact first sun bounce (off: the linear lobe only)
#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstring>
#include <optional>

#include "drtv/baker/bake.h"
#include "drtv/baker/cube_bake.h"
#include "drtv/formats/sh.h"
#include "drtv/runtime/lighting_sh.h"
#include "drtv/runtime/occlusion.h"
#include "drtv/runtime/runtime.h"
#include "techniques.h"

namespace drtv::eval {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kAxes = baker::kCubeAxes;
constexpr int kTexelBytes = 3 * kAxes;  // six RGB8 colours
constexpr float kMinHdrScale = 1e-6f;   // as runtime.cpp's

using CubeColours = std::array<glm::vec3, kAxes>;  // [axis +x, -x, +y, -y, +z, -z]
using CubeTexel = std::array<uint8_t, kTexelBytes>;  // [axis][channel]

struct Params {
  baker::Quality quality = baker::Quality::kDefault;
  std::optional<int> rays_per_basis, bounces;
  std::optional<float> texel_m;
  std::optional<uint32_t> part;
  bool sun_transfer = true;
};

Params readCube(ParamReader& r) {
  Params out;
  if (const std::string* v = r.text("quality")) {
    if (auto q = baker::parseQuality(*v)) out.quality = *q;
    else r.reject("quality=" + *v + ": expected draft, default or high");
  }
  r.integer("rays_per_basis", out.rays_per_basis, 1, 1 << 20)
      .integer("bounces", out.bounces, 1, 1 << 20)
      .real("texel_m", out.texel_m, 0, 1e4, true);
  readPart(r, out.part);
  r.oneOf("sun_transfer", out.sun_transfer, {{"on", true}, {"off", false}});
  return out;
}

// [2]: the squared components weigh the face each component's sign points to.
glm::vec3 shadeCube(const CubeColours& c, const glm::vec3& n) {
  return n.x * n.x * c[n.x >= 0.f ? 0 : 1] + n.y * n.y * c[n.y >= 0.f ? 2 : 3] + n.z * n.z * c[n.z >= 0.f ? 4 : 5];
}

// Runtime::ambient's normal handling: zero or non-finite reads as +Z.
glm::vec3 unitNormal(const glm::vec3& n) {
  const glm::dvec3 d(n);
  const double len = std::sqrt(glm::dot(d, d));
  if (!(len > 1e-30) || !std::isfinite(len)) return {0.f, 0.f, 1.f};
  return glm::vec3(d / len);
}

int64_t floorDiv(int64_t a, int64_t b) { return a / b - ((a % b != 0) && ((a < 0) != (b < 0))); }
int64_t wrap(int64_t a, int64_t n) { return a - floorDiv(a, n) * n; }

class AmbientCube final : public Technique {
 public:
  using Params = drtv::eval::Params;
  AmbientCube(TechniqueMade made, Params p) : Technique(std::move(made), {}), params_(std::move(p)) {}

  static Params read(ParamReader& r) { return readCube(r); }
  static std::vector<TechniqueInfo> variants() {
    return {{"ambient-cube",
             "DRTV with a six-axis ambient cube per probe (in memory only): baked on the drtv bake's rays, relit, "
             "a 96x96x16 volume of 18 bytes a texel",
             {},
             &knobs}};
  }
  // Each term alone against the reference's (as the `part` rows of sh-l1), and the sun transfer
  // off: the technique baked once per row, seconds each (docs/accuracy.md).
  static std::vector<KnobRow> knobs(const KnobContext& c) {
    std::vector<KnobRow> rows;
    const uint32_t components = runtime::componentsFromEffects(c.effects);
    for (size_t k = 0; k < kRuntimeParts.size(); ++k)
      if (components & kRuntimeParts[k].second)
        rows.push_back({"part ambient-cube", kRuntimeParts[k].first, false, "ambient-cube", {{"part", kRuntimeParts[k].first}}, "", int(k)});
    if ((components & runtime::kComponentSunBounce) && Params{}.sun_transfer)
      rows.push_back({"cube sun_transfer", "off", false, "ambient-cube", {{"sun_transfer", "off"}},
                      "the ambient cube with the linear sun lobe alone (no exact first bounce)"});
    return rows;
  }

 protected:
  Result<void> onPrepare(const PrepareInput& in) override {
    baker::BakeSettings s = baker::BakeSettings::forQuality(params_.quality, in.seed);
    if (params_.rays_per_basis) s.transfer.probe_rays_per_basis = *params_.rays_per_basis;
    if (params_.bounces) s.transfer.bounces = *params_.bounces;
    std::optional<baker::InMemoryBake> own;
    auto baked = bakeFor(in, s, own);
    if (!baked) return std::unexpected(baked.error());
    const baker::InMemoryBake* bake = *baked;
    auto cube = baker::bakeCube(in.world, in.where, s, bake->sectors, in.threads, &bake->manifest.interiors);
    if (!cube) return std::unexpected(cube.error());
    cube_ = std::move(*cube);
    manifest_ = bake->manifest;
    // A drtv runtime for what the representation does not change: the index grid (probeAt), the
    // occlusion tiles of the distant ambient, the interiors' designated probes, the light shares.
    options_ = runtime::optionsForEffects(manifest_.effects);
    if (params_.texel_m) options_.volume.texel_size_m = glm::vec3(*params_.texel_m, *params_.texel_m, 2.f * *params_.texel_m);
    auto rt = runtime::runtimeForSectors(manifest_, options_, 12.0, bake->sectors);
    if (!rt) return std::unexpected(rt.error());
    rt_ = std::move(*rt);
    slot_sector_.assign(size_t(rt_->cache().maxSectors()), -1);
    sources_.clear();
    for (size_t i = 0; i < bake->sectors.size(); ++i) {
      const int slot = rt_->cache().slotOf(bake->sectors[i].key);
      DRTV_CHECK(slot >= 0);
      slot_sector_[size_t(slot)] = int(i);
      sources_.push_back(bake->sectors[i].lprt.sources);
      DRTV_CHECK_EQ(cube_.sectors[i].transfer.prt.size(), bake->sectors[i].probes.size());
    }
    colours_.assign(cube_.sectors.size(), {});
    packed_.assign(cube_.sectors.size(), {});
    components_ = runtime::componentsFromEffects(manifest_.effects);
    if (params_.part) components_ &= *params_.part;
    reportPrepareSeconds(bake->bake_s + cube_.bake_s);
    costs_.stored_bytes = storedBytes(bake->sectors);
    const glm::ivec3 n = options_.volume.size;
    size_ = n;
    texels_.assign(size_t(n.x) * size_t(n.y) * size_t(n.z), CubeTexel{});
    texel_probe_.assign(texels_.size(), -1);
    costs_.runtime_bytes = texels_.size() * sizeof(CubeTexel);
    built_ = false;
    dirty_ = true;
    lit_ = false;
    return {};
  }

  Result<void> onSetLighting(double hour, const std::vector<PointLight>& lights) override {
    if (auto why = validateLighting(manifest_.sky, lights, manifest_.interiors); !why) return fail(why.error().message);
    lighting_ = runtime::evaluateSky(manifest_.sky, hour, runtime::kLinearSunBand1, 0.f);
    lights_ = lights;
    dirty_ = true;
    lit_ = true;
    return {};
  }

  Result<void> onUpdate(const glm::dvec3& camera) override {
    const bool relit = dirty_;
    if (dirty_) relight(), dirty_ = false;
    scroll(originFor(camera), relit);
    return {};
  }

  glm::vec3 onAmbient(const glm::dvec3& position, const glm::vec3& normal) const override {
    const glm::vec3 n = unitNormal(normal);
    static const runtime::OcclusionMap kOpenSky;
    const sh::Sh4Rgb sky = components_ & runtime::kComponentDirectSky ? lighting_.sky_sh : sh::Sh4Rgb{};
    const glm::vec3 distant =
        runtime::distantAmbient(manifest_.effects & kEffectDistantOcclusion ? rt_->occlusion() : kOpenSky, sky, position, n);
    const glm::dvec3 ts(options_.volume.texel_size_m);
    const glm::dvec3 sample = position + glm::dvec3(n) * double(options_.normal_offset_m);
    float weight = built_ ? 1.f : 0.f;
    for (int a = 0; a < 3 && weight > 0.f; ++a) {
      const double t = sample[a] / ts[a] - double(origin_[a]);
      const double dist = std::min(t - 0.5, double(size_[a]) - 0.5 - t);
      if (!(dist >= 0.0)) weight = 0.f;
      else if (options_.edge_fade_texels > 0.f) weight = std::min(weight, float(std::min(1.0, dist / options_.edge_fade_texels)));
    }
    glm::vec3 out = distant;
    if (weight > 0.f) {
      const glm::dvec3 t = sample / ts - 0.5;
      const glm::dvec3 g0 = glm::floor(t), f = t - g0;
      std::array<float, kTexelBytes> acc{};
      for (int corner = 0; corner < 8; ++corner) {
        const glm::i64vec3 g = glm::i64vec3(g0) + glm::i64vec3(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        const float w = float((corner & 1 ? f.x : 1 - f.x) * (corner & 2 ? f.y : 1 - f.y) * (corner & 4 ? f.z : 1 - f.z));
        const CubeTexel& texel = texels_[storeIndex(g)];
        for (int q = 0; q < kTexelBytes; ++q) acc[size_t(q)] += w * float(texel[size_t(q)]);
      }
      CubeColours c;
      for (int a = 0; a < kAxes; ++a)
        for (int ch = 0; ch < 3; ++ch) c[size_t(a)][ch] = acc[size_t(a * 3 + ch)] * (scale_ / 255.f);
      out = distant + (shadeCube(c, n) - distant) * weight;
    }
    if (manifest_.effects & kEffectInteriors) out = interiorBlend(position, n, out);
    return out;
  }

 private:
  // What an archive of the cube would hold: the sh-l1 sector (its record, index grid, ground map,
  // LPRT and sun blocks) with every per-axis block 6/4 as large: the transfer 96 -> 144 bytes a
  // probe (the 24 bytes of sky terms hold the 12 axis values), an LPRT row 24 -> 36 bytes per
  // source, a sun sample 12 -> 18 bytes.
  size_t storedBytes(const std::vector<Sector>& sectors) const {
    size_t n = 0;
    for (size_t i = 0; i < sectors.size(); ++i) {
      const Sector& s = sectors[i];
      const size_t P = s.probes.size(), S = s.lprt.sources.size(), K = cube_.sectors[i].sun_directions.size();
      n += encodedSectorBytes(P, S, s.has_ground, K) + P * (48 + S * 12 + K * 6);
    }
    return n;
  }

  glm::ivec3 originFor(const glm::dvec3& camera) const {
    glm::ivec3 o;
    for (int a = 0; a < 3; ++a) {
      const double c = std::isfinite(camera[a]) ? std::clamp(camera[a], -1e8, 1e8) : 0.0;
      o[a] = int(std::floor(c / double(options_.volume.texel_size_m[a]))) - size_[a] / 2;
    }
    return o;
  }

  size_t storeIndex(const glm::i64vec3& g) const {
    return size_t((wrap(g.z, size_.z) * size_.y + wrap(g.y, size_.y)) * size_.x + wrap(g.x, size_.x));
  }

  void relight() {
    const runtime::ProbeCache& cache = rt_->cache();
    // Light shares per resident probe (the runtime's distribution, probe_cache.h).
    std::vector<std::vector<glm::vec3>> share(slot_sector_.size());
    const bool lights = (components_ & runtime::kComponentLocalLights) && !lights_.empty();
    if (lights)
      for (const runtime::LightShare& s : cache.distributeLights(lights_)) {
        auto& v = share[size_t(s.probe.slot)];
        if (v.size() <= size_t(s.probe.index)) v.resize(size_t(s.probe.index) + 1, glm::vec3(0.f));
        v[size_t(s.probe.index)] += s.colour;
      }
    const sh::Sh4Rgb& sky = lighting_.sky_sh;
    const sh::Sh4Rgb& sun = lighting_.sun_sh;
    const glm::vec3 H = lighting_.sky_horizon, Z = lighting_.sky_zenith, E = lighting_.sun_irradiance;
    const bool sky_bounce = components_ & runtime::kComponentSkyBounce, sun_bounce = components_ & runtime::kComponentSunBounce,
               direct = components_ & runtime::kComponentDirectSky;
    float mx = 0.f;
    for (size_t i = 0; i < cube_.sectors.size(); ++i) {
      const baker::CubeSector& cs = cube_.sectors[i];
      const baker::CubeTransfer& t = cs.transfer;
      const size_t P = t.prt.size(), K = cs.sun_directions.size(), S = sources_[i].size();
      std::vector<float> w(K, 0.f);
      if (K && params_.sun_transfer && sun_bounce && !t.sun.empty()) runtime::sunTransferWeights(cs.sun_directions, lighting_.sun_direction, w);
      std::vector<glm::vec3> light(S, glm::vec3(0.f));
      if (lights)
        for (size_t j = 0; j < S; ++j) {
          const LprtSource& src = sources_[i][j];
          const int slot = cache.slotOf(SectorKey{cs.key.ix + src.dx, cs.key.iy + src.dy});
          if (slot < 0) continue;
          const auto& v = share[size_t(slot)];
          if (size_t(src.probe) < v.size()) light[j] = v[src.probe];
        }
      std::vector<CubeColours>& out = colours_[i];
      out.assign(P, CubeColours{});
      for (size_t p = 0; p < P; ++p)
        for (int a = 0; a < kAxes; ++a)
          for (int c = 0; c < 3; ++c) {
            const sh::Sh4& T = t.prt[p][size_t(c)][size_t(a)];
            double v = 0.0;
            if (sky_bounce) v += glm::dot(sky[c], T);
            if (sun_bounce) {
              v += glm::dot(sun[c], T);
              for (size_t k = 0; k < K; ++k)
                if (w[k] != 0.f) v += double(E[c]) * w[k] * t.sun[((p * K + k) * 3 + size_t(c)) * kAxes + size_t(a)];
            }
            if (direct) v += double(H[c]) * t.sky_h[p][size_t(a)] + double(Z[c] - H[c]) * t.sky_delta[p][size_t(a)];
            if (lights && !t.lprt.empty())
              for (size_t j = 0; j < S; ++j) v += double(light[j][c]) * t.lprt[((p * S + j) * 3 + size_t(c)) * kAxes + size_t(a)];
            const float x = std::isnan(v) ? 0.f : float(std::clamp(v, 0.0, double(runtime::kMaxColour)));
            out[p][size_t(a)][c] = x;
            mx = std::max(mx, x);
          }
    }
    // The fallback where no probe is resident: the sky's irradiance about each axis.
    for (int a = 0; a < kAxes; ++a)
      for (int c = 0; c < 3; ++c) {
        fallback_[size_t(a)][c] = std::max(0.f, glm::dot(sh::cosineLobe(baker::cubeAxis(a)), sky[c]));
        mx = std::max(mx, fallback_[size_t(a)][c]);
      }
    scale_ = std::max(kMinHdrScale, std::min(mx * options_.hdr_headroom, runtime::kMaxColour));
    auto pack = [&](const CubeColours& c) {
      CubeTexel b;
      for (int a = 0; a < kAxes; ++a)
        for (int ch = 0; ch < 3; ++ch)
          b[size_t(a * 3 + ch)] = uint8_t(std::lround(255.f * std::min(1.f, c[size_t(a)][ch] / scale_)));
      return b;
    };
    for (size_t i = 0; i < colours_.size(); ++i) {
      packed_[i].resize(colours_[i].size());
      for (size_t p = 0; p < colours_[i].size(); ++p) packed_[i][p] = pack(colours_[i][p]);
    }
    packed_fallback_ = pack(fallback_);
  }

  // The probe the index grid names at world texel g's centre, as sector * 256 + probe (a sector
  // holds at most 255), or -1 for the fallback.
  int32_t probeIndexAt(const glm::i64vec3& g) const {
    const glm::dvec3 centre = (glm::dvec3(g) + 0.5) * glm::dvec3(options_.volume.texel_size_m);
    const runtime::ProbeRef pr = rt_->cache().probeAt(centre);
    if (!pr.valid()) return -1;
    const int i = slot_sector_[size_t(pr.slot)];
    return i < 0 ? -1 : i * 256 + pr.index;
  }

  bool inWindow(const glm::i64vec3& g) const {
    for (int a = 0; a < 3; ++a)
      if (g[a] < origin_[a] || g[a] >= int64_t(origin_[a]) + size_[a]) return false;
    return true;
  }

  // The unblurred texel g: the probe its index cell names, looked up once while g is in the
  // window (which texel takes which probe does not change with the lighting), relit bytes gathered.
  const CubeTexel& texelAt(const glm::i64vec3& g) const {
    const int32_t idx = inWindow(g) ? texel_probe_[storeIndex(g)] : probeIndexAt(g);
    return idx < 0 ? packed_fallback_ : packed_[size_t(idx >> 8)][size_t(idx & 255)];
  }

  void indexBox(const glm::i64vec3& lo, const glm::i64vec3& hi) {
    for (int64_t z = lo.z; z < hi.z; ++z)
      for (int64_t y = lo.y; y < hi.y; ++y)
        for (int64_t x = lo.x; x < hi.x; ++x) texel_probe_[storeIndex({x, y, z})] = probeIndexAt({x, y, z});
  }

  // Fills world texels [lo, hi) (each axis within the volume's window). The wrapped storage
  // index and whether the window holds a coordinate are tabulated per axis once per box.
  void fillBox(const glm::i64vec3& lo, const glm::i64vec3& hi) {
    if (hi.x <= lo.x || hi.y <= lo.y || hi.z <= lo.z) return;
    const int64_t m = options_.volume.blur ? 1 : 0;  // the blur reads one texel around the box
    const glm::i64vec3 elo = lo - m, d = hi - lo + 2 * m;
    std::array<std::vector<size_t>, 3> stride;
    std::array<std::vector<uint8_t>, 3> inside;
    const glm::i64vec3 scale(1, size_.x, int64_t(size_.x) * size_.y);
    for (int a = 0; a < 3; ++a)
      for (int64_t i = 0; i < d[a]; ++i) {
        const int64_t g = elo[a] + i;
        stride[size_t(a)].push_back(size_t(wrap(g, size_[a]) * scale[a]));
        inside[size_t(a)].push_back(g >= origin_[a] && g < int64_t(origin_[a]) + size_[a]);
      }
    auto source = [&](int64_t x, int64_t y, int64_t z) -> const CubeTexel& {
      const size_t sx = size_t(x), sy = size_t(y), sz = size_t(z);
      const int32_t idx = inside[0][sx] && inside[1][sy] && inside[2][sz] ? texel_probe_[stride[0][sx] + stride[1][sy] + stride[2][sz]]
                                                                          : probeIndexAt({elo.x + x, elo.y + y, elo.z + z});
      return idx < 0 ? packed_fallback_ : packed_[size_t(idx >> 8)][size_t(idx & 255)];
    };
    if (!m) {
      for (int64_t z = 0; z < d.z; ++z)
        for (int64_t y = 0; y < d.y; ++y) {
          const size_t row = stride[1][size_t(y)] + stride[2][size_t(z)];
          for (int64_t x = 0; x < d.x; ++x) texels_[row + stride[0][size_t(x)]] = source(x, y, z);
        }
      return;
    }
    // The 3x3x3 [1 2 1] / 64 blur of the unblurred texels around the box, separably, on flat
    // 16-bit planes: each pass is one contiguous loop (it vectorises) over a range that holds what
    // the next pass reads; the values it computes at the box's faces read across rows and are
    // never read back.
    const size_t B = size_t(kTexelBytes), count = size_t(d.x * d.y * d.z);
    blur_a_.resize(count * B);
    blur_b_.resize(count * B);
    auto at = [&](int64_t x, int64_t y, int64_t z) { return size_t((z * d.y + y) * d.x + x); };
    for (int64_t z = 0; z < d.z; ++z)
      for (int64_t y = 0; y < d.y; ++y)
        for (int64_t x = 0; x < d.x; ++x) {
          const CubeTexel& t = source(x, y, z);
          uint16_t* out = &blur_a_[at(x, y, z) * B];
          for (size_t q = 0; q < B; ++q) out[q] = t[q];
        }
    auto pass = [&](size_t back, size_t begin, size_t end, const std::vector<uint16_t>& from, std::vector<uint16_t>& to) {
      const uint16_t* f = from.data();
      uint16_t* o = to.data();
      for (size_t i = begin; i < end; ++i) o[i] = uint16_t(f[i - back] + 2 * f[i] + f[i + back]);
    };
    pass(B, at(1, 0, 0) * B, at(d.x - 1, d.y - 1, d.z - 1) * B, blur_a_, blur_b_);
    pass(B * size_t(d.x), at(0, 1, 0) * B, at(0, d.y - 1, d.z - 1) * B, blur_b_, blur_a_);
    pass(B * size_t(d.x * d.y), at(0, 0, 1) * B, at(0, 0, d.z - 1) * B, blur_a_, blur_b_);
    for (int64_t z = 1; z < d.z - 1; ++z)
      for (int64_t y = 1; y < d.y - 1; ++y) {
        const size_t row = stride[1][size_t(y)] + stride[2][size_t(z)];
        for (int64_t x = 1; x < d.x - 1; ++x) {
          CubeTexel& t = texels_[row + stride[0][size_t(x)]];
          const uint16_t* v = &blur_b_[at(x, y, z) * B];
          for (size_t q = 0; q < B; ++q) t[q] = uint8_t((v[q] + 32) / 64);
        }
      }
  }

  // Moves the window to `origin`: the texels that entered look their probe up; then everything
  // is filled after a relight, else only those texels.
  void scroll(const glm::ivec3& origin, bool all) {
    const glm::i64vec3 nlo(origin), nhi = nlo + glm::i64vec3(size_);
    const glm::i64vec3 olo(origin_), ohi = olo + glm::i64vec3(size_);
    bool overlap = built_;
    for (int a = 0; a < 3; ++a) overlap = overlap && nlo[a] < ohi[a] && olo[a] < nhi[a];
    origin_ = origin;
    built_ = true;
    std::vector<std::pair<glm::i64vec3, glm::i64vec3>> entered;
    if (!overlap) {
      entered.push_back({nlo, nhi});
    } else {
      // The new window less the old one: an x slab, then a y slab within the old x range, then z.
      glm::i64vec3 lo = nlo, hi = nhi;
      for (int a = 0; a < 3; ++a) {
        glm::i64vec3 slo = lo, shi = hi;
        if (nlo[a] < olo[a]) {
          shi[a] = olo[a];
          entered.push_back({slo, shi});
        } else if (nhi[a] > ohi[a]) {
          slo[a] = ohi[a];
          entered.push_back({slo, shi});
        }
        lo[a] = std::max(nlo[a], olo[a]);
        hi[a] = std::min(nhi[a], ohi[a]);
      }
    }
    for (const auto& [lo, hi] : entered) indexBox(lo, hi);
    if (all) return fillBox(nlo, nhi);
    for (const auto& [lo, hi] : entered) fillBox(lo, hi);
  }

  glm::vec3 interiorBlend(const glm::dvec3& position, const glm::vec3& n, glm::vec3 ambient) const {
    int best = -1;
    float best_t = 0.f;
    const auto& interiors = rt_->interiors();
    for (size_t k = 0; k < interiors.size(); ++k) {
      if (!rt_->interiorProbe(k).valid()) continue;
      const InteriorVolume& v = interiors[k];
      const glm::dvec3 lo = position - v.min, hi = v.max - position;
      const double depth = std::min({lo.x, lo.y, lo.z, hi.x, hi.y, hi.z});
      if (!(depth >= 0.0)) continue;
      const float t = v.blend_distance_m > 0.f ? float(std::min(1.0, depth / v.blend_distance_m)) : 1.f;
      if (t <= best_t && best >= 0) continue;
      best = int(k);
      best_t = t;
    }
    if (best < 0) return ambient;
    const runtime::ProbeRef pr = rt_->interiorProbe(size_t(best));
    const int i = slot_sector_[size_t(pr.slot)];
    if (i < 0 || colours_[size_t(i)].empty()) return ambient;
    return ambient + (shadeCube(colours_[size_t(i)][size_t(pr.index)], n) - ambient) * best_t;
  }

  Params params_;
  baker::CubeBake cube_;
  Manifest manifest_;
  runtime::RuntimeOptions options_;
  std::unique_ptr<runtime::Runtime> rt_;
  std::vector<int> slot_sector_;                   // runtime slot -> index into cube_.sectors
  std::vector<std::vector<LprtSource>> sources_;   // per sector, its LPRT sources (record order)
  uint32_t components_ = runtime::kAllComponents;
  runtime::SkyLighting lighting_;
  std::vector<PointLight> lights_;
  std::vector<std::vector<CubeColours>> colours_;  // [sector][probe], relit
  std::vector<std::vector<CubeTexel>> packed_;     // [sector][probe], converted once per relight
  CubeColours fallback_{};
  CubeTexel packed_fallback_{};
  float scale_ = 1.f;
  glm::ivec3 size_{0};
  glm::ivec3 origin_{0};
  std::vector<CubeTexel> texels_;
  std::vector<int32_t> texel_probe_;  // per stored texel: probeIndexAt of the world texel it holds
  std::vector<uint16_t> blur_a_, blur_b_;  // the blur's scratch, 18 sums a texel, kept between fills
  bool built_ = false, dirty_ = true, lit_ = false;
};

}  // namespace

Result<void> registerAmbientCubeTechnique() { return registerTechnique<AmbientCube>(); }

}  // namespace drtv::eval
