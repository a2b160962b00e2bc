// drtv_consumer <archive.drtv> [x y z]: streams the archive's sectors around a camera at (x, y, z)
// (default: the centre of the archive, 20 m up) into a runtime lit at 10:00, the way an engine's
// frame loop does (the adds and the volume update on a runtime::UpdateWorker, off the frame's
// thread), and prints the ambient irradiance an up-facing surface there receives. The frames here
// only stream; the one update at the end, after every add, gives what `drtv query` gives there
// (scripts/package-check compares the two).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <thread>

#include "drtv/runtime/runtime.h"
#include "drtv/runtime/update_worker.h"
#include "drtv/streamer/streamer.h"

namespace {

// Hands every sector the streamer loads to the runtime's worker (added there before its next
// update), and takes it back on eviction.
class RuntimeSink final : public drtv::streamer::SectorSink {
 public:
  RuntimeSink(drtv::runtime::Runtime& rt, drtv::runtime::UpdateWorker& worker) : rt_(rt), worker_(worker) {}
  void onSectorLoaded(const drtv::Sector& sector, const drtv::runtime::OcclusionTile& tile) override {
    // `sector` stays resident until onSectorEvicted returns, so its LPRT block is borrowed, not copied.
    worker_.addSector(sector, &tile, drtv::runtime::SectorBlock::kBorrow);
  }
  void onSectorEvicted(drtv::SectorKey key) override {
    if (!worker_.cancelAdd(key)) rt_.removeSector(key);  // a queued add never reached the runtime
  }

 private:
  drtv::runtime::Runtime& rt_;
  drtv::runtime::UpdateWorker& worker_;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2 && argc != 5) {
    std::fprintf(stderr, "usage: drtv_consumer <archive.drtv> [x y z]\n");
    return 2;
  }
  auto streamer = drtv::streamer::Streamer::open(argv[1]);
  if (!streamer) {
    std::fprintf(stderr, "drtv_consumer: error: %s\n", streamer.error().message.c_str());
    return 1;
  }
  const drtv::Manifest& m = (*streamer)->manifest();
  glm::dvec3 at = 0.5 * (m.bounds_min + m.bounds_max) + glm::dvec3(0, 0, 20);
  if (argc == 5) at = {std::atof(argv[2]), std::atof(argv[3]), std::atof(argv[4])};
  auto rt = drtv::runtime::runtimeForArchive(m, drtv::runtime::optionsForEffects(m.effects), 10.0);
  if (!rt) {
    std::fprintf(stderr, "drtv_consumer: error: %s: %s\n", argv[1], rt.error().message.c_str());
    return 1;
  }
  drtv::runtime::UpdateWorker worker(**rt);
  RuntimeSink sink(**rt, worker);
  drtv::streamer::Camera camera{at, glm::dvec3(0.0)};
  // Frames until every sector the streamer wants is resident, or nothing more can come (its loads
  // failed), at most 10 s of wall time: its I/O threads load while the frame sleeps, as they would
  // while an engine renders (a loop that spun 600 frames without waiting ended, on a loaded
  // machine, before the last load had decoded).
  double t = 0.0;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  for (int frame = 0; std::chrono::steady_clock::now() < give_up; ++frame, t += 1.0 / 60.0) {
    // An engine would hand each frame's adds and update over here (worker.start), and wait for
    // them (worker.wait) before the next frame streams.
    const drtv::streamer::FrameStats st = (*streamer)->update(camera, t, sink);
    if (st.wanted > 0 && st.resident == st.wanted) break;
    if (frame > 2 && (*streamer)->idle()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  worker.start(at);  // the queued adds, then the update: relight, fill, publish
  worker.wait();
  for (const auto& [key, e] : worker.takeAddErrors()) std::fprintf(stderr, "drtv_consumer: %s\n", e.message.c_str());
  // An engine would log these: a sector that failed to load is retried, and named here.
  for (const drtv::streamer::SectorFailure& f : (*streamer)->failures())
    std::fprintf(stderr, "drtv_consumer: sector load failed (attempt %d): %s\n", f.attempt, f.message.c_str());
  const drtv::runtime::AmbientSample a = (*rt)->ambient(at, glm::vec3(0, 0, 1));
  std::printf("resident %zu sectors; ambient at (%.1f, %.1f, %.1f), normal +Z: %.4f %.4f %.4f\n",
              (*streamer)->residentKeys().size(), at.x, at.y, at.z, a.irradiance.r, a.irradiance.g, a.irradiance.b);
  return 0;
}
