// A real nginx (Debian's nginx-light), started by a test or a benchmark on a free loopback port with its
// configuration, logs, pid and temp files in a folder of its own, and stopped by its PID. No
// mocks: the HTTP source is tested against the server that would serve it in production.
//
// nginx runs in the foreground as one process (`daemon off; master_process off;`), a child of the
// test: stop() sends SIGTERM to that PID and reaps it, so nothing is left running when the test
// ends. Not finding nginx is a failure, not a skip: scripts/bootstrap installs it.
#pragma once

#include <csignal>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include "drtv/formats/error.h"

namespace drtv::testing {

class NginxServer {
 public:
  // `root`: the folder served at "/"; `locations`: extra nginx `location` blocks (faults).
  // Its own files go to `dir` (created).
  NginxServer(std::filesystem::path dir, std::filesystem::path root, std::string locations)
      : dir_(std::move(dir)), root_(std::move(root)), locations_(std::move(locations)) {
    std::filesystem::create_directories(dir_);
    // libcurl honours http_proxy: requests to this server must not go through a proxy that the
    // environment (a CI runner's) names.
    ::setenv("no_proxy", "127.0.0.1,localhost", 1);
  }
  ~NginxServer() { stop(); }
  NginxServer(const NginxServer&) = delete;
  NginxServer& operator=(const NginxServer&) = delete;

  // The nginx binary: $DRTV_NGINX, else /usr/sbin/nginx, else nginx on PATH; nullopt if none.
  static std::optional<std::string> binary() {
    if (const char* env = std::getenv("DRTV_NGINX"); env && *env) return std::string(env);
    if (::access("/usr/sbin/nginx", X_OK) == 0) return std::string("/usr/sbin/nginx");
    if (std::system("command -v nginx >/dev/null 2>&1") == 0) return std::string("nginx");
    return std::nullopt;
  }

  // Starts nginx (on a free port the first time, on the same port after a stop) and returns when
  // it accepts connections. Error: nginx missing, or its error log if it did not come up.
  Result<void> start() {
    if (port_ != 0) return startOn(port_);
    // ctest runs tests in parallel processes: another may take the free port before nginx binds
    // it. Then nginx says so and exits, and another free port is tried.
    Result<void> started;
    for (int attempt = 0; attempt < 5; ++attempt) {
      started = startOn(freePort());
      if (started || errorLog().find("Address already in use") == std::string::npos) break;
    }
    return started;
  }

 private:
  Result<void> startOn(int port) {
    port_ = port;
    auto bin = binary();
    if (!bin)
      return fail("nginx not found (not in /usr/sbin, not on PATH, DRTV_NGINX unset): install it with scripts/bootstrap "
                  "(Debian package nginx-light); these tests need a real web server");
    writeConfig();
    const std::string prefix = dir_.string() + "/", conf = (dir_ / "nginx.conf").string(), err = (dir_ / "error.log").string();
    pid_ = ::fork();
    if (pid_ == 0) {
      ::execlp(bin->c_str(), bin->c_str(), "-p", prefix.c_str(), "-c", conf.c_str(), "-e", err.c_str(), (char*)nullptr);
      ::_exit(127);
    }
    if (pid_ < 0) return fail("fork: cannot start nginx");
    // Up within 10 s on any machine; a readiness bound, not a timed assertion.
    for (int i = 0; i < 1000; ++i) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        if (WIFEXITED(status) && WEXITSTATUS(status) == 127) return fail(*bin + ": cannot be run (missing or not executable)");
        return fail("nginx exited at start (status " + std::to_string(status) + "): " + errorLog());
      }
      if (accepts()) return {};
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    stop();
    return fail("nginx did not accept connections on port " + std::to_string(port_) + " within 10 s: " + errorLog());
  }


 public:
  // SIGTERM (nginx's fast shutdown) to our child, and reap it. Idempotent.
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }

  bool running() const { return pid_ > 0; }
  int port() const { return port_; }
  // "http://127.0.0.1:<port><path>"
  std::string url(const std::string& path) const { return "http://127.0.0.1:" + std::to_string(port_) + path; }
  std::string errorLog() const { return slurp(dir_ / "error.log"); }
  std::string accessLog() const { return slurp(dir_ / "access.log"); }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  static std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  // A port the kernel says is free now (bound to 0, read back, released).
  static int freePort() {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = 0;
    ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    socklen_t len = sizeof a;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    ::close(fd);
    return ntohs(a.sin_port);
  }
  bool accepts() const {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(uint16_t(port_));
    const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    ::close(fd);
    return ok;
  }
  void writeConfig() const {
    const std::string d = dir_.string();
    std::ofstream c(dir_ / "nginx.conf");
    c << "daemon off;\nmaster_process off;\nworker_processes 1;\n"
      << "pid " << d << "/nginx.pid;\nerror_log " << d << "/error.log info;\n"
      << "events { worker_connections 256; }\n"
      << "http {\n"
      << "  access_log " << d << "/access.log;\n"
      << "  client_body_temp_path " << d << "/body;\n  proxy_temp_path " << d << "/proxy;\n"
      << "  fastcgi_temp_path " << d << "/fastcgi;\n  uwsgi_temp_path " << d << "/uwsgi;\n  scgi_temp_path " << d << "/scgi;\n"
      << "  default_type application/octet-stream;\n  keepalive_requests 100000;\n  keepalive_timeout 60s;\n"
      << "  server {\n    listen 127.0.0.1:" << port_ << ";\n    root " << root_.string() << ";\n"
      << locations_ << "\n  }\n}\n";
  }

  std::filesystem::path dir_, root_;
  std::string locations_;
  int port_ = 0;
  pid_t pid_ = -1;
};

}  // namespace drtv::testing
