// The drtv program on an archive's URL (docs/streamer.md, "Serving an archive over HTTP"),
// served by a real nginx the test starts on a free loopback port and stops by its PID. A file of
// its own: nginx_server.h brings namespace drtv, which the `drtv()` runner of cli_test.cpp would
// collide with.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "nginx_server.h"

namespace {

struct Outcome {
  int status = -1;
  std::string out;  // stdout, then stderr with each line prefixed "E:"
};

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs drtv with `args` (as cli_test.cpp's runner does).
Outcome run(const std::string& args) {
  const std::string stem = ::testing::TempDir() + "drtv_cli_http_" + std::to_string(::getpid());
  const std::string out = stem + "_out.txt", err = stem + "_err.txt";
  const std::string cmd = std::string("'") + DRTV_EXE + "' " + args + " >'" + out + "' 2>'" + err + "'";
  Outcome r;
  const int st = std::system(cmd.c_str());
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  r.out = slurp(out);
  std::istringstream e(slurp(err));
  for (std::string line; std::getline(e, line);) r.out += "E:" + line + "\n";
  std::remove(out.c_str());
  std::remove(err.c_str());
  return r;
}

std::string src(const std::string& rel) { return std::string(DRTV_SOURCE_DIR) + "/" + rel; }

// The first `fields` comma-separated fields of each line: frames.csv without its timings.
std::string csvFields(const std::string& text, int fields) {
  std::istringstream in(text);
  std::string line, out;
  while (std::getline(in, line)) {
    size_t at = 0;
    for (int i = 0; i < fields && at != std::string::npos; ++i) at = line.find(',', at + (i ? 1 : 0));
    out += line.substr(0, at) + "\n";
  }
  return out;
}

// An archive's URL in place of its path: the same info, the same ambient, the same flight (all
// of frames.csv but its timings), and a missing URL is an error naming it.
TEST(Cli, InfoQueryAndFlyOnAnArchivesUrlPrintWhatTheyPrintForTheFile) {
  const std::filesystem::path dir = ::testing::TempDir() + "drtv_cli_http_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir / "www");
  const std::string file = (dir / "www" / "box.drtv").string();
  ASSERT_EQ(run("bake " + src("worlds/fc3_testbox.json") + " -o " + file + " --quality draft").status, 0);
  drtv::testing::NginxServer nginx(dir / "nginx", dir / "www", "");
  auto started = nginx.start();
  ASSERT_TRUE(started.has_value()) << started.error().message;
  const std::string url = nginx.url("/box.drtv");

  const Outcome info_file = run("info " + file), info_url = run("info " + url);
  ASSERT_EQ(info_url.status, 0) << info_url.out;
  EXPECT_EQ(info_url.out.substr(info_url.out.find('\n')), info_file.out.substr(info_file.out.find('\n')));
  EXPECT_EQ(info_url.out.rfind("archive: " + url + " (version", 0), 0u) << info_url.out;

  const std::string at = " --at 0,0,23.5 --normal 0,0,1 --time 10:00";
  const Outcome query_file = run("query " + file + at), query_url = run("query " + url + at);
  ASSERT_EQ(query_url.status, 0) << query_url.out;
  EXPECT_EQ(query_url.out, query_file.out);

  const std::string fly = " --frames 120 -o ";
  ASSERT_EQ(run("fly " + file + fly + (dir / "fly-file").string()).status, 0);
  const Outcome fly_url = run("fly " + url + fly + (dir / "fly-url").string());
  ASSERT_EQ(fly_url.status, 0) << fly_url.out;
  EXPECT_NE(fly_url.out.find("http: "), std::string::npos) << fly_url.out;
  // frame .. fallback, resident and reserved bytes: 17 fields; the timings follow.
  const std::string csv_file = csvFields(slurp((dir / "fly-file" / "frames.csv").string()), 17);
  EXPECT_GT(csv_file.size(), 120u * 20u);
  EXPECT_EQ(csvFields(slurp((dir / "fly-url" / "frames.csv").string()), 17), csv_file);

  const Outcome missing = run("info " + nginx.url("/nope.drtv"));
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.out.find("E:drtv: error: " + nginx.url("/nope.drtv") + ": the header: bytes 0-63: HTTP 404"), std::string::npos)
      << missing.out;
  nginx.stop();
  std::filesystem::remove_all(dir);
}
}  // namespace
