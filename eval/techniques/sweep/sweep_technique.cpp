// sweep (technique.h): the top-down sweep light grid of seed 001 (drtv::sweep). prepare() voxelises
// the world into material grids: one coarse grid over the world's sectors and the block, and a
// fine grid per sector of the block, its height following that sector's geometry (terrain and
// vegetation, seed 001: "grid height depends on vegetation height"). setLighting() sweeps them
// all: the coarse grid from the sky, each fine grid with its edges from the coarse grid. ambient()
// reads the finest grid that holds the point, offset along the normal. Point lights are not
// part of the model (seed 001 has none): they are ignored. Parameters:
//   cell_m        1 | 2 | 4 | 8 | 16 | 32 | 64   the fine grids' cell edge, metres (0: no fine grids)
//   coarse_m      2 .. 64 (divides 64)          the coarse grid's cell edge, metres
//   bottom_up     0 | 1                         carry the reflected light back up (sweep.h)
//   smoothing     [0, 1]                        SweepOptions::smoothing
//   sun_disc_deg  (0, 45]                       the sun disc's angular radius (directions.h)
//   offset        [0, 4]                        the lookup's offset along the normal, in cells
//   ray_spacing_m (0, 64]                       VoxelOptions::ray_spacing_m
// Registered as "sweep" and as the variant "sweep-bottom-up" (bottom_up=1).
// The world given to prepare() must outlive the technique.
#include <chrono>
#include <charconv>
#include <cmath>
#include <map>
#include <memory>

#include "drtv/formats/sector.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/sweep/sweep.h"
#include "sweep_material.h"
#include "techniques.h"

namespace drtv::eval {
namespace {

using Clock = std::chrono::steady_clock;

struct Params {
  double cell_m = 1.0;
  double coarse_m = 16.0;
  bool bottom_up = false;
  float smoothing = sweep::SweepOptions{}.smoothing;
  double sun_disc_deg = 3.0;
  double offset_cells = 0.5;
  double ray_spacing_m = VoxelOptions{}.ray_spacing_m;
  TechniqueParams given;
};

Result<double> number(const std::string& k, const std::string& v, double lo, double hi, bool lo_open) {
  double x = 0;
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
  if (ec != std::errc() || end != v.data() + v.size() || !std::isfinite(x) || x > hi || x < lo || (lo_open && x == lo))
    return fail(k + "=" + v + ": expected a number in " + (lo_open ? "(" : "[") + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return x;
}

bool dividesSector(double c) {
  const double n = kSectorSizeM / c;
  return c > 0 && std::abs(n - std::round(n)) < 1e-9;
}

Result<Params> parseParams(const TechniqueParams& p) {
  Params out;
  out.given = p;
  for (const auto& [k, v] : p) {
    Result<double> x = fail("");
    if (k == "cell_m") {
      x = number(k, v, 0, 64, false);
      if (x && *x != 0 && !dividesSector(*x)) return fail(k + "=" + v + ": must divide 64 (or be 0: no fine grids)");
      if (x) out.cell_m = *x;
    } else if (k == "coarse_m") {
      x = number(k, v, 2, 64, false);
      if (x && !dividesSector(*x)) return fail(k + "=" + v + ": must divide 64");
      if (x) out.coarse_m = *x;
    } else if (k == "bottom_up") {
      if (v != "0" && v != "1") return fail(k + "=" + v + ": expected 0 or 1");
      out.bottom_up = v == "1";
      continue;
    } else if (k == "smoothing") {
      x = number(k, v, 0, 1, false);
      if (x) out.smoothing = float(*x);
    } else if (k == "sun_disc_deg") {
      x = number(k, v, 0, 45, true);
      if (x) out.sun_disc_deg = *x;
    } else if (k == "offset") {
      x = number(k, v, 0, 4, false);
      if (x) out.offset_cells = *x;
    } else if (k == "ray_spacing_m") {
      x = number(k, v, 0, 64, true);
      if (x) out.ray_spacing_m = *x;
    } else {
      return fail("no parameter '" + k + "' (sweep takes cell_m, coarse_m, bottom_up, smoothing, sun_disc_deg, offset, ray_spacing_m)");
    }
    if (!x) return std::unexpected(x.error());
  }
  if (out.cell_m > out.coarse_m) return fail("cell_m must not exceed coarse_m");
  return out;
}

class SweepTechnique final : public Technique {
 public:
  SweepTechnique(std::string name, Params p) : name_(std::move(name)), params_(std::move(p)) {}

  Result<void> prepare(const PrepareInput& in) override {
    const auto t0 = Clock::now();
    auto geo = raytrace::WorldGeometry::build(in.world, in.where);
    if (!geo) return std::unexpected(geo.error());
    sky_ = in.world.sky;
    fine_.clear();
    coarse_.reset();
    // The coarse grid: every sector of the world and of the block, the geometry's height range.
    raytrace::SectorRange all = geo->sectors();
    all = {std::min(all.x0, in.block.x0), std::max(all.x1, in.block.x1), std::min(all.y0, in.block.y0), std::max(all.y1, in.block.y1)};
    const double c = params_.coarse_m;
    const double z0 = std::floor(geo->boundsMin().z / c) * c - c, z1 = std::ceil(geo->boundsMax().z / c) * c + c;
    sweep::GridShape cs{{kSectorSizeM * all.x0, kSectorSizeM * all.y0, z0}, c,
                        {int(std::lround((all.x1 - all.x0 + 1) * kSectorSizeM / c)),
                         int(std::lround((all.y1 - all.y0 + 1) * kSectorSizeM / c)), int(std::lround((z1 - z0) / c))}};
    VoxelOptions vo;
    vo.ray_spacing_m = params_.ray_spacing_m;
    auto cm = voxelise(*geo, cs, vo);
    if (!cm) return std::unexpected(cm.error().context(in.where));
    coarse_material_ = std::move(*cm);
    if (params_.cell_m > 0) {
      const double f = params_.cell_m;
      for (int32_t y = in.block.y0; y <= in.block.y1; ++y)
        for (int32_t x = in.block.x0; x <= in.block.x1; ++x) {
          const SectorKey key{x, y};
          const raytrace::SectorGeometry sg = geo->gather(key, vo.halo_m);
          if (sg.triangleCount() == 0) continue;
          // Two cells of air above the tallest geometry, one below the lowest.
          const double lo = std::floor(double(sg.z_min) / f) * f - f, hi = std::ceil(double(sg.z_max) / f) * f + 2 * f;
          sweep::GridShape fs{{kSectorSizeM * x, kSectorSizeM * y, lo}, f,
                              {int(std::lround(kSectorSizeM / f)), int(std::lround(kSectorSizeM / f)), int(std::lround((hi - lo) / f))}};
          auto fm = voxelise(*geo, fs, vo);
          if (!fm) return std::unexpected(fm.error().context(in.where));
          fine_[key].material = std::move(*fm);
        }
    }
    costs_ = {};
    costs_.prepare_s = std::chrono::duration<double>(Clock::now() - t0).count();
    costs_.stored_bytes = materialBytes();
    prepared_ = true;
    return sweepAll(12.0);
  }

  Result<void> setParams(const TechniqueParams& params) override {
    auto p = parseParams(params);
    if (!p) return std::unexpected(p.error());
    if (prepared_ && (p->cell_m != params_.cell_m || p->coarse_m != params_.coarse_m || p->ray_spacing_m != params_.ray_spacing_m))
      return fail("sweep: cell_m, coarse_m and ray_spacing_m need another prepare");
    params_ = std::move(*p);
    if (prepared_) return sweepAll(hour_);
    return {};
  }

  Result<void> setLighting(double hour, const std::vector<PointLight>&) override {
    if (!prepared_) return fail("technique " + describe() + ": setLighting before prepare");
    if (!std::isfinite(hour)) return fail("sweep: hour must be finite");
    return sweepAll(hour);
  }

  Result<void> update(const glm::dvec3&) override { return {}; }
  bool preparesFromWorld() const override { return true; }

  glm::vec3 ambient(const glm::dvec3& position, const glm::vec3& normal) const override {
    if (!coarse_) return glm::vec3(0.f);
    const SectorKey key = sectorAt(position.x, position.y);
    const auto it = fine_.find(key);
    if (it != fine_.end() && it->second.light) {
      const sweep::LightGrid& g = it->second.light->light;
      const glm::dvec3 q = position + glm::dvec3(normal) * (params_.offset_cells * g.shape.cell_m);
      if (g.shape.contains(q)) return g.ambient(q, normal);
    }
    const sweep::LightGrid& g = coarse_->light;
    return g.ambient(position + glm::dvec3(normal) * (params_.offset_cells * g.shape.cell_m), normal);
  }

  TechniqueCosts costs() const override { return costs_; }

  std::string describe() const override { return describeTechnique(name_, params_.given); }

 private:
  struct Fine {
    sweep::MaterialGrid material;
    std::unique_ptr<sweep::SweptGrid> light;
  };

  size_t materialBytes() const {
    size_t n = coarse_material_.shape.cellCount();
    for (const auto& [k, f] : fine_) n += f.material.shape.cellCount();
    return n * (sizeof(float) + sizeof(glm::vec3));
  }

  Result<void> sweepAll(double hour) {
    const auto t0 = Clock::now();
    hour_ = hour;
    const sweep::SkyInput sky{sweep::skyLight(sky_, hour), sweep::sunLight(sky_, hour, params_.sun_disc_deg * 3.14159265358979323846 / 180.0)};
    sweep::SweepOptions o;
    o.bottom_up = params_.bottom_up;
    o.smoothing = params_.smoothing;
    o.keep_direct = true;
    coarse_ = std::make_unique<sweep::SweptGrid>(sweep::sweep(coarse_material_, sky, nullptr, o));
    size_t bytes = coarse_->bytes();
    o.keep_direct = false;
    for (auto& [k, f] : fine_) {
      f.light = std::make_unique<sweep::SweptGrid>(sweep::sweep(f.material, sky, coarse_.get(), o));
      bytes += f.light->bytes();
    }
    costs_.runtime_bytes = bytes;
    costs_.update_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    return {};
  }

  std::string name_;
  Params params_;
  Sky sky_;
  bool prepared_ = false;
  double hour_ = 12.0;
  sweep::MaterialGrid coarse_material_;
  std::unique_ptr<sweep::SweptGrid> coarse_;
  std::map<SectorKey, Fine> fine_;
  TechniqueCosts costs_;
};

}  // namespace

std::vector<TechniqueRegistration> sweepTechniques() {
  auto factory = [](std::string name) -> TechniqueFactory {
    return [name](const TechniqueParams& p) -> Result<std::unique_ptr<Technique>> {
      auto parsed = parseParams(p);
      if (!parsed) return std::unexpected(parsed.error());
      return std::make_unique<SweepTechnique>(name, std::move(*parsed));
    };
  };
  std::vector<TechniqueRegistration> out;
  out.push_back({{"sweep",
                  "the top-down sweep light grid (seed 001): sky and sun swept down through voxelised material grids, "
                  "a 16 m grid over the world and 1 m grids per sector",
                  {}},
                 factory("sweep")});
  out.push_back({{"sweep-bottom-up", "the sweep with the bottom-up pass the seed did not implement (bottom_up=1)", {{"bottom_up", "1"}}},
                 factory("sweep-bottom-up")});
  return out;
}

}  // namespace drtv::eval
