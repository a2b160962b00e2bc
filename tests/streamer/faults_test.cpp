// Faults: corrupt, truncated, missing, slow and stalled reads never stop the service.
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

#include "drtv/streamer/streamer.h"
#include "streamer_world.h"

namespace drtv::streamer {
namespace {

constexpr double kFrameS = 1.0 / 60.0;

class FaultTest : public ::testing::TestWithParam<Fault> {
 protected:
  void SetUp() override {
    manifest_ = testing::writeWorld(dir_.path() / "world.drtv", {});
    auto file = FileSectorSource::open(dir_.path() / "world.drtv");
    ASSERT_TRUE(file.has_value());
    faults_ = std::make_shared<FaultInjectingSource>(std::shared_ptr<SectorSource>(std::move(*file)),
                                                     FaultInjectingSource::SlowReads::kSimulated);
  }
  std::unique_ptr<Streamer> make(IoMode mode) {
    StreamerOptions o;
    o.io_mode = mode;
    return std::make_unique<Streamer>(manifest_, faults_, o);
  }
  testing::TempDir dir_;
  Manifest manifest_;
  std::shared_ptr<FaultInjectingSource> faults_;
};

// A sector in the middle of the footprint of a camera at (512, 512).
constexpr SectorKey kBad{7, 7};
constexpr SectorKey kWorseBad{8, 8};

TEST_P(FaultTest, ABadSectorIsReportedRetriedAndFallsBackWhileTheRestStays) {
  auto s = make(IoMode::kDeterministic);
  testing::CheckingSink sink;
  double t = 0;
  const Camera start{{100, 100, 0}, {0, 0, 0}};  // (7,7) is ~490 m away: not among the 51
  for (int i = 0; i < 30; ++i, t += kFrameS) s->update(start, t, sink);
  ASSERT_NE(s->state(kBad), SectorState::kResident);

  faults_->inject(kBad, GetParam());
  // Step towards (512, 512): the bad sector enters the footprint. Hold there 3 s.
  const Camera there{{512, 512, 0}, {0, 0, 0}};
  int failures = 0, fallback_frames = 0;
  for (int i = 0; i < 180; ++i, t += kFrameS) {
    const FrameStats st = s->update(there, t, sink);
    failures += st.failures;
    fallback_frames += st.fallback > 0;
    if (i > 10) {
      EXPECT_LE(st.misses, 1);  // after the jump's loads land: the bad one only
    }
  }
  EXPECT_NE(s->state(kBad), SectorState::kResident);
  EXPECT_GE(failures, 3);                  // retried: 0.25 + 0.5 + 1 s of back-off fit in 3 s
  EXPECT_LE(failures, 5);                  // ... with back-off, not every frame
  EXPECT_GT(fallback_frames, 90);          // its area fell back to distant ambient meanwhile
  EXPECT_EQ(sink.failures, failures);
  EXPECT_NE(sink.last_error.find("(7,7)"), std::string::npos) << sink.last_error;
  ASSERT_FALSE(s->failures().empty());
  EXPECT_EQ(s->failures().back().key, kBad);
  // Everything else around the camera is resident.
  EXPECT_EQ(s->residentKeys().size(), size_t(kMaxResidentSectors - 1));

  // Heal the disk: the next retry loads it.
  faults_->clear(kBad);
  for (int i = 0; i < 600 && s->state(kBad) != SectorState::kResident; ++i, t += kFrameS) s->update(there, t, sink);
  EXPECT_EQ(s->state(kBad), SectorState::kResident);
  EXPECT_EQ(s->update(there, t, sink).misses, 0);
}

TEST_P(FaultTest, AFaultNeverEvictsWhatIsAlreadyResident) {
  auto s = make(IoMode::kDeterministic);
  testing::CheckingSink sink;
  double t = 0;
  const Camera cam{{512, 512, 0}, {0, 0, 0}};
  for (int i = 0; i < 30; ++i, t += kFrameS) s->update(cam, t, sink);
  const auto before = s->residentKeys();
  // Every sector of the world now fails; the resident ones are not re-read, so nothing changes.
  for (const SectorEntry& e : manifest_.sectors) faults_->inject(e.key, GetParam());
  for (int i = 0; i < 120; ++i, t += kFrameS) EXPECT_EQ(s->update(cam, t, sink).evictions, 0);
  EXPECT_EQ(s->residentKeys(), before);
}

INSTANTIATE_TEST_SUITE_P(EveryFault, FaultTest, ::testing::Values(Fault::kMissing, Fault::kTruncated, Fault::kCorrupt),
                         [](const auto& info) { return std::string(faultName(info.param)); });

using FaultsTest = FaultTest;

TEST_F(FaultsTest, BackOffDoublesFromAQuarterSecondUpToEightSeconds) {
  auto s = make(IoMode::kDeterministic);
  testing::CheckingSink sink;
  faults_->inject(kBad, Fault::kCorrupt);
  const Camera cam{{512, 512, 0}, {0, 0, 0}};
  double t = 0;
  for (int i = 0; i < 60 * 40; ++i, t += kFrameS) s->update(cam, t, sink);
  std::vector<double> waits;
  for (const SectorFailure& f : s->failures())
    if (f.key == kBad) waits.push_back(f.retry_at_s - f.time_s);
  ASSERT_GE(waits.size(), 7u);
  const double expect[] = {0.25, 0.5, 1, 2, 4, 8, 8};
  for (size_t i = 0; i < 7; ++i) EXPECT_DOUBLE_EQ(waits[i], expect[i]) << i;
  for (size_t i = 0; i < waits.size(); ++i) EXPECT_EQ(s->failures()[i].attempt, int(i) + 1);
}

TEST_F(FaultsTest, ASlowReadInDeterministicModeArrivesLaterWithoutHoldingUpOthers) {
  // Every read slow, and only the next one: the first read is late either way.
  for (int times : {FaultInjectingSource::kForever, 1}) {
    auto s = make(IoMode::kDeterministic);
    testing::CheckingSink sink;
    faults_->inject(kBad, Fault::kSlow, times, 1.0);
    const Camera cam{{512, 512, 0}, {0, 0, 0}};
    double t = 0;
    for (; t < 0.5; t += kFrameS) s->update(cam, t, sink);
    EXPECT_EQ(s->state(kBad), SectorState::kLoading) << "times " << times;
    EXPECT_EQ(s->residentKeys().size(), size_t(kMaxResidentSectors - 1));
    for (; t < 1.2; t += kFrameS) s->update(cam, t, sink);
    EXPECT_EQ(s->state(kBad), SectorState::kResident);
  }
}

TEST_F(FaultsTest, AStalledReadOnOneThreadDoesNotStopTheOtherThreads) {
  StreamerOptions o;
  o.io_threads = 2;
  auto s = std::make_unique<Streamer>(manifest_, faults_, o);
  testing::CheckingSink sink;
  faults_->inject(kBad, Fault::kStall);
  faults_->inject(kWorseBad, Fault::kSlow, FaultInjectingSource::kForever, 0.0);
  const Camera cam{{512, 512, 0}, {0, 0, 0}};
  double t = 0;
  for (int i = 0; i < 20000 && s->residentKeys().size() < size_t(kMaxResidentSectors - 1); ++i, t += kFrameS) {
    s->update(cam, t, sink);
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  EXPECT_EQ(s->residentKeys().size(), size_t(kMaxResidentSectors - 1));
  EXPECT_EQ(s->state(kBad), SectorState::kLoading);
  EXPECT_EQ(faults_->stalled(), 1);
  faults_->releaseStalls();
  for (int i = 0; i < 20000 && s->state(kBad) != SectorState::kResident; ++i, t += kFrameS) {
    s->update(cam, t, sink);
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  EXPECT_EQ(s->state(kBad), SectorState::kResident);
  s->evictAll(sink);
}

TEST_F(FaultsTest, ThreadedModeRetriesACorruptSectorUntilItHeals) {
  StreamerOptions o;
  o.io_threads = 2;
  o.retry_initial_s = 0.05;
  auto s = std::make_unique<Streamer>(manifest_, faults_, o);
  testing::CheckingSink sink;
  faults_->inject(kBad, Fault::kCorrupt, 3);  // the first three reads are bad
  const Camera cam{{512, 512, 0}, {0, 0, 0}};
  double t = 0;
  for (int i = 0; i < 20000 && s->state(kBad) != SectorState::kResident; ++i, t += kFrameS) {
    s->update(cam, t, sink);
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  EXPECT_EQ(s->state(kBad), SectorState::kResident);
  EXPECT_EQ(sink.failures, 3);
  EXPECT_EQ(faults_->reads(kBad), 4);
  s->evictAll(sink);
}

}  // namespace
}  // namespace drtv::streamer
