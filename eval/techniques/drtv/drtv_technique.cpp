// DRTV as a technique (technique.h): the baker's transfer bake in memory, then drtv::runtime set up
// as an engine sets it up from an archive (runtime::runtimeForArchive) holding every sector of the
// block. Its knobs are parameters:
//   quality         draft | default | high        the bake preset (BakeSettings::forQuality)
//   rays_per_basis  integer >= 1                  overrides the preset's transfer rays
//   bounces         integer >= 1                  overrides the preset's bounces
//   fill            nearest | smooth              the volume fill (runtime FillMode)
//   texel_m         metres > 0                    the volume's horizontal texel size
// Registered as "drtv" and as the variants "drtv-nearest" and "drtv-smooth".
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <optional>

#include "drtv/baker/bake.h"
#include "drtv/runtime/runtime.h"
#include "techniques.h"

namespace drtv::eval {
namespace {

using Clock = std::chrono::steady_clock;

struct DrtvParams {
  baker::Quality quality = baker::Quality::kDefault;
  std::optional<int> rays_per_basis, bounces;
  runtime::FillMode fill = runtime::FillMode::kNearest;
  std::optional<float> texel_m;
  TechniqueParams given;
};

Result<int> positiveInt(const std::string& key, const std::string& v) {
  int x = 0;
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
  if (ec != std::errc() || end != v.data() + v.size() || x < 1) return fail(key + "=" + v + ": expected an integer >= 1");
  return x;
}

Result<DrtvParams> parseParams(const TechniqueParams& p) {
  DrtvParams out;
  out.given = p;
  if (auto it = p.find("quality"); it != p.end()) {
    auto parsed = baker::parseQuality(it->second);
    if (!parsed) return fail("quality=" + it->second + ": expected draft, default or high");
    out.quality = *parsed;
  }
  for (const auto& [k, v] : p) {
    if (k == "quality") continue;
    if (k == "rays_per_basis") {
      auto x = positiveInt(k, v);
      if (!x) return std::unexpected(x.error());
      out.rays_per_basis = *x;
    } else if (k == "bounces") {
      auto x = positiveInt(k, v);
      if (!x) return std::unexpected(x.error());
      out.bounces = *x;
    } else if (k == "fill") {
      if (v == "nearest") out.fill = runtime::FillMode::kNearest;
      else if (v == "smooth") out.fill = runtime::FillMode::kSmooth;
      else return fail("fill=" + v + ": expected nearest or smooth");
    } else if (k == "texel_m") {
      char* end = nullptr;
      const double x = std::strtod(v.c_str(), &end);
      if (end != v.c_str() + v.size() || !(x > 0.0) || !std::isfinite(x) || x > 1e4) return fail("texel_m=" + v + ": expected metres in (0, 1e4]");
      out.texel_m = float(x);
    } else {
      return fail("no parameter '" + k + "' (drtv takes quality, rays_per_basis, bounces, fill, texel_m)");
    }
  }
  return out;
}

class DrtvTechnique final : public Technique {
 public:
  DrtvTechnique(std::string name, DrtvParams params) : name_(std::move(name)), params_(std::move(params)) {}

  Result<void> prepare(const PrepareInput& in) override {
    baker::BakeSettings s = baker::BakeSettings::forQuality(params_.quality, in.seed);
    if (params_.rays_per_basis) s.transfer.probe_rays_per_basis = *params_.rays_per_basis;
    if (params_.bounces) s.transfer.bounces = *params_.bounces;
    auto b = baker::bakeInMemory(in.world, in.where, s, in.block, in.threads);
    if (!b) return std::unexpected(b.error());
    costs_.prepare_s = b->bake_s;
    costs_.stored_bytes = b->bytes;
    manifest_ = std::move(b->manifest);
    sectors_ = std::move(b->sectors);
    rt_.reset();
    return {};
  }

  Result<void> prepareBaked(const Manifest& manifest, std::span<const Sector> sectors) override {
    manifest_ = manifest;
    sectors_.assign(sectors.begin(), sectors.end());
    costs_.prepare_s = 0;
    costs_.stored_bytes = 0;
    for (const Sector& s : sectors_) costs_.stored_bytes += encodedSectorBytes(s.probes.size(), s.lprt.sources.size(), s.has_ground);
    rt_.reset();
    return {};
  }

  Result<void> setLighting(double hour, const std::vector<PointLight>& lights) override {
    if (!rt_) {
      runtime::RuntimeOptions o = runtime::optionsForEffects(manifest_.effects);
      o.volume.fill = params_.fill;
      if (params_.texel_m) o.volume.texel_size_m.x = o.volume.texel_size_m.y = *params_.texel_m;
      o.cache.max_sectors = std::max<int>(o.cache.max_sectors, int(sectors_.size()));
      auto rt = runtime::runtimeForArchive(manifest_, o, hour, &lights);
      if (!rt) return std::unexpected(rt.error());
      for (const Sector& s : sectors_)
        if (auto r = (*rt)->addSector(s); !r) return std::unexpected(r.error().context("sector " + toString(s.key)));
      rt_ = std::move(*rt);
      const glm::ivec3 n = o.volume.size;
      costs_.runtime_bytes = size_t(n.x) * size_t(n.y) * size_t(n.z) * 12;  // 3 RGBA8 textures
      return {};
    }
    if (auto r = rt_->setLights(lights); !r) return std::unexpected(r.error());
    return rt_->setTime(hour);
  }

  Result<void> update(const glm::dvec3& camera) override {
    if (!rt_) return fail("technique " + describe() + ": update before setLighting");
    const auto t0 = Clock::now();
    rt_->update(camera);
    costs_.update_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    return {};
  }

  glm::vec3 ambient(const glm::dvec3& position, const glm::vec3& normal) const override {
    return rt_ ? rt_->ambient(position, normal).irradiance : glm::vec3(0.f);
  }

  TechniqueCosts costs() const override { return costs_; }

  std::string describe() const override {
    std::string s = name_;
    char sep = ' ';
    for (const auto& [k, v] : params_.given) s += sep + k + "=" + v, sep = ',';
    return s;
  }

 private:
  std::string name_;
  DrtvParams params_;
  Manifest manifest_;
  std::vector<Sector> sectors_;
  std::unique_ptr<runtime::Runtime> rt_;
  TechniqueCosts costs_;
};

TechniqueFactory factoryFor(std::string name) {
  return [name](const TechniqueParams& p) -> Result<std::unique_ptr<Technique>> {
    auto parsed = parseParams(p);
    if (!parsed) return std::unexpected(parsed.error());
    return std::make_unique<DrtvTechnique>(name, std::move(*parsed));
  };
}

}  // namespace

std::vector<TechniqueRegistration> drtvTechniques() {
  std::vector<TechniqueRegistration> out;
  out.push_back({{"drtv", "Deferred Radiance Transfer Volumes (GDC 2012): baked probe transfer, relit per frame, a camera volume", {}},
                 factoryFor("drtv")});
  out.push_back({{"drtv-nearest", "DRTV, each volume texel from the probe its index cell names (the talk's fill)", {{"fill", "nearest"}}},
                 factoryFor("drtv-nearest")});
  out.push_back({{"drtv-smooth", "DRTV, each volume texel trilinear over the index cells around it", {{"fill", "smooth"}}},
                 factoryFor("drtv-smooth")});
  return out;
}

}  // namespace drtv::eval
