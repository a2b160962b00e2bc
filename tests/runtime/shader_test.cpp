// The GLSL and HLSL versions of ambient() compile as the fragment shaders an engine uses
// (glslangValidator from Debian's glslang-tools, to SPIR-V; HLSL through its -D front end), and
// both files carry the A1..A9 lines of the C++ version in order (docs/runtime.md). That they give
// what sampleVolume gives is shown by running them: shader_run_test.cpp.
#include <unistd.h>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace {

const std::filesystem::path kShaders = std::filesystem::path(DRTV_SOURCE_DIR) / "runtime" / "shaders";

bool haveGlslang() { return std::system("glslangValidator --version > /dev/null 2>&1") == 0; }

int compile(const std::string& args) {
  const std::filesystem::path out = std::filesystem::temp_directory_path() / ("drtv_shader_test_" + std::to_string(::getpid()) + ".spv");
  return std::system(("glslangValidator " + args + " -o " + out.string() + " > /dev/null 2>&1").c_str());
}

std::string read(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

TEST(Shaders, GlslAmbientCompilesToSpirv) {
  if (!haveGlslang()) GTEST_SKIP() << "glslangValidator not installed";
  EXPECT_EQ(compile("-V -S frag " + (kShaders / "ambient.glsl").string()), 0);
}

TEST(Shaders, HlslAmbientCompilesToSpirv) {
  if (!haveGlslang()) GTEST_SKIP() << "glslangValidator not installed";
  EXPECT_EQ(compile("-D -V -e main -S frag " + (kShaders / "ambient.hlsl").string()), 0);
}

TEST(Shaders, ShL1VariantsCompileToSpirv) {
  if (!haveGlslang()) GTEST_SKIP() << "glslangValidator not installed";
  EXPECT_EQ(compile("-V -S frag -DDRTV_SH_L1 " + (kShaders / "ambient.glsl").string()), 0);
  EXPECT_EQ(compile("-D -V -e main -S frag -DDRTV_SH_L1 " + (kShaders / "ambient.hlsl").string()), 0);
}

TEST(Shaders, BothCarryTheNumberedLinesOfTheCppVersionInOrder) {
  for (const auto& [file, wrap] : {std::pair{"ambient.glsl", "fract("}, std::pair{"ambient.hlsl", "frac("}}) {
    const std::string text = read(kShaders / file);
    size_t at = 0;
    for (int i = 1; i <= 9; ++i) {
      const size_t found = text.find("A" + std::to_string(i), at);
      ASSERT_NE(found, std::string::npos) << file << " lacks line A" << i;
      at = found;
    }
    EXPECT_NE(text.find(wrap), std::string::npos) << file << ": the wrap is the talk's frac trick";
  }
}

}  // namespace
