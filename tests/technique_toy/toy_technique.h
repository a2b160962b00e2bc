// A toy technique: the smallest one a newcomer copies (technique.h, "Adding a technique"). Its
// ambient is the prepared world's sky at the hour, unoccluded, times `level`: E(n) = level x the
// sky's irradiance on an open plane facing n, approximated as (0.5 + 0.5 n.z) x pi x the zenith
// radiance. No bake, nothing per frame.
#pragma once

#include <sstream>

#include "drtv/eval/technique.h"

namespace drtv::toy {

class ToyTechnique final : public eval::Technique {
 public:
  struct Params {
    double level = 1.0;  // a scale on the sky's light, [0, 10]
  };
  ToyTechnique(eval::TechniqueMade made, Params p)
      : Technique(std::move(made), {.prepares_from_world = true, .frame_work = eval::FrameWork::kNone}), params_(p) {}

  static Params read(eval::ParamReader& r) {
    Params p;
    r.real("level", p.level, 0.0, 10.0);
    return p;
  }
  static std::vector<eval::TechniqueInfo> variants() {
    return {{"toy", "the sky's light unoccluded, scaled (a test's technique)", {}, &knobs},
            {"toy-bright", "the toy at twice the light", {{"level", "2"}}, {}}};
  }
  static std::vector<eval::KnobRow> knobs(const eval::KnobContext&) {
    std::ostringstream def;
    def << Params{}.level;
    return eval::knobAround("toy", "toy_level", "level", {"0.5", "1", "2"}, def.str(), "the sky's light scaled");
  }

 protected:
  Result<void> onPrepare(const eval::PrepareInput& in) override {
    sky_ = &in.world.sky;
    return {};
  }
  Result<void> onSetLighting(double hour, const std::vector<PointLight>&) override {
    zenith_ = sky_->skyRadiance(glm::dvec3(0, 0, 1), hour);
    return {};
  }
  Result<void> onUpdate(const glm::dvec3&) override {
    ++updates_;
    return {};
  }
  glm::vec3 onAmbient(const glm::dvec3&, const glm::vec3& n) const override {
    return float(params_.level) * (0.5f + 0.5f * n.z) * 3.14159265f * zenith_;
  }
  Result<void> onSetParams(const eval::TechniqueParams& params) override {
    auto p = eval::readParams<Params>(params, &read);
    if (!p) return std::unexpected(p.error());
    params_ = *p;
    return {};
  }

 public:
  int updates() const { return updates_; }  // update() calls that reached the toy

 private:
  int updates_ = 0;
  Params params_;
  const Sky* sky_ = nullptr;
  glm::vec3 zenith_{0.f};
};

}  // namespace drtv::toy
