// The HTTP sector source against a real nginx: the same sectors and the same flight as from the
// file, and the faults a web server really produces (503 then recovery, 404, a 200 that ignores
// Range, a rate limit past the timeout, a corrupt copy, the server stopped and restarted
// mid-flight; and through a proxy, answers cut short, reset or stalled). The flight goes on through each, counts its misses and failures, and never makes
// resident a sector that failed its checks.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "drtv/netsource/http_source.h"
#include "drtv/streamer/streamer.h"
#include "fault_proxy.h"
#include "nginx_server.h"
#include "streamer_world.h"

namespace drtv::netsource {
namespace {

constexpr double kFrameS = 1.0 / 60.0;
constexpr SectorKey kBad{7, 7};  // in the middle of the footprint of a camera at (512, 512)

// The locations that make nginx misbehave, one per fault. Each serves the same folders as "/"
// (root is inherited), so /<fault>/world.drtv is the world archive under that fault. A flag file
// in the server's folder switches the 503 and the 404 on and off while nginx runs.
std::string faultLocations(const std::filesystem::path& flags) {
  const std::string f = flags.string();
  return "    location /flaky/ { if (-f " + f + "/down) { return 503; } }\n"
         "    location /gone/ { if (-f " + f + "/gone) { return 404; } }\n"
         "    location /norange/ { max_ranges 0; }\n"
         "    location /slow/ { if (-f " + f + "/slow) { set $limit_rate 1k; } }\n";
}

class HttpSourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto root = dir_.path() / "www";
    for (const char* sub : {"ok", "flaky", "gone", "norange", "slow", "corrupt"}) std::filesystem::create_directories(root / sub);
    file_ = root / "ok" / "world.drtv";
    manifest_ = testing::writeWorld(file_, {});
    for (const char* sub : {"flaky", "gone", "norange", "slow", "corrupt"}) std::filesystem::copy_file(file_, root / sub / "world.drtv");
    // The corrupt copy: one byte flipped in the middle of kBad's payload (bit rot on the server).
    const SectorEntry* bad = manifest_.find(kBad);
    ASSERT_NE(bad, nullptr);
    {
      std::fstream f(root / "corrupt" / "world.drtv", std::ios::in | std::ios::out | std::ios::binary);
      f.seekg(std::streamoff(bad->offset + bad->compressed_bytes / 2));
      char c = 0;
      f.read(&c, 1);
      c = char(c ^ 0x10);
      f.seekp(std::streamoff(bad->offset + bad->compressed_bytes / 2));
      f.write(&c, 1);
    }
    nginx_ = std::make_unique<testing::NginxServer>(dir_.path() / "nginx", root, faultLocations(dir_.path()));
    auto started = nginx_->start();
    ASSERT_TRUE(started.has_value()) << started.error().message;
  }
  void TearDown() override { nginx_.reset(); }  // stops nginx by its PID before the folder goes

  // Options for tests: quick retries, short timeouts (loopback answers in microseconds).
  static HttpOptions quick() {
    HttpOptions o;
    o.connect_timeout_ms = 1000;
    o.request_timeout_ms = 1000;
    o.max_attempts = 3;
    o.retry_initial_ms = 5;
    o.retry_max_ms = 20;
    return o;
  }
  std::shared_ptr<HttpSectorSource> openHttp(const std::string& path, HttpOptions o = quick()) {
    auto s = HttpSectorSource::open(nginx_->url(path), o);
    EXPECT_TRUE(s.has_value()) << s.error().message;
    return s ? std::shared_ptr<HttpSectorSource>(std::move(*s)) : nullptr;
  }
  // What a streamer reading the file holds once settled at `cam`: the set a recovered flight
  // must come back to.
  std::vector<SectorKey> settledFromFile(const streamer::Camera& cam) {
    auto file = streamer::FileSectorSource::open(file_);
    EXPECT_TRUE(file.has_value());
    streamer::StreamerOptions o;
    o.io_mode = streamer::IoMode::kDeterministic;
    streamer::Streamer s(manifest_, std::shared_ptr<streamer::SectorSource>(std::move(*file)), o);
    testing::CheckingSink sink;
    for (int i = 0; i < 120; ++i) s.update(cam, i / 60.0, sink);
    EXPECT_TRUE(s.idle());
    return s.residentKeys();
  }
  void touch(const char* flag) { std::ofstream(dir_.path() / flag) << "1"; }
  void untouch(const char* flag) { std::filesystem::remove(dir_.path() / flag); }

  testing::TempDir dir_;
  std::filesystem::path file_;
  Manifest manifest_;
  std::unique_ptr<testing::NginxServer> nginx_;
};

streamer::StreamerOptions deterministic() {
  streamer::StreamerOptions o;
  o.io_mode = streamer::IoMode::kDeterministic;
  return o;
}

// The camera of a flight across the 1 km world: diagonal, 100 m/s, 10 s at 60 Hz.
streamer::Camera flightCamera(int frame) {
  const double t = frame * kFrameS;
  return {{60.0 + 70.0 * t, 60.0 + 70.0 * t, 40.0}, {0, 0, 0}};
}

TEST_F(HttpSourceTest, OpensTheSameManifestAsTheFileAndReadsTheSameBytes) {
  auto http = openHttp("/ok/world.drtv");
  ASSERT_NE(http, nullptr);
  auto file = streamer::FileSectorSource::open(file_);
  ASSERT_TRUE(file.has_value());
  const Manifest& m = http->manifest();
  ASSERT_EQ(m.sectors.size(), manifest_.sectors.size());
  EXPECT_EQ(m.version, manifest_.version);
  EXPECT_EQ(m.effects, manifest_.effects);
  for (size_t i = 0; i < m.sectors.size(); ++i) {
    const SectorEntry &a = m.sectors[i], &b = manifest_.sectors[i];
    ASSERT_EQ(a.key, b.key);
    ASSERT_EQ(a.offset, b.offset);
    ASSERT_EQ(a.compressed_bytes, b.compressed_bytes);
    ASSERT_EQ(a.hash, b.hash);
    auto over_http = http->read(a);
    auto from_file = (*file)->read(b);
    ASSERT_TRUE(over_http.has_value()) << over_http.error().message;
    ASSERT_TRUE(from_file.has_value());
    ASSERT_EQ(*over_http, *from_file) << toString(a.key);
  }
  EXPECT_EQ(http->stats().retries, 0u);
  EXPECT_EQ(http->stats().failures, 0u);
  // Read one after another, every request went over the one kept-alive connection open() made.
  EXPECT_EQ(http->stats().requests, m.sectors.size() + 2);
  EXPECT_EQ(http->stats().connections, 1u);
}

TEST_F(HttpSourceTest, AFlightOverHttpLoadsTheSameSectorsInTheSameFramesAsFromTheFile) {
  auto http = openHttp("/ok/world.drtv");
  ASSERT_NE(http, nullptr);
  auto file = streamer::FileSectorSource::open(file_);
  ASSERT_TRUE(file.has_value());
  streamer::Streamer from_file(manifest_, std::shared_ptr<streamer::SectorSource>(std::move(*file)), deterministic());
  streamer::Streamer over_http(http->manifest(), http, deterministic());
  testing::CheckingSink file_sink, http_sink;
  int loads = 0;
  for (int frame = 0; frame < 600; ++frame) {
    const streamer::FrameStats a = from_file.update(flightCamera(frame), frame * kFrameS, file_sink);
    const streamer::FrameStats b = over_http.update(flightCamera(frame), frame * kFrameS, http_sink);
    ASSERT_EQ(a.loads, b.loads) << "frame " << frame;
    ASSERT_EQ(a.evictions, b.evictions) << "frame " << frame;
    ASSERT_EQ(a.misses, b.misses) << "frame " << frame;
    ASSERT_EQ(b.failures, 0) << "frame " << frame;
    ASSERT_EQ(from_file.residentKeys(), over_http.residentKeys()) << "frame " << frame;
    loads += b.loads;
  }
  EXPECT_GT(loads, 51);  // the flight crossed sectors: more loads than one resident set
  for (SectorKey key : over_http.residentKeys())
    ASSERT_EQ(encodeSector(*over_http.resident(key)), encodeSector(*from_file.resident(key))) << toString(key);
  EXPECT_EQ(http->stats().failures, 0u);
}

// Eight I/O threads, eight reads in flight at once over the pool's connections: the streamer
// settles on the sectors the file gives, each checked, over at most eight connections.
TEST_F(HttpSourceTest, EightIoThreadsReadAtOnceOverAtMostEightConnections) {
  HttpOptions o = quick();
  o.max_connections = 8;
  auto http = openHttp("/ok/world.drtv", o);
  ASSERT_NE(http, nullptr);
  streamer::StreamerOptions so;
  so.io_mode = streamer::IoMode::kThreads;
  so.io_threads = 8;
  so.max_in_flight = 16;
  streamer::Streamer s(http->manifest(), http, so);
  testing::CheckingSink sink;
  const streamer::Camera cam{{512, 512, 40}, {0, 0, 0}};
  // Until every wanted sector is resident; a bound for a loaded machine, not a timed assertion.
  streamer::FrameStats st;
  double t = 0;
  for (int i = 0; i < 20000; ++i, t += kFrameS) {
    st = s.update(cam, t, sink);
    if (st.resident == st.wanted && s.idle()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(st.resident, st.wanted);
  EXPECT_EQ(sink.failures, 0) << sink.last_error;
  EXPECT_EQ(s.residentKeys(), settledFromFile(cam));
  for (SectorKey key : s.residentKeys()) {
    auto from_file = ArchiveReader::open(file_)->readSector(key);
    ASSERT_EQ(encodeSector(*s.resident(key)), encodeSector(*from_file)) << toString(key);
  }
  EXPECT_LE(http->stats().connections, 8u);
  EXPECT_EQ(http->stats().requests, 2 + uint64_t(sink.loads));
}

// A server 100 ms away (the proxy holds every answer that long): the streamer, on I/O threads
// and a real clock, measures each load at no less than that, and its residency then looks at
// least twice that far ahead. The bytes are the file's.
TEST_F(HttpSourceTest, AServerFarAwayIsMeasuredAndTheResidencyLooksFurtherAhead) {
  testing::FaultProxy proxy(nginx_->port());
  proxy.setLatency(std::chrono::milliseconds(100));
  auto opened = HttpSectorSource::open(proxy.url("/ok/world.drtv"), quick());
  ASSERT_TRUE(opened.has_value()) << opened.error().message;
  std::shared_ptr<HttpSectorSource> http(std::move(*opened));
  streamer::StreamerOptions so;
  so.io_mode = streamer::IoMode::kThreads;
  so.io_threads = 8;
  so.max_in_flight = 16;
  streamer::Streamer s(http->manifest(), http, so);
  EXPECT_EQ(s.guardS(), so.residency.guard_s);  // nothing measured yet: the least
  testing::CheckingSink sink;
  const streamer::Camera cam{{512, 512, 40}, {0, 0, 0}};
  const auto start = std::chrono::steady_clock::now();
  auto now = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  streamer::FrameStats st;
  std::vector<double> latencies;
  for (int i = 0; i < 20000; ++i) {  // a bound for a loaded machine, not a timed assertion
    st = s.update(cam, now(), sink);
    latencies.insert(latencies.end(), s.lastLoadLatenciesS().begin(), s.lastLoadLatenciesS().end());
    if (st.resident == st.wanted && s.idle()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ASSERT_EQ(st.resident, st.wanted);
  EXPECT_EQ(sink.failures, 0) << sink.last_error;
  ASSERT_EQ(int(latencies.size()), sink.loads);
  for (double l : latencies) EXPECT_GE(l, 0.1);
  EXPECT_GE(s.latencyEstimateS(), 0.1);
  EXPECT_DOUBLE_EQ(s.guardS(), std::max(so.residency.guard_s, 2.0 * s.latencyEstimateS()));
  EXPECT_GE(proxy.delayed(), sink.loads);
  for (SectorKey key : s.residentKeys()) {
    auto from_file = ArchiveReader::open(file_)->readSector(key);
    ASSERT_EQ(encodeSector(*s.resident(key)), encodeSector(*from_file)) << toString(key);
  }
}

TEST_F(HttpSourceTest, A503IsRetriedAndTheFlightRecoversWhenTheServerDoes) {
  auto http = openHttp("/flaky/world.drtv");
  ASSERT_NE(http, nullptr);
  streamer::Streamer s(http->manifest(), http, deterministic());
  testing::CheckingSink sink;
  const streamer::Camera cam{{512, 512, 40}, {0, 0, 0}};
  touch("down");
  double t = 0;
  int failures = 0, miss_frames = 0;
  for (int i = 0; i < 60; ++i, t += kFrameS) {
    const streamer::FrameStats st = s.update(cam, t, sink);
    failures += st.failures;
    miss_frames += st.misses > 0;
  }
  EXPECT_GT(failures, 0);
  EXPECT_EQ(miss_frames, 60);
  EXPECT_TRUE(s.residentKeys().empty());
  EXPECT_NE(sink.last_error.find(nginx_->url("/flaky/world.drtv")), std::string::npos) << sink.last_error;
  EXPECT_NE(sink.last_error.find("HTTP 503"), std::string::npos) << sink.last_error;
  EXPECT_NE(sink.last_error.find("gave up after 3 attempts"), std::string::npos) << sink.last_error;
  // Each failed read was tried max_attempts times.
  EXPECT_EQ(http->stats().retries, 2 * http->stats().failures);

  // Back up: within the longest back-off (8 s) every sector is retried and loads.
  untouch("down");
  int misses = -1;
  for (int i = 0; i < 60 * 10; ++i, t += kFrameS) misses = s.update(cam, t, sink).misses;
  EXPECT_EQ(misses, 0);
  EXPECT_TRUE(s.idle());
  EXPECT_EQ(s.residentKeys(), settledFromFile(cam));
}

TEST_F(HttpSourceTest, A404IsFinalNamingTheUrlAndTheSector) {
  auto http = openHttp("/gone/world.drtv");
  ASSERT_NE(http, nullptr);
  touch("gone");
  const uint64_t before = http->stats().requests;
  auto r = http->read(*http->manifest().find(kBad));
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(http->stats().requests, before + 1);  // not retried
  EXPECT_NE(r.error().message.find(nginx_->url("/gone/world.drtv") + ": sector (7,7): bytes "), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("HTTP 404"), std::string::npos) << r.error().message;

  auto missing = HttpSectorSource::open(nginx_->url("/ok/nothing-here.drtv"), quick());
  ASSERT_FALSE(missing.has_value());
  EXPECT_NE(missing.error().message.find("nothing-here.drtv: the header: bytes 0-63: HTTP 404"), std::string::npos)
      << missing.error().message;
}

TEST_F(HttpSourceTest, AFileShorterThanAHeaderIsRefusedAsTruncatedNamingTheUrl) {
  std::ofstream(dir_.path() / "www" / "ok" / "short.drtv") << "DRTVARC";
  auto s = HttpSectorSource::open(nginx_->url("/ok/short.drtv"), quick());
  ASSERT_FALSE(s.has_value());
  EXPECT_EQ(s.error().message, nginx_->url("/ok/short.drtv") + ": byte 0: truncated: 7 bytes, not a drtv archive");
}

TEST_F(HttpSourceTest, AnArchiveReplacedOnTheServerIsRefusedNotMixedIn) {
  auto http = openHttp("/ok/world.drtv");
  ASSERT_NE(http, nullptr);
  // A rebake published under the same name: here the same bytes and one more.
  std::ofstream(file_, std::ios::app | std::ios::binary) << '\0';
  const uint64_t before = http->stats().requests;
  auto r = http->read(*http->manifest().find(kBad));
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("sector (7,7): bytes "), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("it was replaced; open it again"), std::string::npos) << r.error().message;
  EXPECT_EQ(http->stats().requests, before + 1);  // final, not retried
}

TEST_F(HttpSourceTest, AServerThatIgnoresRangeIsRefusedNotReadToTheEnd) {
  auto s = HttpSectorSource::open(nginx_->url("/norange/world.drtv"), quick());
  ASSERT_FALSE(s.has_value());
  EXPECT_NE(s.error().message.find("ignored the Range header (200 OK"), std::string::npos) << s.error().message;
  // nginx really did answer 200 to a range request. It logs the request once it has seen the
  // connection close, which may come after open() returned: wait for the line (a bound, not a
  // timed assertion).
  const std::string line = "GET /norange/world.drtv HTTP/1.1\" 200 ";
  for (int i = 0; i < 500 && nginx_->accessLog().find(line) == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_NE(nginx_->accessLog().find(line), std::string::npos) << nginx_->accessLog();
}

TEST_F(HttpSourceTest, AReadSlowerThanItsTimeoutFailsNamingTheSectorAfterItsRetries) {
  HttpOptions o = quick();
  o.request_timeout_ms = 300;
  o.max_attempts = 2;
  auto http = openHttp("/slow/world.drtv", o);
  ASSERT_NE(http, nullptr);
  const SectorEntry& e = *http->manifest().find(kBad);
  // 1 KiB/s against a 300 ms timeout: no sector (~10 KB) can arrive in time.
  ASSERT_GT(e.compressed_bytes, 1024u);
  touch("slow");
  auto r = http->read(e);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("sector (7,7): bytes " + std::to_string(e.offset) + "-"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("Timeout"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("gave up after 2 attempts"), std::string::npos) << r.error().message;
  EXPECT_EQ(http->stats().retries, 1u);
  // The rate limit lifted, the same source reads it (a fresh connection after the timed-out one).
  untouch("slow");
  auto again = http->read(e);
  ASSERT_TRUE(again.has_value()) << again.error().message;
  EXPECT_EQ(again->size(), e.compressed_bytes);
}

TEST_F(HttpSourceTest, ACorruptCopyOnTheServerNeverBecomesResident) {
  auto http = openHttp("/corrupt/world.drtv");
  ASSERT_NE(http, nullptr);
  streamer::Streamer s(http->manifest(), http, deterministic());
  testing::CheckingSink sink;
  const streamer::Camera cam{{512, 512, 40}, {0, 0, 0}};
  int failures = 0;
  for (int i = 0; i < 180; ++i) failures += s.update(cam, i * kFrameS, sink).failures;
  EXPECT_GT(failures, 0);
  EXPECT_NE(s.state(kBad), streamer::SectorState::kResident);
  EXPECT_FALSE(sink.holds(kBad));
  EXPECT_NE(sink.last_error.find("(7,7)"), std::string::npos) << sink.last_error;
  EXPECT_NE(sink.last_error.find("hash mismatch"), std::string::npos) << sink.last_error;
  EXPECT_EQ(s.residentKeys().size(), size_t(streamer::kMaxResidentSectors - 1));
  EXPECT_EQ(http->stats().retries, 0u);  // the server answered well: the bytes are bad, not the transfer
}

TEST_F(HttpSourceTest, TheFlightGoesOnWhileTheServerIsStoppedAndRestarted) {
  auto http = openHttp("/ok/world.drtv");
  ASSERT_NE(http, nullptr);
  streamer::Streamer s(http->manifest(), http, deterministic());
  testing::CheckingSink sink;
  int frame = 0;
  for (; frame < 120; ++frame) s.update(flightCamera(frame), frame * kFrameS, sink);
  const size_t resident_before = s.residentKeys().size();
  ASSERT_GT(resident_before, 0u);

  nginx_->stop();
  int failures = 0, evictions = 0, miss_frames = 0;
  for (; frame < 240; ++frame) {
    const streamer::FrameStats st = s.update(flightCamera(frame), frame * kFrameS, sink);
    failures += st.failures;
    evictions += st.evictions;
    miss_frames += st.misses > 0;
  }
  EXPECT_GT(failures, 0);
  EXPECT_GT(miss_frames, 0);
  EXPECT_NE(sink.last_error.find("Couldn't connect"), std::string::npos) << sink.last_error;
  // What was resident stays until the camera leaves it behind: nothing is dropped for the outage.
  EXPECT_GT(s.residentKeys().size(), 0u);
  EXPECT_LT(size_t(evictions), resident_before);

  // Back on the same port: the camera waits where the outage left it, and every sector the
  // file would give there arrives within the longest back-off (8 s).
  auto restarted = nginx_->start();
  ASSERT_TRUE(restarted.has_value()) << restarted.error().message;
  // (Which sectors it holds also depends on what it held before: the residency keeps held ones,
  // so the set is compared with what it wants, not with another streamer's.)
  const streamer::Camera hold = flightCamera(240);
  streamer::FrameStats last;
  for (const int end = frame + 60 * 10; frame < end; ++frame) last = s.update(hold, frame * kFrameS, sink);
  EXPECT_EQ(last.misses, 0);
  EXPECT_EQ(last.fallback, 0);
  EXPECT_EQ(last.resident, last.wanted);
  EXPECT_TRUE(s.idle());
  for (const SectorEntry& e : manifest_.sectors) EXPECT_NE(s.state(e.key), streamer::SectorState::kBackingOff) << toString(e.key);
}

// Answers broken in the network, between nginx and the source: cut short, reset, stalled.
class BrokenAnswerTest : public HttpSourceTest, public ::testing::WithParamInterface<testing::FaultProxy::Mode> {};

const char* modeName(testing::FaultProxy::Mode m) {
  switch (m) {
    case testing::FaultProxy::Mode::kCut: return "cut_short";
    case testing::FaultProxy::Mode::kReset: return "reset";
    case testing::FaultProxy::Mode::kStall: return "stalled";
    default: return "pass";
  }
}

TEST_P(BrokenAnswerTest, IsRetriedOnAFreshConnectionAndTheReadSucceeds) {
  testing::FaultProxy proxy(nginx_->port());
  HttpOptions o = quick();
  o.request_timeout_ms = 300;  // a stalled answer is given up after this
  auto s = HttpSectorSource::open(proxy.url("/ok/world.drtv"), o);
  ASSERT_TRUE(s.has_value()) << s.error().message;
  const SectorEntry& e = *(*s)->manifest().find(kBad);
  auto file = streamer::FileSectorSource::open(file_);
  const auto want = (*file)->read(e);

  proxy.fault(GetParam(), 2);  // the first two attempts break, the third gets through
  auto r = (*s)->read(e);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  EXPECT_EQ(*r, *want);
  EXPECT_EQ(proxy.faulted(), 2);
  EXPECT_EQ((*s)->stats().retries, 2u);
  EXPECT_EQ((*s)->stats().failures, 0u);
  // open()'s connection, and a new one after each broken answer (the proxy closed the first two).
  EXPECT_EQ((*s)->stats().connections, 3u);
}

TEST_P(BrokenAnswerTest, FailsNamingTheSectorWhenEveryAttemptBreaksAndTheFlightGoesOn) {
  testing::FaultProxy proxy(nginx_->port());
  HttpOptions o = quick();
  o.request_timeout_ms = 300;
  auto opened = HttpSectorSource::open(proxy.url("/ok/world.drtv"), o);
  ASSERT_TRUE(opened.has_value()) << opened.error().message;
  std::shared_ptr<HttpSectorSource> http(std::move(*opened));
  streamer::Streamer s(http->manifest(), http, deterministic());
  testing::CheckingSink sink;
  const streamer::Camera cam{{512, 512, 40}, {0, 0, 0}};
  // Every attempt of the first three reads breaks: the first sector the streamer asks for fails.
  proxy.fault(GetParam(), 3);
  int failures = 0;
  for (int i = 0; i < 120; ++i) failures += s.update(cam, i * kFrameS, sink).failures;
  EXPECT_EQ(failures, 1);
  EXPECT_NE(sink.last_error.find(": sector ("), std::string::npos) << sink.last_error;
  EXPECT_NE(sink.last_error.find("gave up after 3 attempts"), std::string::npos) << sink.last_error;
  // Retried by the streamer after its back-off, with the proxy passing again: all loaded.
  for (int i = 120; i < 120 + 60 * 2; ++i) s.update(cam, i * kFrameS, sink);
  const streamer::FrameStats last = s.update(cam, 240 * kFrameS, sink);
  EXPECT_EQ(last.misses, 0);
  EXPECT_EQ(last.resident, last.wanted);
  EXPECT_EQ(http->stats().failures, 1u);
}

INSTANTIATE_TEST_SUITE_P(EveryBreak, BrokenAnswerTest,
                         ::testing::Values(testing::FaultProxy::Mode::kCut, testing::FaultProxy::Mode::kReset,
                                           testing::FaultProxy::Mode::kStall),
                         [](const auto& info) { return std::string(modeName(info.param)); });

}  // namespace
}  // namespace drtv::netsource
