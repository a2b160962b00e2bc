// What each sector costs to bake (sector_costs.h): the triangles' estimate, an earlier bake's
// measured times sector by sector for the same world, only its rate for another, and a report
// that cannot be read named with what is wrong.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "drtv/baker/bake.h"
#include "drtv/baker/sector_costs.h"
#include "drtv/baker/shard.h"
#include "drtv/raytrace/world_geometry.h"
#include "test_worlds.h"

namespace drtv::baker {
namespace {
namespace fs = std::filesystem;

std::string hex16(uint64_t v) {
  char text[32];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(v));
  return text;
}

fs::path writeReport(const std::string& name, const nlohmann::json& j) {
  const fs::path p = fs::path(::testing::TempDir()) / ("drtv_sector_costs_" + name + ".json");
  std::ofstream(p) << j.dump();
  return p;
}

// A report as `drtv bake` writes it, for `keys`, each with `seconds(i)` and `triangles(i)`.
template <class Seconds, class Triangles>
nlohmann::json report(const std::string& geometry, const std::vector<SectorKey>& keys, Seconds seconds, Triangles triangles) {
  nlohmann::json j = {{"world", "test"}, {"threads", 2}, {"geometry_fingerprint", geometry}};
  nlohmann::json per = nlohmann::json::array();
  for (size_t i = 0; i < keys.size(); ++i)
    per.push_back({{"ix", keys[i].ix}, {"iy", keys[i].iy}, {"triangles", triangles(i)}, {"total_s", seconds(i)}, {"probes", 3}});
  j["per_sector"] = per;
  return j;
}

// A 400 m plane with a few boxes on it, so that sectors gather unlike counts of triangles.
struct Fixture {
  raytrace::WorldGeometry geometry;
  std::vector<SectorKey> keys;
  static Fixture make() {
    worlds::World w = test::planeWorld(200.0, glm::vec3(0.5f));
    for (int i = 0; i < 5; ++i)
      test::add(w, test::box({-150.f + 60.f * i, 10.f, 0.f}, {-140.f + 60.f * i, 20.f, 5.f}, glm::vec3(0.5f)), worlds::InstanceClass::kStatic);
    auto g = raytrace::WorldGeometry::build(w, "plane");
    EXPECT_TRUE(g);
    Fixture f{std::move(*g), {}};
    f.keys = bakeKeys(f.geometry.sectors());
    return f;
  }
};

TEST(SectorCosts, WithoutAReportASectorCostsItsTrianglesAndNoTimeIsPredicted) {
  const Fixture f = Fixture::make();
  ASSERT_GE(f.keys.size(), 16u);
  const SectorCosts c = sectorCosts(f.geometry, f.keys, 64.0);
  ASSERT_EQ(c.units.size(), f.keys.size());
  for (size_t i = 0; i < f.keys.size(); ++i) EXPECT_EQ(c.units[i], 1 + f.geometry.gatherEstimate(f.keys[i], 64.0)) << i;
  EXPECT_EQ(c.split, "estimated");
  EXPECT_EQ(c.seconds_per_unit, 0.0);
  EXPECT_EQ(c.measured, 0u);
}

TEST(SectorCosts, ASlowSectorOfThisWorldMeasuredSoGetsAShardToItselfAndTheRestFollowTheFittedRate) {
  const Fixture f = Fixture::make();
  const SectorCosts est = sectorCosts(f.geometry, f.keys, 64.0);
  // Every sector but the last measured; sector 5 took 100x the others (a lamp's LPRT, say),
  // which its triangles do not show.
  std::vector<SectorKey> measured_keys(f.keys.begin(), f.keys.end() - 1);
  const auto seconds = [&](size_t i) { return i == 5 ? 5.0 : 0.05; };
  const auto triangles = [&](size_t i) { return est.units[i] - 1; };
  const fs::path p = writeReport("same", report(hex16(f.geometry.fingerprint()), measured_keys, seconds, triangles));
  auto m = readMeasuredCosts(p);
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_EQ(m->seconds.size(), measured_keys.size());
  EXPECT_EQ(m->threads, 2);
  double sum_s = 0, sum_units = 0;
  for (size_t i = 0; i < measured_keys.size(); ++i) sum_s += seconds(i), sum_units += double(est.units[i]);
  EXPECT_NEAR(m->seconds_per_unit, sum_s / sum_units, 1e-12);

  const SectorCosts c = sectorCosts(f.geometry, f.keys, 64.0, &*m);
  EXPECT_EQ(c.split, "measured " + m->digest);
  EXPECT_EQ(c.measured, measured_keys.size());
  EXPECT_EQ(c.units[5], 5'000'000u) << "microseconds";
  EXPECT_EQ(c.units[0], 50'000u);
  EXPECT_NEAR(double(c.units.back()), double(est.units.back()) * m->seconds_per_unit * 1e6, 1.0) << "unmeasured: the rate";
  EXPECT_DOUBLE_EQ(c.seconds_per_unit, 1e-6);
  // Split 4 ways: the slow sector alone on its shard; by triangles it would share one.
  const std::vector<int> owner = shardOwners(c.units, 4);
  EXPECT_EQ(std::count(owner.begin(), owner.end(), owner[5]), 1);
  const std::vector<int> by_triangles = shardOwners(est.units, 4);
  EXPECT_GT(std::count(by_triangles.begin(), by_triangles.end(), by_triangles[5]), 1);
  // The same report gives the same split in every process.
  auto again = readMeasuredCosts(p);
  ASSERT_TRUE(again);
  EXPECT_EQ(sectorCosts(f.geometry, f.keys, 64.0, &*again).units, c.units);
  EXPECT_EQ(again->digest, m->digest);
}

TEST(SectorCosts, AReportOfAnotherWorldOnlyPredictsTheTimesAndTheSplitStaysTheTriangles) {
  const Fixture f = Fixture::make();
  const SectorCosts est = sectorCosts(f.geometry, f.keys, 64.0);
  const fs::path p = writeReport("other", report("0123456789abcdef", {{0, 0}, {1, 0}}, [](size_t i) { return i ? 3.0 : 1.0; },
                                                 [](size_t) { return 999; }));
  auto m = readMeasuredCosts(p);
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_DOUBLE_EQ(m->seconds_per_unit, 4.0 / 2000.0);
  const SectorCosts c = sectorCosts(f.geometry, f.keys, 64.0, &*m);
  EXPECT_EQ(c.units, est.units);
  EXPECT_EQ(c.split, "estimated");
  EXPECT_EQ(c.measured, 0u);
  EXPECT_DOUBLE_EQ(c.seconds_per_unit, 4.0 / 2000.0);
}

TEST(SectorCosts, AReportThatCannotBeReadIsAnErrorNamingTheFileAndWhatIsWrong) {
  const std::string fp = "0123456789abcdef";
  const auto one = [](size_t) { return 1.0; };
  const auto tri = [](size_t) { return 10; };
  struct Case {
    std::string name;
    nlohmann::json j;
    std::string says;
  } cases[] = {
      {"array", nlohmann::json::array(), "not a bake report"},
      {"nofp", [&] { auto j = report(fp, {{0, 0}}, one, tri); j.erase("geometry_fingerprint"); return j; }(), "geometry_fingerprint"},
      {"negative", report(fp, {{0, 0}}, [](size_t) { return -1.0; }, tri), "per_sector[0]: \"total_s\" must be"},
      {"huge", report(fp, {{0, 0}}, [](size_t) { return 1e300; }, tri), "per_sector[0]: \"total_s\" must be a number of seconds from 0 to 1e9"},
      {"zero", report(fp, {{0, 0}, {1, 0}}, [](size_t) { return 0.0; }, tri), "no sector has a bake time above 0"},
      {"twice", report(fp, {{0, 0}, {0, 0}}, one, tri), "per_sector[1]: sector (0,0) is listed twice"},
      {"nokey", [&] { auto j = report(fp, {{0, 0}}, one, tri); j["per_sector"][0].erase("iy"); return j; }(), "per_sector[0]: needs"},
  };
  for (const Case& c : cases) {
    const fs::path p = writeReport("bad_" + c.name, c.j);
    auto m = readMeasuredCosts(p);
    ASSERT_FALSE(m) << c.name;
    EXPECT_NE(m.error().message.find(p.string() + ": "), std::string::npos) << m.error().message;
    EXPECT_NE(m.error().message.find(c.says), std::string::npos) << c.name << ": " << m.error().message;
  }
  const fs::path text = fs::path(::testing::TempDir()) / "drtv_sector_costs_text.json";
  std::ofstream(text) << "{ not json";
  auto m = readMeasuredCosts(text);
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("not JSON"), std::string::npos) << m.error().message;
  EXPECT_FALSE(readMeasuredCosts(fs::path(::testing::TempDir()) / "drtv_no_such_report.json"));
}

}  // namespace
}  // namespace drtv::baker
