// A small HTTP/1.1 proxy between the source and nginx that breaks responses the way networks do:
// cut short (the connection closed halfway through the body), reset (RST halfway), stalled (the
// headers and half the body, then silence). It forwards requests and nginx's answers byte for
// byte otherwise, over kept-alive connections on both sides.
//
// Faults apply to the next `count` responses (set with fault()); the rest pass. Added latency
// (setLatency) holds every response, and every new connection before it reaches nginx, for that
// long: one round trip of a network that far away, on each connection independently, so that
// reads in flight on several connections overlap as they would over a real network. One thread
// per client connection; stop() (and the destructor) shuts every socket down and joins them all.
#pragma once

#include <atomic>
#include <chrono>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace drtv::testing {

class FaultProxy {
 public:
  enum class Mode { kPass, kCut, kReset, kStall };

  explicit FaultProxy(int upstream_port) : upstream_port_(upstream_port) {
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a = loopback(0);
    ::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a);
    socklen_t len = sizeof a;
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    ::listen(listen_fd_, 64);
    acceptor_ = std::thread([this] { acceptLoop(); });
  }
  ~FaultProxy() { stop(); }
  FaultProxy(const FaultProxy&) = delete;
  FaultProxy& operator=(const FaultProxy&) = delete;

  // The next `count` responses get `mode`.
  void fault(Mode mode, int count) {
    mode_ = mode;
    left_ = count;
  }
  int faulted() const { return faulted_; }  // responses broken so far
  // Every response (and every new connection) from now on waits this long: added round-trip time.
  void setLatency(std::chrono::microseconds latency) { latency_us_ = latency.count(); }
  int64_t delayed() const { return delayed_; }  // responses held so far
  int port() const { return port_; }
  std::string url(const std::string& path) const { return "http://127.0.0.1:" + std::to_string(port_) + path; }

  void stop() {
    if (stopping_.exchange(true)) return;
    ::shutdown(listen_fd_, SHUT_RDWR);
    acceptor_.join();
    ::close(listen_fd_);
    {
      std::lock_guard lock(mutex_);
      for (int fd : open_) ::shutdown(fd, SHUT_RDWR);
    }
    for (std::thread& t : workers_) t.join();
  }

 private:
  static sockaddr_in loopback(int port) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(uint16_t(port));
    return a;
  }
  void track(int fd) {
    std::lock_guard lock(mutex_);
    open_.push_back(fd);
  }
  void untrack(int fd) {
    std::lock_guard lock(mutex_);
    std::erase(open_, fd);
    ::close(fd);
  }
  void acceptLoop() {
    while (!stopping_) {
      const int client = ::accept(listen_fd_, nullptr, nullptr);
      if (client < 0) return;  // shut down
      track(client);
      std::lock_guard lock(mutex_);
      workers_.emplace_back([this, client] { serve(client); });
    }
  }
  static bool sendAll(int fd, const char* p, size_t n) {
    while (n > 0) {
      const ssize_t k = ::send(fd, p, n, MSG_NOSIGNAL);
      if (k <= 0) return false;
      p += k;
      n -= size_t(k);
    }
    return true;
  }
  // Reads from `fd` into `buf` until it holds "\r\n\r\n"; returns the header length or 0.
  static size_t readHead(int fd, std::string& buf) {
    char tmp[16384];
    for (;;) {
      if (const size_t at = buf.find("\r\n\r\n"); at != std::string::npos) return at + 4;
      const ssize_t k = ::recv(fd, tmp, sizeof tmp, 0);
      if (k <= 0) return 0;
      buf.append(tmp, size_t(k));
    }
  }
  static size_t contentLength(const std::string& head) {
    std::string lower(head);
    for (char& c : lower) c = char(std::tolower((unsigned char)c));
    const size_t at = lower.find("\r\ncontent-length:");
    return at == std::string::npos ? 0 : std::stoul(lower.substr(at + 17));
  }
  void wait() {
    if (const int64_t us = latency_us_; us > 0) {
      std::this_thread::sleep_for(std::chrono::microseconds(us));
      ++delayed_;
    }
  }
  void serve(int client) {
    wait();  // the connection's handshake crosses the same distance
    const int up = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a = loopback(upstream_port_);
    track(up);
    if (::connect(up, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0) relay(client, up);
    untrack(up);
    untrack(client);
  }
  void relay(int client, int up) {
    std::string in, out;
    while (!stopping_) {
      // A request (GETs only: no body), forwarded as is.
      const size_t req = readHead(client, in);
      if (req == 0 || !sendAll(up, in.data(), req)) return;
      in.erase(0, req);
      // nginx's answer: headers, then Content-Length bytes of body.
      const size_t head = readHead(up, out);
      if (head == 0) return;
      const size_t total = head + contentLength(out.substr(0, head));
      char tmp[16384];
      while (out.size() < total) {
        const ssize_t k = ::recv(up, tmp, sizeof tmp, 0);
        if (k <= 0) return;
        out.append(tmp, size_t(k));
      }
      wait();
      Mode mode = Mode::kPass;
      if (left_ > 0 && left_.fetch_sub(1) > 0) mode = mode_;
      if (mode == Mode::kPass) {
        if (!sendAll(client, out.data(), total)) return;
        out.erase(0, total);
        continue;
      }
      ++faulted_;
      const size_t half = head + (total - head) / 2;
      sendAll(client, out.data(), half);
      if (mode == Mode::kReset) {
        linger l{1, 0};  // close with RST instead of FIN
        ::setsockopt(client, SOL_SOCKET, SO_LINGER, &l, sizeof l);
      } else if (mode == Mode::kStall) {
        // Silence until the client gives up (its timeout closes the connection) or stop().
        pollfd p{client, POLLIN, 0};
        while (!stopping_ && ::poll(&p, 1, 20) == 0) {
        }
      }
      return;
    }
  }

  int upstream_port_;
  int listen_fd_ = -1, port_ = 0;
  std::atomic<Mode> mode_{Mode::kPass};
  std::atomic<int> left_{0}, faulted_{0};
  std::atomic<int64_t> latency_us_{0}, delayed_{0};
  std::atomic<bool> stopping_{false};
  std::thread acceptor_;
  std::mutex mutex_;
  std::vector<int> open_;
  std::vector<std::thread> workers_;
};

}  // namespace drtv::testing
