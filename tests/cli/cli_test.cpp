// The drtv program's contract (STYLE.md, "Command line"): --help on stdout with exit 0; an
// unknown flag named, exit 2; a failure "drtv: error: <file>: <what>", exit 1.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

namespace {

struct Outcome {
  int status = -1;
  std::string out;  // stdout and stderr, tagged
};

std::string slurp(const std::string& path) {
  std::string text;
  if (FILE* f = std::fopen(path.c_str(), "rb")) {
    std::array<char, 4096> buf;
    while (size_t n = std::fread(buf.data(), 1, buf.size(), f)) text.append(buf.data(), n);
    std::fclose(f);
  }
  return text;
}

// Runs drtv with `args`; stdout arrives as-is, each stderr line prefixed "E:".
Outcome drtv(const std::string& args) {
  // ctest runs the tests of this file in parallel processes: names unique to this test and process.
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string stem = ::testing::TempDir() + "drtv_cli_" + (info ? info->name() : "none") + "_" + std::to_string(::getpid());
  const std::string out = stem + "_out.txt", err = stem + "_err.txt";
  const std::string cmd = std::string("'") + DRTV_EXE + "' " + args + " >'" + out + "' 2>'" + err + "'";
  Outcome r;
  const int st = std::system(cmd.c_str());
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  r.out = slurp(out);
  std::string e = slurp(err);
  std::remove(out.c_str());
  std::remove(err.c_str());
  for (size_t at = 0; at < e.size();) {
    const size_t nl = e.find('\n', at);
    r.out += "E:" + e.substr(at, nl == std::string::npos ? std::string::npos : nl - at + 1);
    at = nl == std::string::npos ? e.size() : nl + 1;
  }
  return r;
}

std::string src(const std::string& rel) { return std::string(DRTV_SOURCE_DIR) + "/" + rel; }

TEST(Cli, HelpGoesToStdoutAndExitsZero) {
  const Outcome r = drtv("--help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("Subcommands:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("info"), std::string::npos);
  EXPECT_EQ(r.out.find("E:"), std::string::npos) << "help must not go to stderr";
}

TEST(Cli, SubcommandHelpExitsZero) {
  const Outcome r = drtv("info --help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("--json"), std::string::npos) << r.out;
}

TEST(Cli, UnknownFlagIsNamedAndExitsTwo) {
  const Outcome r = drtv("info " + src("worlds/fc3_testbox.json") + " --bogus-flag");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("E:"), std::string::npos);
  EXPECT_NE(r.out.find("--bogus-flag"), std::string::npos) << r.out;
}

TEST(Cli, MissingSubcommandExitsTwo) { EXPECT_EQ(drtv("").status, 2); }

TEST(Cli, MissingFileIsAnErrorNamingItAndExitsOne) {
  const Outcome r = drtv("info /nonexistent/world.json");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("E:drtv: error: /nonexistent/world.json: "), std::string::npos) << r.out;
}

TEST(Cli, InfoDescribesTheTestBox) {
  const Outcome r = drtv("info " + src("worlds/fc3_testbox.json") + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("\"kind\": \"world\""), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"dynamic\""), std::string::npos);
}

TEST(Cli, InfoDescribesAnArchive) {
  const Outcome r = drtv("info " + src("tests/formats/data/golden_v1.drtv"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("sectors: 1 of 64 m (1 with LPRT)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("probes: 2"), std::string::npos) << r.out;
}

TEST(Cli, ACorruptArchiveIsAnErrorNamingTheFileAndOffset) {
  const std::string bad = ::testing::TempDir() + "corrupt.drtv";
  std::string cmd = "head -c 100 '" + src("tests/formats/data/golden_v1.drtv") + "' > '" + bad + "'";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const Outcome r = drtv("info " + bad);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("E:drtv: error: " + bad + ": byte 40: "), std::string::npos) << r.out;
}

// The project's own lit world (a glTF Cornell box on a ground plane with a lamp): it bakes LPRT
// through the CLI, and 1 thread, 2 threads and 2 shards merged write the same bytes.
TEST(Cli, ALitGltfWorldBakesAndEveryWayOfBakingItAgrees) {
  const std::string dir = ::testing::TempDir() + "drtv_cli_lit_" + std::to_string(::getpid());
  const std::string world = src("tests/reference/data/cornell_world.json");
  ASSERT_EQ(std::system(("rm -rf '" + dir + "' && mkdir -p '" + dir + "'").c_str()), 0);
  for (const char* t : {"1", "2"}) {
    const Outcome r = drtv("bake " + world + " -o " + dir + "/t" + t + ".drtv --quality draft --threads " + t);
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("sectors"), std::string::npos) << r.out;
  }
  for (const char* k : {"0/2", "1/2"}) {
    const Outcome r = drtv("bake " + world + " -o " + dir + "/m.drtv --quality draft --shard " + k);
    ASSERT_EQ(r.status, 0) << r.out;
  }
  const Outcome m = drtv("bake " + world + " -o " + dir + "/m.drtv --quality draft --merge");
  ASSERT_EQ(m.status, 0) << m.out;
  const std::string one = slurp(dir + "/t1.drtv");
  EXPECT_GT(one.size(), 1000u);
  EXPECT_EQ(one, slurp(dir + "/t2.drtv"));
  EXPECT_EQ(one, slurp(dir + "/m.drtv"));
  const Outcome info = drtv("info " + dir + "/t1.drtv");
  ASSERT_EQ(info.status, 0) << info.out;
  EXPECT_NE(info.out.find("with LPRT"), std::string::npos) << info.out;
  std::system(("rm -rf '" + dir + "'").c_str());
}

}  // namespace
