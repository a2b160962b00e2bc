// probe-reference (technique.h): DRTV's probes and index grid, but each probe's values path-traced
// (the reference) instead of baked and relit, read at the probe the index grid names for a point,
// without the volume. It isolates the error of the directional representation from everything
// else (docs/accuracy.md, `basis` rows). Parameters:
//   basis          sh-l1 | 4-basis | ambient-cube   how a probe's light is stored and read back
//                  (default sh-l1, the representation drtv bakes by default):
//                  the talk's four bases and shading weights; the six-axis ambient cube [2]; band-1
//                  SH irradiance from the same six axes [3] (accuracy.h's references)
//   probe_samples  integer >= 2                     reference paths per probe and direction
//   part           sun_bounce | sky_bounce | direct_sky | local_lights
//                  one term of the reference's ambient alone (reference.h), so that a term's
//                  error in the `part` rows can be set against the representation's floor for it
//                  (default: the whole ambient)
// Only the probes the shaded points name are traced, at evaluate(); their values are kept per hour,
// so that another basis reads them without tracing again. The world given to prepare() must
// outlive the technique.
#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>

#include "drtv/baker/bake.h"
#include "drtv/formats/sh.h"
#include "drtv/reference/reference.h"
#include "drtv/runtime/runtime.h"
#include "techniques.h"

namespace drtv::eval {
namespace {

enum class Basis { kFour, kCube, kShL1 };

struct Params {
  Basis basis = Basis::kShL1;  // the default representation's (drtv bakes sh-l1)
  int probe_samples = 256;
  int part = -1;  // a ReferencePart up to kRefLocalLights, or -1: the whole ambient
};

Params readProbeReference(ParamReader& r) {
  Params out;
  r.oneOf("basis", out.basis, {{"4-basis", Basis::kFour}, {"ambient-cube", Basis::kCube}, {"sh-l1", Basis::kShL1}});
  r.integer("probe_samples", out.probe_samples, 2, 1 << 20);
  r.oneOf("part", out.part,
          {{"sun_bounce", int(reference::kRefSunBounce)}, {"sky_bounce", int(reference::kRefSkyBounce)},
           {"direct_sky", int(reference::kRefDirectSky)}, {"local_lights", int(reference::kRefLocalLights)}});
  return out;
}

// 10 normals per probe: the 4 bases, then +x -x +y -y +z -z.
const std::array<glm::vec3, 10>& probeNormals() {
  static const std::array<glm::vec3, 10> n = {sh::kBasis[0], sh::kBasis[1], sh::kBasis[2], sh::kBasis[3],
                                              glm::vec3(1, 0, 0),  glm::vec3(-1, 0, 0), glm::vec3(0, 1, 0),
                                              glm::vec3(0, -1, 0), glm::vec3(0, 0, 1),  glm::vec3(0, 0, -1)};
  return n;
}

class ProbeReference final : public Technique {
 public:
  using Params = drtv::eval::Params;
  ProbeReference(TechniqueMade made, Params p)
      : Technique(std::move(made), {.frame_work = FrameWork::kNone}), params_(std::move(p)) {}

  static Params read(ParamReader& r) { return readProbeReference(r); }
  static std::vector<TechniqueInfo> variants() {
    return {{"probe-reference",
             "DRTV's probes with path-traced values read through a basis (4-basis, ambient-cube, sh-l1), no volume: "
             "the representation's error alone",
             {},
             {}}};
  }

 protected:
  Result<void> onPrepare(const PrepareInput& in) override {
    const baker::BakeSettings s = baker::BakeSettings::forQuality(baker::Quality::kDefault, in.seed);
    std::optional<baker::InMemoryBake> own;
    auto baked = bakeFor(in, s, own);
    if (!baked) return std::unexpected(baked.error());
    const baker::InMemoryBake* bake = *baked;
    auto scene = reference::ReferenceScene::build(in.world, in.where);
    if (!scene) return std::unexpected(scene.error());
    scene_ = std::make_unique<reference::ReferenceScene>(std::move(*scene));
    world_ = &in.world;
    seed_ = in.seed;
    threads_ = in.threads;
    // A runtime only for its index grid: which probe a point reads (ProbeCache::probeAt).
    runtime::RuntimeOptions o = runtime::optionsForEffects(bake->manifest.effects);
    auto rt = runtime::runtimeForSectors(bake->manifest, o, 12.0, bake->sectors);
    if (!rt) return std::unexpected(rt.error());
    rt_ = std::move(*rt);
    normal_offset_m_ = o.normal_offset_m;
    reportPrepareSeconds(0.0);  // the probes' tracing is counted as evaluate() traces them
    costs_.stored_bytes = bake->bytes;
    const glm::ivec3 n = o.volume.size;
    volume_texels_ = size_t(n.x) * size_t(n.y) * size_t(n.z);
    setBytes();
    probes_.clear();
    traced_.clear();
    return {};
  }

  Result<void> onSetParams(const TechniqueParams& params) override {
    auto p = readParams<Params>(params, &read);
    if (!p) return std::unexpected(p.error());
    if (p->probe_samples != params_.probe_samples) traced_.clear();
    params_ = std::move(*p);
    setBytes();
    return {};
  }

  Result<void> onSetLighting(double hour, const std::vector<PointLight>& lights) override {
    // The traced values hold for one lighting: other lights (the same count or not) trace again.
    auto same = [](const PointLight& a, const PointLight& b) {
      return a.position == b.position && a.intensity == b.intensity && a.radius_m == b.radius_m;
    };
    if (!std::equal(lights.begin(), lights.end(), lights_.begin(), lights_.end(), same)) traced_.clear();
    hour_ = hour;
    lights_ = lights;
    return {};
  }

  Result<void> onUpdate(const glm::dvec3&) override { return {}; }

  Result<std::vector<glm::vec3>> onEvaluate(std::span<const SurfacePoint> points) override {
    // The probes the points name, in the order the points first name them.
    std::vector<int> point_probe(points.size(), -1);
    for (size_t i = 0; i < points.size(); ++i) point_probe[i] = probeIndex(points[i]);
    std::vector<Traced>& e = traced_[key()];
    if (e.size() < probes_.size()) {
      const auto t0 = std::chrono::steady_clock::now();
      reference::ReferenceSettings ps;
      ps.samples = params_.probe_samples;
      ps.seed = seed_;
      std::vector<reference::ReferenceQuery> q;
      for (size_t k = e.size(); k < probes_.size(); ++k)
        for (int d = 0; d < 10; ++d) q.push_back({probes_[k].position, probeNormals()[size_t(d)], uint64_t(1u << 30) + k * 10 + d});
      const auto r = reference::referenceIrradiance(*scene_, reference::ReferenceLighting{world_->sky, hour_, lights_}, q, ps, threads_);
      for (size_t k = 0; k * 10 < r.size(); ++k) {
        Traced v;
        for (int d = 0; d < 10; ++d) {
          v[0][size_t(d)] = r[k * 10 + d].ambient.mean;
          for (int q = 0; q <= reference::kRefLocalLights; ++q) v[size_t(q + 1)][size_t(d)] = r[k * 10 + d].parts[size_t(q)].mean;
        }
        e.push_back(v);
      }
      costs_.prepare_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    std::vector<glm::vec3> out;
    out.reserve(points.size());
    for (size_t i = 0; i < points.size(); ++i)
      out.push_back(point_probe[i] < 0 ? glm::vec3(0.f) : read(e[size_t(point_probe[i])][size_t(params_.part + 1)], points[i].normal));
    return out;
  }

  glm::vec3 onAmbient(const glm::dvec3& position, const glm::vec3& normal) const override {
    const runtime::ProbeRef pr = rt_->cache().probeAt(position + glm::dvec3(normal) * double(normal_offset_m_));
    const auto it = traced_.find(key());
    if (!pr.valid() || it == traced_.end()) return glm::vec3(0.f);
    for (size_t k = 0; k < probes_.size() && k < it->second.size(); ++k)
      if (probes_[k].slot == pr.slot && probes_[k].index == pr.index) return read(it->second[k][size_t(params_.part + 1)], normal);
    return glm::vec3(0.f);  // a probe no evaluate() traced
  }


 private:
  struct Probe {
    int slot, index;
    glm::dvec3 position;
  };
  // A probe's traced irradiance on its 10 normals: the whole ambient, then each part up to the
  // local lights, so that another part reads them without tracing again.
  using Traced = std::array<std::array<glm::vec3, 10>, reference::kRefLocalLights + 2>;

  // The hour the traced values belong to (the lights are the same for all of traced_).
  double key() const { return hour_; }

  int probeIndex(const SurfacePoint& p) {
    const runtime::ProbeRef pr = rt_->cache().probeAt(p.position + glm::dvec3(p.normal) * double(normal_offset_m_));
    if (!pr.valid()) return -1;
    for (size_t k = 0; k < probes_.size(); ++k)
      if (probes_[k].slot == pr.slot && probes_[k].index == pr.index) return int(k);
    probes_.push_back({pr.slot, pr.index, rt_->cache().worldPosition(pr)});
    return int(probes_.size() - 1);
  }

  glm::vec3 read(const std::array<glm::vec3, 10>& e, const glm::vec3& n) const {
    switch (params_.basis) {
      case Basis::kFour: {
        const glm::vec4 w = sh::shadingWeights(n);
        return w.x * e[0] + w.y * e[1] + w.z * e[2] + w.w * e[3];
      }
      case Basis::kCube:
        // The squared normal components weigh the axis the normal leans to.
        return n.x * n.x * (n.x >= 0 ? e[4] : e[5]) + n.y * n.y * (n.y >= 0 ? e[6] : e[7]) + n.z * n.z * (n.z >= 0 ? e[8] : e[9]);
      case Basis::kShL1: {
        glm::vec3 a(0.f);
        for (int d = 4; d < 10; ++d) a += e[size_t(d)] / 6.f;
        const glm::vec3 bx = 0.5f * (e[4] - e[5]), by = 0.5f * (e[6] - e[7]), bz = 0.5f * (e[8] - e[9]);
        return glm::max(a + n.x * bx + n.y * by + n.z * bz, glm::vec3(0.f));
      }
    }
    return glm::vec3(0.f);
  }

  void setBytes() { costs_.runtime_bytes = volume_texels_ * (params_.basis == Basis::kCube ? 18 : 12); }

  Params params_;
  std::unique_ptr<reference::ReferenceScene> scene_;
  const worlds::World* world_ = nullptr;
  uint64_t seed_ = 1;
  int threads_ = 0;
  std::unique_ptr<runtime::Runtime> rt_;
  float normal_offset_m_ = 1.f;
  size_t volume_texels_ = 0;
  double hour_ = 12.0;
  std::vector<PointLight> lights_;
  std::vector<Probe> probes_;
  std::map<double, std::vector<Traced>> traced_;
};

}  // namespace

Result<void> registerProbeReferenceTechnique() { return registerTechnique<ProbeReference>(); }

}  // namespace drtv::eval
