// The technique interface (eval/technique.h): the registry, DRTV through it against physics, and
// the accuracy table's "technique" rows against the rows the same configuration gets directly.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "drtv/eval/accuracy.h"
#include "drtv/eval/technique.h"
#include "drtv/worlds/load.h"
#include "test_scenes.h"

namespace drtv::eval {
namespace {

// A small, fast sweep: one hour, few points and paths, one timing.
AccuracyOptions smallSweep(double hour, int points, std::vector<std::string> techniques = {}) {
  AccuracyOptions o;
  o.hours = {hour};
  o.points = points;
  o.reference_samples = 16;
  o.probe_samples = 8;
  o.timing_repeats = 1;
  o.techniques = std::move(techniques);
  return o;
}

TEST(Techniques, DrtvAndItsTwoFillsAreRegistered) {
  std::vector<std::string> names;
  for (const TechniqueInfo& t : registeredTechniques()) names.push_back(t.name);
  for (const char* want : {"drtv", "drtv-nearest", "drtv-smooth", "probe-reference"})
    EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
  for (const std::string& n : names) {
    auto t = makeTechnique(n);
    ASSERT_TRUE(t.has_value()) << n << ": " << t.error().message;
    EXPECT_EQ((*t)->describe().substr(0, n.size()), n);
  }
}

TEST(Techniques, AnUnknownNameOrParameterIsAnErrorNamingIt) {
  auto u = makeTechnique("lpv-9000");
  ASSERT_FALSE(u.has_value());
  EXPECT_NE(u.error().message.find("unknown technique 'lpv-9000'"), std::string::npos) << u.error().message;
  EXPECT_NE(u.error().message.find("drtv-smooth"), std::string::npos) << "the known names are listed: " << u.error().message;
  for (const auto& [params, what] : std::vector<std::pair<TechniqueParams, std::string>>{
           {{{"fill", "blurry"}}, "fill=blurry"},
           {{{"rays_per_basis", "0"}}, "rays_per_basis=0"},
           {{{"bounces", "2x"}}, "bounces=2x"},
           {{{"texel_m", "-1"}}, "texel_m=-1"},
           {{{"quality", "ultra"}}, "quality=ultra"},
           {{{"colour", "red"}}, "technique drtv: unknown parameter 'colour' (takes: quality, rays_per_basis, "}}) {
    auto t = makeTechnique("drtv", params);
    ASSERT_FALSE(t.has_value()) << what;
    EXPECT_NE(t.error().message.find(what), std::string::npos) << t.error().message;
  }
  EXPECT_FALSE(parseTechniqueParams("fill").has_value());
  EXPECT_FALSE(parseTechniqueParams("=x").has_value());
  auto p = parseTechniqueParams("fill=smooth,texel_m=1");
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->at("fill"), "smooth");
  EXPECT_EQ(p->at("texel_m"), "1");
  EXPECT_TRUE(parseTechniqueParams("")->empty());
}

// A technique of its own, registered from outside the library: adding one is a registration.
class ConstantTechnique final : public Technique {
 public:
  struct Params {};
  ConstantTechnique(TechniqueMade made, Params) : Technique(std::move(made), {}) {}
  static Params read(ParamReader&) { return {}; }
  static std::vector<TechniqueInfo> variants() { return {{"test-constant", "ambient 1 everywhere", {}, {}}}; }

 protected:
  Result<void> onPrepare(const PrepareInput&) override { return {}; }
  Result<void> onSetLighting(double, const std::vector<PointLight>&) override { return {}; }
  Result<void> onUpdate(const glm::dvec3&) override { return {}; }
  glm::vec3 onAmbient(const glm::dvec3&, const glm::vec3&) const override { return glm::vec3(1.f); }
};

TEST(Techniques, ARegisteredTechniqueIsMadeByNameAndANameIsTakenOnce) {
  ASSERT_TRUE(registerTechnique<ConstantTechnique>().has_value());
  EXPECT_FALSE(registerTechnique<ConstantTechnique>().has_value());
  auto factory = [](const TechniqueMade& made) -> Result<std::unique_ptr<Technique>> {
    return std::make_unique<ConstantTechnique>(made, ConstantTechnique::Params{});
  };
  EXPECT_FALSE(registerTechnique({"drtv", "a second drtv", {}, {}}, factory).has_value());
  auto t = makeTechnique("test-constant");
  ASSERT_TRUE(t.has_value());
  // A technique that takes no parameters names the one given.
  auto p = makeTechnique("test-constant", {{"shade", "1"}});
  ASSERT_FALSE(p.has_value());
  EXPECT_NE(p.error().message.find("technique test-constant: unknown parameter 'shade' (takes: none)"), std::string::npos)
      << p.error().message;
  // A technique that does not bake into drtv archives says so.
  auto baked = (*t)->prepareBaked(Manifest{}, {});
  ASSERT_FALSE(baked.has_value());
  EXPECT_NE(baked.error().message.find("constant"), std::string::npos);
  worlds::World w;
  ASSERT_TRUE((*t)->prepare({w, "w", {0, 0, 0, 0}}).has_value());
  ASSERT_TRUE((*t)->setLighting(12.0, {}).has_value());
  EXPECT_EQ((*t)->ambient(glm::dvec3(0.0), glm::vec3(0, 0, 1)), glm::vec3(1.f));
  // Bad input at the interface is an error, not a bug, and names the technique.
  auto hour = (*t)->setLighting(std::nan(""), {});
  ASSERT_FALSE(hour.has_value());
  EXPECT_NE(hour.error().message.find("technique test-constant: hour"), std::string::npos) << hour.error().message;
  EXPECT_FALSE((*t)->update(glm::dvec3(std::nan(""), 0, 0)).has_value());
}

// The call order is a contract: a caller that breaks it has a bug, and the base stops it.
TEST(TechniquesDeathTest, UpdateOrAmbientBeforeSetLightingIsABug) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");  // the registry's and TBB's threads may be running
  auto t = makeTechnique("lpv");
  ASSERT_TRUE(t.has_value());
  EXPECT_DEATH((void)(*t)->setLighting(12.0, {}), "internal error");
  EXPECT_DEATH((void)(*t)->update(glm::dvec3(0.0)), "internal error");
  EXPECT_DEATH((void)(*t)->ambient(glm::dvec3(0.0), glm::vec3(0, 0, 1)), "internal error");
}

// Every technique's parameters are read by one reader: an unknown key is named with the keys the
// technique takes, a malformed value with what was expected, and the technique is named once.
TEST(Techniques, EveryTechniqueNamesAnUnknownParameterAndWhatItTakes) {
  for (const TechniqueInfo& info : registeredTechniques()) {
    auto t = makeTechnique(info.name, {{"foo", "1"}});
    ASSERT_FALSE(t.has_value()) << info.name;
    const std::string& m = t.error().message;
    EXPECT_EQ(m.rfind("technique " + info.name + ": unknown parameter 'foo' (takes: ", 0), 0u) << m;
    EXPECT_EQ(m.find("technique", 1), std::string::npos) << "named once: " << m;
  }
  auto lpv = makeTechnique("lpv", {{"cells", "many"}});
  ASSERT_FALSE(lpv.has_value());
  EXPECT_EQ(lpv.error().message, "technique lpv: cells=many: expected an integer in [4, 128]");
  auto sweep = makeTechnique("sweep", {{"cell_m", "3"}});
  ASSERT_FALSE(sweep.has_value());
  EXPECT_EQ(sweep.error().message, "technique sweep: cell_m=3: must divide 64 (or be 0: no fine grids)");
  auto cube = makeTechnique("ambient-cube", {{"sun_transfer", "maybe"}});
  ASSERT_FALSE(cube.has_value());
  EXPECT_EQ(cube.error().message, "technique ambient-cube: sun_transfer=maybe: expected on or off");
}

// A white plane under a uniform sky of radiance L: the ground reflects L (rho E / pi with E = pi L),
// so the radiance is L from every direction and every surface receives E = pi L exactly. DRTV
// through the interface, both fills, at points on and above the plane (one 5 m from a sector
// corner), facing up, down, sideways and at 37 deg, at the default (sh-l1) and default quality.
// Tolerance 3 %: issue 13's bound for the default; measured here within 2.1 % (the sideways
// normal at the corner point: the band-1 transfer's Monte Carlo estimate of the ground's half of
// the sky, 256 rays per basis, and the fit of the direct sky). Draft quality (64 rays) reads
// 4.1 % low facing down at that point, from the same estimate. fc3 passes facing up and down but
// gives 1.167 pi L facing sideways and 1.10 pi L at 37 deg, because the talk's shading weights
// (sh::shadingWeights) do not sum to 1 there: its figures are asserted as the finding they are.
TEST(Techniques, DrtvOverAWhitePlaneUnderAUniformSkyGivesPiLFacingEveryWay) {
  const float L = 1.5f;
  worlds::World world = testing::planeWorld(2000.0, glm::vec3(1.f));
  world.sky = testing::uniformSky(L, 1.f);
  const raytrace::SectorRange block{-1, 0, -1, 0};
  const double want = testing::kPi * L;
  const glm::vec3 side(1, 0, 0), tilted = glm::normalize(glm::vec3(0.6f, 0.f, 0.8f));  // 37 deg from up
  for (const char* name : {"drtv-nearest", "drtv-smooth"}) {
    auto t = makeTechnique(name);
    ASSERT_TRUE(t.has_value()) << t.error().message;
    ASSERT_TRUE((*t)->prepare({world, "white plane", block, 1, 0}).has_value());
    ASSERT_TRUE((*t)->setLighting(12.0, {}).has_value());
    const TechniqueCosts c = (*t)->costs();
    EXPECT_GT(c.stored_bytes, 0u);
    EXPECT_EQ(c.runtime_bytes, size_t(96 * 96 * 16 * 12));
    for (const glm::dvec3 at : {glm::dvec3(-20, -30, 0.01), glm::dvec3(-40, -10, 2), glm::dvec3(-5, -5, 6)}) {
      ASSERT_TRUE((*t)->update(at).has_value());
      for (const glm::vec3 n : {glm::vec3(0, 0, 1), glm::vec3(0, 0, -1), side, -side, glm::vec3(0, 1, 0), tilted}) {
        if (at.z < 1 && n.z < 0) continue;  // below the surface
        const glm::vec3 e = (*t)->ambient(at, n);
        for (int ch = 0; ch < 3; ++ch)
          EXPECT_NEAR(e[ch], want, 0.03 * want) << name << " at (" << at.x << ", " << at.y << ", " << at.z << ") normal (" << n.x
                                                << ", " << n.y << ", " << n.z << ") channel " << ch;
      }
    }
  }
  auto fc3 = makeTechnique("drtv-nearest", {{"quality", "draft"}, {"representation", "fc3"}});
  ASSERT_TRUE(fc3.has_value());
  ASSERT_TRUE((*fc3)->prepare({world, "white plane", block, 1, 0}).has_value());
  ASSERT_TRUE((*fc3)->setLighting(12.0, {}).has_value());
  const glm::dvec3 at(-40, -10, 2);
  ASSERT_TRUE((*fc3)->update(at).has_value());
  for (const glm::vec3 n : {glm::vec3(0, 0, 1), glm::vec3(0, 0, -1)}) EXPECT_NEAR((*fc3)->ambient(at, n).y, want, 0.02 * want);
  EXPECT_NEAR((*fc3)->ambient(at, side).y, 1.167 * want, 0.03 * want) << "the talk's weights sum to 1.167 sideways";
  EXPECT_NEAR((*fc3)->ambient(at, tilted).y, 1.10 * want, 0.03 * want) << "and to 1.10 at 37 deg";
}

// The technique measures the lighting of the hour it is given: with the volume blur on (a world
// that asks for it), whose engine-side refill is spread over two frames (publish.h), the first
// point evaluated after a change of hour reads what a technique set up at that hour reads.
TEST(Techniques, DrtvEvaluatesTheHourItIsGivenWithTheBlurOn) {
  worlds::World world = testing::planeWorld(200.0, glm::vec3(0.5f));
  world.effects |= kEffectVolumeBlur;
  const std::vector<SurfacePoint> pts = {{glm::dvec3(-30, -30, 0.01), glm::vec3(0, 0, 1)}, {glm::dvec3(-20, -40, 0.01), glm::vec3(1, 0, 0)}};
  auto at = [&](std::vector<double> hours) {
    auto t = makeTechnique("drtv", {{"quality", "draft"}});
    EXPECT_TRUE(t.has_value());
    EXPECT_TRUE((*t)->prepare({world, "plane", {-1, 0, -1, 0}, 1, 0}).has_value());
    std::vector<glm::vec3> v;
    for (double h : hours) {
      EXPECT_TRUE((*t)->setLighting(h, {}).has_value());
      auto e = (*t)->evaluate(pts);
      EXPECT_TRUE(e.has_value());
      v = *e;
    }
    return v;
  };
  const std::vector<glm::vec3> fresh = at({16.0}), after = at({9.0, 16.0});
  ASSERT_EQ(fresh.size(), after.size());
  for (size_t i = 0; i < fresh.size(); ++i) EXPECT_EQ(fresh[i], after[i]) << "point " << i << " read another hour's volume";
}

// Runtime parameters change on a prepared technique; bake parameters need another prepare.
TEST(Techniques, DrtvTakesRuntimeParametersAfterPrepareAndRefusesBakeOnes) {
  worlds::World world = testing::planeWorld(200.0, glm::vec3(0.5f));
  world.sky = testing::uniformSky(1.f, 0.f);
  auto t = makeTechnique("drtv", {{"quality", "draft"}});
  ASSERT_TRUE(t.has_value());
  ASSERT_TRUE((*t)->prepare({world, "plane", {-1, 0, -1, 0}, 1, 0}).has_value());
  const double bake_s = (*t)->costs().prepare_s;
  auto shade = [&]() {
    EXPECT_TRUE((*t)->setLighting(12.0, {}).has_value());
    const std::vector<SurfacePoint> pts = {{glm::dvec3(-30, -30, 0.01), glm::vec3(0, 0, 1)}};
    auto v = (*t)->evaluate(pts);
    EXPECT_TRUE(v.has_value());
    return v ? v->front() : glm::vec3(-1.f);
  };
  const glm::vec3 all = shade();
  ASSERT_TRUE((*t)->setParams({{"quality", "draft"}, {"part", "direct_sky"}}).has_value());
  const glm::vec3 sky = shade();
  ASSERT_TRUE((*t)->setParams({{"quality", "draft"}, {"part", "sky_bounce"}}).has_value());
  const glm::vec3 bounce = shade();
  EXPECT_EQ((*t)->costs().prepare_s, bake_s) << "no second bake";
  // Under a sky with no sun the whole ambient is the direct sky and its bounce, up to the 8-bit
  // volume's steps (each run fills the volume at its own HDR scale: 0.36 % apart here).
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(all[c], sky[c] + bounce[c], 0.01f * all[c]) << c;
  EXPECT_GT(sky.x, 0.f);
  ASSERT_TRUE((*t)->setParams({{"quality", "draft"}, {"storage", "float"}}).has_value());
  shade();
  EXPECT_EQ((*t)->costs().runtime_bytes, size_t(96 * 96 * 16 * 48));
  auto bake = (*t)->setParams({{"quality", "high"}});
  ASSERT_FALSE(bake.has_value());
  EXPECT_NE(bake.error().message.find("new prepare"), std::string::npos) << bake.error().message;
  EXPECT_FALSE((*t)->setParams({{"quality", "draft"}, {"rays_per_basis", "7"}}).has_value());
  EXPECT_FALSE((*t)->setParams({{"quality", "draft"}, {"shininess", "7"}}).has_value());
}

// The accuracy table's technique rows go through the interface; DRTV's two fills must give there
// exactly what the table's own fill rows give for the same bake and runtime options.
TEST(Techniques, TheAccuracyTablesTechniqueRowsMatchItsFillRows) {
  worlds::World world = testing::planeWorld(400.0, glm::vec3(0.4f, 0.5f, 0.3f));
  world.sky = testing::uniformSky(1.f, 0.f);
  const AccuracyOptions o = smallSweep(10.0, 24);
  auto r = measureAccuracy(world, "plane", o);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  auto find = [&](const std::string& knob, const std::string& value) -> const AccuracyRow* {
    for (const AccuracyRow& row : r->rows)
      if (row.knob == knob && row.value == value) return &row;
    return nullptr;
  };
  for (const TechniqueInfo& t : registeredTechniques()) {
    if (t.name.rfind("drtv", 0) == 0) {
      EXPECT_NE(find("technique", t.name), nullptr) << t.name;
    }
  }
  for (const auto& [technique, fill] : {std::pair{"drtv", "nearest"}, std::pair{"drtv-nearest", "nearest"}, std::pair{"drtv-smooth", "smooth"}}) {
    const AccuracyRow* a = find("technique", technique);
    const AccuracyRow* b = find("fill", fill);
    ASSERT_NE(a, nullptr) << technique;
    ASSERT_NE(b, nullptr) << fill;
    EXPECT_EQ(a->rel_error, b->rel_error) << technique;
    EXPECT_EQ(a->bias, b->bias) << technique;
    EXPECT_EQ(a->abs_error, b->abs_error) << technique;
    EXPECT_EQ(a->probe_bytes, b->probe_bytes) << technique;
    EXPECT_EQ(a->volume_bytes, b->volume_bytes) << technique;
    EXPECT_GT(a->bake_s, 0.0) << technique;
  }
  // The part rows are shares of the whole reference ambient: the runtime's terms add up to its
  // total and the reference's parts to its ambient, so in fc3, whose shading is linear, their
  // biases add up to the total's. sh-l1 (the default) shades max(0, e0 + e.n) per term, and
  // sum_i max(0, x_i) >= max(0, sum_i x_i): its parts may only add up to more than its total, by
  // what the clamp removes where one term's directional part outweighs its e0 (measured here:
  // 0.18 % of the reference ambient).
  auto partsOf = [&](const std::string& knob) {
    double sum = 0;
    int n = 0;
    for (const AccuracyRow& row : r->rows)
      if (row.knob == knob) sum += row.bias, ++n;
    EXPECT_EQ(n, 3) << knob << ": sun bounce, sky bounce, direct sky";
    return sum;
  };
  const AccuracyRow* total = find("rays_per_basis", "128");
  const AccuracyRow* fc3 = find("representation", "fc3");
  ASSERT_NE(total, nullptr);
  ASSERT_NE(fc3, nullptr);
  // Up to rounding: each part is relit, packed to the volume's 8 bits and shaded on its own, so
  // the parts carry three roundings where the total carries one, and which way a texel rounds
  // depends on the relight clone the CPU runs (FMA or not). 1e-4 held on the AVX-512 Xeons; an
  // AVX2 EPYC (2026-12-04) reads 2.1e-4. A term that the total leaves out or counts twice moves
  // the total's bias by that term's whole share of the ambient (here the sky's bounce and its
  // direct light, each a large part of it), hundreds of times 1e-3.
  EXPECT_NEAR(partsOf("part fc3"), fc3->bias, 1e-3);
  const double sh = partsOf("part");
  EXPECT_GE(sh, total->bias - 1e-4);
  EXPECT_LE(sh, total->bias + 0.005);
}

}  // namespace
}  // namespace drtv::eval

namespace drtv::eval {
namespace {

// The per-category errors (issue 16's measurement): on an open plane every point is open ground
// and the category's error is the row's; on the talk's test box (walls, spheres) the walls and
// the dynamic objects get points of their own.
TEST(AccuracyCategories, AnOpenPlaneIsAllOpenGroundAndItsErrorIsTheRows) {
  worlds::World world = testing::planeWorld(400.0, glm::vec3(0.4f));
  world.sky = testing::uniformSky(1.f, 0.f);
  const AccuracyOptions o = smallSweep(10.0, 20, {"drtv"});
  auto r = measureAccuracy(world, "plane", o);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  EXPECT_EQ(r->category_points[kOpenGround], r->points);
  for (const AccuracyRow& row : r->rows) {
    const CategoryError& e = row.categories[kOpenGround];
    EXPECT_EQ(e.points, r->points) << row.knob << "=" << row.value;
    EXPECT_NEAR(e.rel, row.rel_error, 1e-9) << row.knob << "=" << row.value;
    EXPECT_NEAR(e.bias, row.bias, 1e-9) << row.knob << "=" << row.value;
  }
}

TEST(AccuracyCategories, TheTestBoxHasWallAndDynamicPoints) {
  auto world = worlds::loadWorld(std::string(DRTV_SOURCE_DIR) + "/worlds/fc3_testbox.json");
  ASSERT_TRUE(world.has_value()) << world.error().message;
  const AccuracyOptions o = smallSweep(9.0, 60, {"drtv"});
  auto r = measureAccuracy(*world, "testbox", o);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  size_t sum = 0;
  for (size_t n : r->category_points) sum += n;
  EXPECT_EQ(sum, r->points);
  EXPECT_GT(r->category_points[kWallOrFacade], 0u);
  EXPECT_EQ(r->category_points[kOnDynamic], r->dynamic_points);
  EXPECT_GT(r->category_points[kOpenGround], 0u);
}

// --stratify: on the facade scene (a 15 m building with balconies) the walls and the space under
// the balconies get as many points as the open ground that takes 90 % of them otherwise; a
// category with too few candidates (under the balconies) gives its share to the others.
TEST(AccuracyCategories, StratifiedPointsGiveEachCategoryAnEqualShare) {
  auto world = worlds::loadWorld(std::string(DRTV_SOURCE_DIR) + "/tests/reference/data/facade.json");
  ASSERT_TRUE(world.has_value()) << world.error().message;
  AccuracyOptions o = smallSweep(9.0, 60, {"drtv"});
  o.stratify = true;
  auto r = measureAccuracy(*world, "facade", o);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  EXPECT_TRUE(r->stratified);
  EXPECT_EQ(r->points, 60u);
  const size_t open = r->category_points[kOpenGround], wall = r->category_points[kWallOrFacade], enclosed = r->category_points[kEnclosed];
  EXPECT_EQ(open + wall + enclosed, r->points);
  EXPECT_GT(enclosed, 0u);
  EXPECT_LE(enclosed, wall);
  EXPECT_LE(wall > open ? wall - open : open - wall, 1u) << open << " open, " << wall << " wall";
  EXPECT_GE(3 * wall, r->points) << "walls are 7 % of the unstratified points; a third or more here";
}

}  // namespace
}  // namespace drtv::eval

namespace drtv::eval {
namespace {

// The accuracy samples no point that no camera sees: a dynamic sphere wholly inside the Cornell
// box's short block, whose material is double-sided (so no ray meets a back face there), gets no
// sample point; the same sphere beside the block gets its share.
TEST(AccuracyCategories, NoPointIsSampledOnADynamicObjectInsideADoubleSidedSolid) {
  auto dynamicPointsWithSphereAt = [](const char* at) -> size_t {
    const std::filesystem::path file = std::filesystem::temp_directory_path() / "drtv-buried-sphere.json";
    std::ofstream(file) << R"({"name": "buried", "gltf": [{"path": ")" << DRTV_TEST_ASSETS
                        << R"(/cornell_bevy/CornellBox.glb", "class": "static", "scale": 0.02, "translation": [5.56, -5.59, 0]}],
      "primitives": [{"name": "ground", "shape": "plane", "class": "terrain", "translation": [0, 0, -0.01], "scale": [60, 60, 1]},
                     {"name": "sphere", "shape": "sphere", "class": "dynamic", "translation": [)"
                        << at << R"(], "scale": 1.2}]})";
    auto world = worlds::loadWorld(file.string());
    EXPECT_TRUE(world.has_value()) << world.error().message;
    if (!world) return 0;
    auto r = measureAccuracy(*world, "buried", smallSweep(12.0, 40, {"drtv"}));
    EXPECT_TRUE(r.has_value()) << r.error().message;
    return r ? r->dynamic_points : 0;
  };
  // The short block: centre (1.86, -2.21), about 4.1 m wide and 3.3 m tall, turned ~17 degrees.
  EXPECT_EQ(dynamicPointsWithSphereAt("1.86, -2.21, 1.65"), 0u);
  EXPECT_GT(dynamicPointsWithSphereAt("-3, -4, 1.5"), 0u);
}

}  // namespace
}  // namespace drtv::eval
