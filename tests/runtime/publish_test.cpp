// Publishing: a reader on another thread never sees a half-updated volume. Runs in the plain
// build; for ThreadSanitizer build a separate directory with -fsanitize=thread (docs/runtime.md).
#include <atomic>
#include <thread>

#include <gtest/gtest.h>

#include "drtv/runtime/lighting_sh.h"
#include "drtv/runtime/publish.h"
#include "runtime_world.h"

namespace drtv::runtime {
namespace {

TEST(PublishedVolume, AConcurrentReaderNeverSeesAHalfUpdatedVolume) {
  // Identical probes everywhere: each publish is a uniform volume whose value depends only on
  // the time of day. A torn read would mix two values inside one view.
  ProbeCache cache;
  for (int y = -2; y <= 2; ++y)
    for (int x = -2; x <= 2; ++x)
      ASSERT_TRUE(cache.addSector(testing::makeSector({x, y}, {.probes = 4, .no_probe_fraction = 0.f, .uniform = true}, 1)));
  // Small volume so that the writer publishes many times while the reader reads.
  const VolumeOptions o{.size = {24, 24, 6}, .texel_size_m = {2.f, 2.f, 4.f}};
  PublishedVolume published(o);
  auto relight = [&](int frame) {
    const SkyLighting s = evaluateSky(Sky::tropicalDefault(), 8.0 + (frame % 8));
    cache.relightAll({s.sky_sh, s.sun_sh, s.sky_direct_sh, {}, kAllComponents});
    cache.setFallback(cache.colours({0, 0}));
    cache.pack(1.f);  // a fixed scale: texel values follow the lighting
    published.invalidateAll();
  };
  relight(0);
  published.update(volumeOriginFor(o, {0.0, 0.0, 12.0}), cache);
  std::atomic<bool> done{false};
  std::atomic<int> reads{0}, torn{0};
  std::thread reader([&] {
    while (!done.load(std::memory_order_acquire)) {
      const PublishedVolume::ReadView view = published.read();
      for (int c = 0; c < 3; ++c) {
        const auto t = view->texture(c);
        for (uint32_t v : t)
          if (v != t[0]) {
            torn.fetch_add(1);
            break;
          }
      }
      reads.fetch_add(1);
    }
  });
  for (int frame = 1; frame < 200 || reads.load() < 50; ++frame) {
    if (frame % 3 == 0) relight(frame);
    published.update(volumeOriginFor(o, {frame * 1.7, -frame * 0.9, 12.0 + (frame % 5)}), cache);
    if (frame > 100000) break;
  }
  done.store(true, std::memory_order_release);
  reader.join();
  EXPECT_EQ(torn.load(), 0);
  EXPECT_GT(reads.load(), 0);
}

TEST(PublishedVolume, TheBackBufferCatchesUpWithSlabsAndSectorRefills) {
  ProbeCache cache;
  for (int x = -2; x <= 2; ++x) ASSERT_TRUE(cache.addSector(testing::makeSector({x, 0}, {}, 1)));
  const SkyLighting s = evaluateSky(Sky::tropicalDefault(), 10.0);
  cache.relightAll({s.sky_sh, s.sun_sh, s.sky_direct_sh, {}, kAllComponents});
  cache.pack(cache.maxColour() * 1.25f);
  const VolumeOptions o;
  PublishedVolume published(o);
  published.invalidateAll();
  glm::ivec3 origin = volumeOriginFor(o, {0.0, 30.0, 12.0});
  published.update(origin, cache);
  published.update(origin, cache);  // the second buffer's first build
  ASSERT_TRUE(cache.addSector(testing::makeSector({0, 1}, {}, 1)));
  cache.relightSector({0, 1}, {s.sky_sh, s.sun_sh, s.sky_direct_sh, {}, kAllComponents});
  cache.packSlot(cache.slotOf({0, 1}));
  published.invalidateSector({0, 1});
  for (int frame = 0; frame < 6; ++frame) {
    origin.x += 1;
    published.update(origin, cache);
    EXPECT_LT(published.lastUpdateTexels(), 40000u);  // slabs and one sector, never a full refill
    Volume fresh(o);
    fresh.rebuild(origin, cache);
    const auto view = published.read();
    for (int c = 0; c < 3; ++c)
      ASSERT_TRUE(std::equal(fresh.texture(c).begin(), fresh.texture(c).end(), view->texture(c).begin())) << "frame " << frame;
  }
}

}  // namespace
}  // namespace drtv::runtime
