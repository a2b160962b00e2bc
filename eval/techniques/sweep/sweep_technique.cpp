// sweep (technique.h): the top-down sweep light grid of seed 001 (drtv::sweep). prepare() voxelises
// the world into material grids: one coarse grid over the world's sectors and the block, and a
// fine grid per sector of the block, its height following that sector's geometry (terrain and
// vegetation, seed 001: "grid height depends on vegetation height"). setLighting() sweeps them
// all: the coarse grid from the sky, each fine grid with its edges from the coarse grid. ambient()
// reads the finest grid that holds the point, offset along the normal, and within `ground_blend`
// cells of the terrain blends toward the ground normal's irradiance (ground_blend.h). Point lights are not
// part of the model (seed 001 has none): they are ignored. Parameters:
//   cell_m        1 | 2 | 4 | 8 | 16 | 32 | 64   the fine grids' cell edge, metres (0: no fine grids)
//   coarse_m      2 .. 64 (divides 64)          the coarse grid's cell edge, metres
//   bottom_up     0 | 1                         carry the reflected light back up (sweep.h)
//   smoothing     [0, 1]                        SweepOptions::smoothing
//   sun_disc_deg  (0, 45]                       the sun disc's angular radius (directions.h)
//   offset        [0, 4]                        the lookup's offset along the normal, in cells
//   ground_blend  [0, 8]                        the seed's ground-proximity blend (ground_blend.h)
//                                               over this many fine cells above the terrain
//                                               (0: off; default 2)
//   ray_spacing_m (0, 64]                       VoxelOptions::ray_spacing_m
//   material      raycast | models              the fine grids' material: every triangle ray cast
//                                               per sector (sweep_material.h), or the placed
//                                               models voxelised once and resampled, terrain and
//                                               large meshes still ray cast (model_material.h);
//                                               the coarse grid is ray cast either way
//   model_voxel_m [0.02, 2]                     ModelVoxelOptions::voxel_m
// Streaming (beginStreaming, `drtv fly --technique sweep`; grid_streamer.h):
//   workers       1 .. 16                       worker threads sweeping fine grids (deterministic
//                                               mode: virtual workers)
//   lead_s        [0, 10]                       a sector gets its fine grid when the volume's
//                                               footprint will reach it within this many seconds
//                                               at the camera's velocity (if it is resident)
//   resweep_h     (0, 24]                       lighting step, hours (GridStreamerOptions)
//   job_s         [0, 10]                       deterministic mode: seconds a fine sweep takes
//   margin_m      [0, 256]                      ... and the footprint grown by this much, metres
//   max_grids     1 .. 256                      fine grids held at most
// prepare() voxelises every sector with geometry once (offline, Embree, on `threads` threads) and
// keeps each sector's material grid compact (material_codec.h, lossless); with
// PrepareInput::streaming it sweeps only the coarse grid, and the stream sweeps the fine grids of
// the sectors the streamer brings near the camera on its workers.
// Registered as "sweep" and as the variant "sweep-bottom-up" (bottom_up=1).
// The world given to prepare() must outlive the technique.
#include <chrono>
#include <sstream>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "drtv/formats/sector.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/streamer/residency.h"
#include "drtv/sweep/grid_streamer.h"
#include "drtv/sweep/material_codec.h"
#include "drtv/sweep/sweep.h"
#include "ground_blend.h"
#include "model_material.h"
#include "sweep_material.h"

#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>
#include "techniques.h"

namespace drtv::eval {
namespace {

using Clock = std::chrono::steady_clock;

struct Params {
  double cell_m = 1.0;
  double coarse_m = 16.0;
  bool bottom_up = false;
  bool unpacked = false;  // storage=float: the grids' lookups read the light before packing (a measurement)
  float smoothing = sweep::SweepOptions{}.smoothing;
  double sun_disc_deg = 3.0;
  double offset_cells = 0.5;
  // 2 cells: of 0, 1, 2 and 4, the lowest error on the test box (15.4 / 13.8 / 13.0 / 13.6 %) and
  // the Cornell world (28.9 / 29.1 / 28.9 / 29.5 %); the island 9.3 / 9.2 / 9.2 / 9.1 %
  // (`drtv accuracy --knobs sweep`, docs/sweep.md).
  double ground_blend_cells = 2.0;
  double ray_spacing_m = VoxelOptions{}.ray_spacing_m;
  bool models = false;
  double model_voxel_m = ModelVoxelOptions{}.voxel_m;
  int workers = 1;
  double lead_s = 1.0;
  double resweep_h = sweep::GridStreamerOptions{}.resweep_hours;
  double job_s = sweep::GridStreamerOptions{}.simulated_job_s;
  int max_grids = 40;
  double margin_m = 32.0;
};

bool dividesSector(double c) {
  const double n = kSectorSizeM / c;
  return c > 0 && std::abs(n - std::round(n)) < 1e-9;
}

Params readSweep(ParamReader& r) {
  Params out;
  r.real("cell_m", out.cell_m, 0, 64);
  if (r.ok() && out.cell_m != 0 && !dividesSector(out.cell_m)) r.reject("cell_m=" + *r.text("cell_m") + ": must divide 64 (or be 0: no fine grids)");
  r.real("coarse_m", out.coarse_m, 2, 64);
  if (r.ok() && !dividesSector(out.coarse_m)) r.reject("coarse_m=" + *r.text("coarse_m") + ": must divide 64");
  r.flag("bottom_up", out.bottom_up)
      .oneOf("storage", out.unpacked, {{"r11g11b10", false}, {"float", true}})
      .real("smoothing", out.smoothing, 0, 1)
      .real("sun_disc_deg", out.sun_disc_deg, 0, 45, true)
      .real("offset", out.offset_cells, 0, 4)
      .real("ground_blend", out.ground_blend_cells, 0, 8)
      .real("ray_spacing_m", out.ray_spacing_m, 0, 64, true)
      .oneOf("material", out.models, {{"raycast", false}, {"models", true}})
      .real("model_voxel_m", out.model_voxel_m, 0.02, 2)
      .integer("workers", out.workers, 1, 16)
      .real("lead_s", out.lead_s, 0, 10)
      .real("margin_m", out.margin_m, 0, 256)
      .real("resweep_h", out.resweep_h, 0, 24, true)
      .real("job_s", out.job_s, 0, 10)
      .integer("max_grids", out.max_grids, 1, 256);
  if (r.ok() && out.cell_m > out.coarse_m) r.reject("cell_m must not exceed coarse_m");
  return out;
}

std::string text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

double sunDiscRad(const Params& p) { return p.sun_disc_deg * 3.14159265358979323846 / 180.0; }

// A sector's fine grid: its material, compact, its ground heights (the blend's) and (not
// streamed) its light.
struct Fine {
  sweep::GridStreamer::MaterialBytes material;  // material_codec.h
  GroundMap ground;                             // the fine grid's columns
  std::unique_ptr<sweep::SweptGrid> light;
};

// The ambient from the finest grid holding the offset point (the fine grid of the point's
// sector, else the coarse grid).
glm::vec3 lookup(const sweep::SweptGrid* fine, const sweep::SweptGrid& coarse, double offset_cells, const glm::dvec3& position,
                 const glm::vec3& normal) {
  if (fine) {
    const sweep::LightGrid& g = fine->light;
    const glm::dvec3 q = position + glm::dvec3(normal) * (offset_cells * g.shape.cell_m);
    if (g.shape.contains(q)) return g.ambient(q, normal);
  }
  const sweep::LightGrid& g = coarse.light;
  return g.ambient(position + glm::dvec3(normal) * (offset_cells * g.shape.cell_m), normal);
}

// The streamed side (beginStreaming): which sectors are resident (the streamer's sink calls),
// which of them the volume will reach within lead_s, and the grid streamer that sweeps those.
class SweepStream final : public TechniqueStream {
 public:
  SweepStream(const Params& p, const Sky& sky, const sweep::MaterialGrid& coarse, const std::map<SectorKey, Fine>& fine,
              const StreamingSetup& setup)
      : params_(p), fine_(fine), manifest_(setup.manifest), residency_(setup.residency),
        grids_(sky, coarse, options(p, setup.deterministic), setup.start_hour) {}

  void onSectorLoaded(const Sector& sector, const streamer::OcclusionTile&) override { resident_.insert(sector.key); }
  void onSectorEvicted(SectorKey key) override { resident_.erase(key); }

  Result<StreamingFrame> frame(const streamer::Camera& cam, double time_s, double hour, const std::vector<PointLight>&) override {
    if (!std::isfinite(hour)) return fail("sweep: hour must be finite");
    const auto t0 = Clock::now();
    // The reach now: the sectors under the volume's footprint about the camera.
    streamer::footprintSectors(manifest_, cam.position_m, residency_, scratch_);
    reach_.clear();
    for (SectorKey k : scratch_)
      if (fine_.count(k)) reach_.push_back(k);
    // Wanted: every resident sector the footprint, grown by margin_m, covers from now to lead_s
    // ahead (sampled every 16 m, a quarter sector), those in reach now first, then by distance to
    // the camera. The margin catches what the straight look-ahead does not: a sector whose corner
    // the footprint clips while moving sideways, and turns (on the island at 100 m/s, without it,
    // 20 sector-frames in 17 frames were missing, all such).
    const double ahead_m = glm::length(glm::dvec2(cam.velocity_mps)) * params_.lead_s;
    const int samples = 1 + int(std::ceil(ahead_m / 16.0));
    candidates_.clear();
    for (int i = 0; i < samples; ++i) {
      const double f = samples == 1 ? 0.0 : double(i) / double(samples - 1);
      streamer::Footprint fp = streamer::volumeFootprint(cam.position_m + cam.velocity_mps * (params_.lead_s * f), residency_);
      fp.min -= params_.margin_m;
      fp.max += params_.margin_m;
      const SectorKey k0 = sectorAt(fp.min.x, fp.min.y), k1 = sectorAt(fp.max.x, fp.max.y);
      for (int32_t y = k0.iy; y <= k1.iy; ++y)
        for (int32_t x = k0.ix; x <= k1.ix; ++x)
          if (streamer::overlaps({x, y}, fp)) candidates_.push_back({x, y});
    }
    std::sort(candidates_.begin(), candidates_.end());
    candidates_.erase(std::unique(candidates_.begin(), candidates_.end()), candidates_.end());
    struct Rank {
      bool later;
      double distance_m;
      SectorKey key;
      auto operator<=>(const Rank&) const = default;
    };
    std::vector<Rank> ranks;
    const glm::dvec2 c(cam.position_m);
    for (SectorKey k : candidates_)
      if (resident_.count(k) && fine_.count(k))
        ranks.push_back({!std::binary_search(reach_.begin(), reach_.end(), k), streamer::distanceToSegment(k, c, c), k});
    std::sort(ranks.begin(), ranks.end());
    if (ranks.size() > size_t(params_.max_grids)) ranks.resize(size_t(params_.max_grids));
    std::vector<sweep::GridStreamer::Wanted> wanted;
    wanted.reserve(ranks.size());
    for (const Rank& r : ranks) wanted.push_back({r.key, fine_.at(r.key).material});
    grids_.setWanted(std::move(wanted));
    const sweep::GridStreamerStats st = grids_.update(time_s, hour);
    StreamingFrame out;
    out.reach = int(reach_.size());
    for (SectorKey k : reach_) out.missing += grids_.fine(k) == nullptr;
    out.held = st.fine_grids;
    out.stale = st.stale;
    out.queued = st.queued;
    out.bytes = st.bytes;
    out.idle = st.idle;
    out.inline_ms = st.inline_ms;
    out.frame_ms = std::max(0.0, std::chrono::duration<double, std::milli>(Clock::now() - t0).count() - st.inline_ms);
    if (st.failed) return fail(grids_.errors().back());
    return out;
  }

  const sweep::GridStreamer& grids() const { return grids_; }

 private:
  static sweep::GridStreamerOptions options(const Params& p, bool deterministic) {
    sweep::GridStreamerOptions o;
    o.sweep.bottom_up = p.bottom_up;
    o.sweep.smoothing = p.smoothing;
    o.sweep.keep_unpacked = p.unpacked;
    o.sun_disc_rad = sunDiscRad(p);
    o.resweep_hours = p.resweep_h;
    o.workers = deterministic ? 0 : p.workers;
    o.simulated_workers = p.workers;
    o.simulated_job_s = p.job_s;
    return o;
  }

  Params params_;
  const std::map<SectorKey, Fine>& fine_;
  Manifest manifest_;
  streamer::ResidencyOptions residency_;
  sweep::GridStreamer grids_;
  std::set<SectorKey> resident_;
  std::vector<SectorKey> scratch_, reach_, candidates_;
};

class SweepTechnique final : public Technique {
 public:
  using Params = drtv::eval::Params;
  SweepTechnique(TechniqueMade made, Params p) : Technique(std::move(made), traitsFor(p)), params_(std::move(p)) {}

  static Params read(ParamReader& r) { return readSweep(r); }
  static std::vector<TechniqueInfo> variants() {
    return {{"sweep",
             "the top-down sweep light grid (seed 001): sky and sun swept down through voxelised material grids, "
             "a 16 m grid over the world and 1 m grids per sector",
             {},
             &knobs},
            {"sweep-bottom-up", "the sweep with the bottom-up pass the seed did not implement (bottom_up=1)", {{"bottom_up", "1"}}, {}}};
  }
  // The sweep's knobs, one at a time around its defaults: seconds each (docs/sweep.md).
  static std::vector<KnobRow> knobs(const KnobContext&) {
    const Params d;
    std::vector<KnobRow> rows;
    auto add = [&](const char* knob, std::vector<std::string> values, const std::string& def, const std::string& note) {
      for (KnobRow& row : knobAround("sweep", std::string("sweep_") + knob, knob, values, def, note)) rows.push_back(std::move(row));
    };
    add("ground_blend", {"0", "1", "2", "4"}, text(d.ground_blend_cells),
        "the seed's ground-proximity blend over this many cells above the terrain (0: off)");
    add("material", {"raycast", "models"}, d.models ? "models" : "raycast",
        "the fine grids' material: ray cast, or per-model grids (OpenVDB) resampled");
    add("storage", {"r11g11b10", "float"}, d.unpacked ? "float" : "r11g11b10",
        "the light grids' values as stored (R11G11B10), or as swept before packing (float: what the stored form costs)");
    for (const char* v : {"0.25", "0.5"})
      rows.push_back({"sweep_model_voxel_m", v, false, "sweep", TechniqueParams{{"material", "models"}, {"model_voxel_m", v}},
                      "material=models with model voxels of this many metres (0.125: the sweep_material models row)"});
    return rows;
  }

 protected:
  static TechniqueTraits traitsFor(const Params& p) {
    return {.prepares_from_world = true, .streams_per_sector = p.cell_m > 0, .frame_work = FrameWork::kLighting};
  }

  Result<void> onPrepare(const PrepareInput& in) override {
    stream_.reset();
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
    // material=models: the placed models voxelised once; the rest of the world (terrain, large
    // meshes) is what is ray cast.
    std::optional<ModelMaterial> models;
    std::optional<worlds::World> rest;
    std::optional<raytrace::WorldGeometry> rest_geo;
    if (params_.models && params_.cell_m > 0) {
      auto mm = ModelMaterial::build(in.world, {params_.model_voxel_m});
      if (!mm) return std::unexpected(mm.error().context(in.where));
      models = std::move(*mm);
      rest.emplace();
      rest->name = in.world.name;
      rest->meshes = in.world.meshes;
      rest->sky = in.world.sky;
      bool any = false;
      for (const worlds::Instance& inst : in.world.instances)
        if (!placedAsModel(in.world, inst)) {
          rest->instances.push_back(inst);
          any |= inst.cls != worlds::InstanceClass::kDynamic;
        }
      if (any) {
        auto rg = raytrace::WorldGeometry::build(*rest, in.where);
        if (!rg) return std::unexpected(rg.error());
        rest_geo = std::move(*rg);
      }
    }
    if (params_.cell_m > 0) {
      // Each sector of the block voxelised on its own (in parallel: each result lands in its own
      // slot, so the grids do not depend on the threads), then kept compact.
      std::vector<SectorKey> keys;
      for (int32_t y = in.block.y0; y <= in.block.y1; ++y)
        for (int32_t x = in.block.x0; x <= in.block.x1; ++x) keys.push_back({x, y});
      struct Made {
        sweep::GridStreamer::MaterialBytes material;
        GroundMap ground;
      };
      std::vector<std::optional<Result<Made>>> made(keys.size());
      const double f = params_.cell_m;
      auto one = [&](size_t i) -> Result<Made> {
        const SectorKey key = keys[i];
        const raytrace::SectorGeometry sg = geo->gather(key, vo.halo_m);
        if (sg.triangleCount() == 0) return Made{};
        // Two cells of air above the tallest geometry, one below the lowest.
        const double lo = std::floor(double(sg.z_min) / f) * f - f, hi = std::ceil(double(sg.z_max) / f) * f + 2 * f;
        sweep::GridShape fs{{kSectorSizeM * key.ix, kSectorSizeM * key.iy, lo}, f,
                            {int(std::lround(kSectorSizeM / f)), int(std::lround(kSectorSizeM / f)), int(std::lround((hi - lo) / f))}};
        Made out;
        out.ground = {glm::dvec2(fs.origin), fs.cell_m, fs.size.x, fs.size.y, {}};
        Result<sweep::MaterialGrid> fm = fail("");
        if (models) {
          const ObjectLayer objects = models->resample(fs);
          fm = voxelise(rest_geo ? &*rest_geo : nullptr, fs, vo, &out.ground.z, &objects);
        } else {
          fm = voxelise(*geo, fs, vo, &out.ground.z);
        }
        if (!fm) return std::unexpected(fm.error().context(in.where));
        out.material = std::make_shared<const std::vector<uint8_t>>(sweep::encodeMaterial(*fm));
        return out;
      };
      tbb::task_arena arena(in.threads > 0 ? in.threads : tbb::task_arena::automatic);
      arena.execute([&] { tbb::parallel_for(size_t(0), keys.size(), [&](size_t i) { made[i] = one(i); }); });
      for (size_t i = 0; i < keys.size(); ++i) {
        if (!*made[i]) return std::unexpected(made[i]->error());
        if ((*made[i])->material) {
          Fine& fine = fine_[keys[i]];
          fine.material = std::move((*made[i])->material);
          fine.ground = std::move((*made[i])->ground);
        }
      }
    }
    costs_.stored_bytes = materialBytes();
    streaming_ = in.streaming;
    prepared_ = true;
    return sweepAll(12.0);
  }

  Result<void> onSetParams(const TechniqueParams& params) override {
    auto p = readParams<Params>(params, &read);
    if (!p) return std::unexpected(p.error());
    if (prepared_ && (p->cell_m != params_.cell_m || p->coarse_m != params_.coarse_m || p->ray_spacing_m != params_.ray_spacing_m ||
                      p->models != params_.models || p->model_voxel_m != params_.model_voxel_m))
      return fail("cell_m, coarse_m, ray_spacing_m, material and model_voxel_m need another prepare");
    if (stream_) return fail("parameters are fixed while streaming");
    params_ = std::move(*p);
    setTraits(traitsFor(params_));
    if (prepared_) return sweepAll(hour_);
    return {};
  }

  Result<void> onSetLighting(double hour, const std::vector<PointLight>&) override {
    if (stream_) return fail("streaming: the hour goes to TechniqueStream::frame");
    return sweepAll(hour);
  }

  Result<void> onUpdate(const glm::dvec3&) override { return {}; }

  Result<TechniqueStream*> onBeginStreaming(const StreamingSetup& setup) override {
    if (!streaming_) return fail("beginStreaming needs prepare() with streaming");
    stream_.reset();
    coarse_.reset();  // the stream sweeps its own
    stream_ = std::make_unique<SweepStream>(params_, sky_, coarse_material_, fine_, setup);
    costs_.runtime_bytes = stream_->grids().coarse().bytes();
    return stream_.get();
  }

  glm::vec3 onAmbient(const glm::dvec3& position, const glm::vec3& normal) const override {
    const SectorKey key = sectorAt(position.x, position.y);
    const auto it = fine_.find(key);
    const sweep::SweptGrid* fine = nullptr;
    const sweep::SweptGrid* coarse = nullptr;
    if (stream_) {
      fine = stream_->grids().fine(key);
      coarse = &stream_->grids().coarse();
    } else {
      if (!coarse_) return glm::vec3(0.f);
      fine = it != fine_.end() ? it->second.light.get() : nullptr;
      coarse = coarse_.get();
    }
    const GroundMap* ground = it != fine_.end() ? &it->second.ground : nullptr;
    return blendTowardGround(ground, params_.ground_blend_cells * params_.cell_m, position, normal,
                             [&](const glm::vec3& n) { return lookup(fine, *coarse, params_.offset_cells, position, n); });
  }

 private:
  size_t materialBytes() const {
    size_t n = coarse_material_.shape.cellCount() * (sizeof(float) + sizeof(glm::vec3));
    for (const auto& [k, f] : fine_) n += f.material->size();
    return n;
  }

  Result<void> sweepAll(double hour) {
    hour_ = hour;
    const sweep::SkyInput sky{sweep::skyLight(sky_, hour), sweep::sunLight(sky_, hour, sunDiscRad(params_))};
    sweep::SweepOptions o;
    o.bottom_up = params_.bottom_up;
    o.smoothing = params_.smoothing;
    o.keep_unpacked = params_.unpacked;
    o.keep_direct = true;
    coarse_ = std::make_unique<sweep::SweptGrid>(sweep::sweep(coarse_material_, sky, nullptr, o));
    size_t bytes = coarse_->bytes();
    o.keep_direct = false;
    for (auto& [k, f] : fine_) {
      if (streaming_) break;  // the stream sweeps them
      auto m = sweep::decodeMaterial(*f.material);
      if (!m) return std::unexpected(m.error().context("sweep: sector " + toString(k)));  // a bug: we encoded it
      f.light = std::make_unique<sweep::SweptGrid>(sweep::sweep(*m, sky, coarse_.get(), o));
      bytes += f.light->bytes();
    }
    costs_.runtime_bytes = bytes;
    return {};
  }

  Params params_;
  Sky sky_;
  bool prepared_ = false, streaming_ = false;
  double hour_ = 12.0;
  sweep::MaterialGrid coarse_material_;
  std::unique_ptr<sweep::SweptGrid> coarse_;
  std::map<SectorKey, Fine> fine_;
  std::unique_ptr<SweepStream> stream_;
};

}  // namespace

Result<void> registerSweepTechniques() { return registerTechnique<SweepTechnique>(); }

}  // namespace drtv::eval
