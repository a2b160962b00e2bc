#include <unistd.h>
#include <filesystem>

#include <gtest/gtest.h>

#include "drtv/worlds/load.h"
#include "drtv/eval/topdown.h"

namespace drtv::eval {
using namespace worlds;
using image::RgbImage;
namespace {

TEST(TopDown, DrawsTheTestBoxWallsInTheirColoursWhereTheyStand) {
  auto world = loadWorld(std::string(DRTV_SOURCE_DIR) + "/worlds/fc3_testbox.json");
  ASSERT_TRUE(world.has_value()) << world.error().message;
  TopDownOptions o;
  o.max_size_px = 384;
  o.sector_grid = false;
  const RgbImage img = renderTopDown(*world, o);
  ASSERT_EQ(img.width, 384);
  ASSERT_EQ(img.height, 384);
  // The world spans x, y in [-48, 48]: 4 px per metre. The red wall stands at x = -12.5, the
  // blue one at x = +12.5, both centred on y = 0 (the image's middle row).
  auto px = [&](double x, double y) {
    const int ix = int((x + 48) * 4), iy = int((48 - y) * 4);
    const uint8_t* p = &img.pixels[(size_t(iy) * img.width + ix) * 3];
    return glm::ivec3(p[0], p[1], p[2]);
  };
  const glm::ivec3 red = px(-12.5, 0.3), blue = px(12.5, 0.3), grass = px(30, 30);
  EXPECT_GT(red.r, 2 * red.g) << red.r << "," << red.g << "," << red.b;
  EXPECT_GT(blue.b, 2 * blue.r);
  EXPECT_GT(grass.g, grass.r);
  EXPECT_GT(grass.g, grass.b);
}

TEST(TopDown, WritesAPngAndNamesAnUnwritablePath) {
  World empty;
  const RgbImage img = renderTopDown(empty);
  EXPECT_EQ(img.width, 1);
  const std::filesystem::path out = std::filesystem::path(::testing::TempDir()) / ("drtv_topdown_test_" + std::to_string(::getpid()) + ".png");
  ASSERT_TRUE(writePng(out, img).has_value());
  EXPECT_GT(std::filesystem::file_size(out), 8u);
  auto bad = writePng("/nonexistent/dir/x.png", img);
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("/nonexistent/dir/x.png"), std::string::npos);
}

}  // namespace
}  // namespace drtv::eval
