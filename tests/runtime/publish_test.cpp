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

// Five sectors in a row along x, relit at 10:00 and packed with the runtime's headroom.
ProbeCache rowLitAtTen() {
  ProbeCache cache;
  for (int x = -2; x <= 2; ++x)
    if (!cache.addSector(testing::makeSector({x, 0}, {}, 1))) ADD_FAILURE() << "sector " << x;
  const SkyLighting s = evaluateSky(Sky::tropicalDefault(), 10.0);
  cache.relightAll({s.sky_sh, s.sun_sh, s.sky_direct_sh, {}, kAllComponents});
  cache.pack(cache.maxColour() * 1.25f);
  return cache;
}

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
  ProbeCache cache = rowLitAtTen();
  const VolumeOptions o;
  PublishedVolume published(o);
  published.invalidateAll();
  glm::ivec3 origin = volumeOriginFor(o, {0.0, 30.0, 12.0});
  published.update(origin, cache);
  published.update(origin, cache);  // the second buffer's first build
  ASSERT_TRUE(cache.addSector(testing::makeSector({0, 1}, {}, 1)));
  const SkyLighting s = evaluateSky(Sky::tropicalDefault(), 10.0);
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

// A blurred relight spread over two updates (publish.h): the first update publishes nothing new,
// the second publishes the volume that a from-scratch rebuild of the first update's lighting
// gives, scrolled to where the camera went meanwhile, bit for bit; a relight in between leaves
// the refill as it began, and the buffer's next turn takes the new lighting.
TEST(PublishedVolume, ATimeSlicedBlurredRefillPublishesOneLightingStateWhole) {
  ProbeCache cache;
  for (int y = -2; y <= 2; ++y)
    for (int x = -2; x <= 2; ++x) ASSERT_TRUE(cache.addSector(testing::makeSector({x, y}, {}, 1)));
  auto relight = [&](double hour) {
    const SkyLighting s = evaluateSky(Sky::tropicalDefault(), hour);
    cache.relightAll({s.sky_sh, s.sun_sh, s.sky_direct_sh, {}, kAllComponents});
    cache.pack(cache.maxColour() * 1.25f);
  };
  const VolumeOptions o{.blur = true};
  PublishedVolume published(o, 2);
  // What a from-scratch rebuild at `origin` of the cache as it is now gives.
  auto rebuiltNow = [&](const glm::ivec3& origin) {
    Volume fresh(o);
    fresh.rebuild(origin, cache);
    return fresh;
  };
  auto published_equals = [&](const Volume& want) {
    const auto view = published.read();
    for (int ch = 0; ch < 3; ++ch)
      if (!std::equal(want.texture(ch).begin(), want.texture(ch).end(), view->texture(ch).begin())) return false;
    return view->origin() == want.origin() && view->hdrScale() == want.hdrScale();
  };
  relight(9.0);
  published.invalidateAll();
  glm::ivec3 origin = volumeOriginFor(o, {0.0, 30.0, 12.0});
  published.update(origin, cache);  // the first volume ever published: whole, at once
  ASSERT_TRUE(published_equals(rebuiltNow(origin)));
  published.update(origin, cache);  // the second buffer's first build, over two updates
  published.update(origin, cache);
  ASSERT_TRUE(published_equals(rebuiltNow(origin)));
  ASSERT_EQ(published.read().sequence(), 2u);

  relight(11.0);
  published.invalidateAll();
  const uint64_t before = published.read().sequence();
  const Volume eleven = rebuiltNow(origin + glm::ivec3(1, 1, 0));
  origin.x += 1;
  published.update(origin, cache);
  EXPECT_EQ(published.read().sequence(), before) << "half a refill was published";
  origin.y += 1;
  published.update(origin, cache);
  EXPECT_GT(published.read().sequence(), before);
  EXPECT_TRUE(published_equals(eleven)) << "the finished refill did not scroll to the camera";

  // A relight while a refill is half done: the refill is published at its own origin and
  // lighting, and the next turn of that buffer takes the newer lighting.
  relight(13.0);
  published.invalidateAll();
  const glm::ivec3 began = origin + glm::ivec3(1, 0, 0);
  const Volume one = rebuiltNow(began);
  published.update(began, cache);
  relight(14.0);
  published.invalidateAll();
  published.update(began + glm::ivec3(1, 0, 0), cache);
  EXPECT_TRUE(published_equals(one)) << "a refill of 13:00 mixed with 14:00, or scrolled with the new scale";
  const glm::ivec3 later = began + glm::ivec3(2, 0, 0);
  published.update(later, cache);
  published.update(later, cache);
  EXPECT_TRUE(published_equals(rebuiltNow(later))) << "14:00 never reached the volume";
}

// Without blur a full refill always takes one update (a fill reads the cache, which a relight
// in between would change under it).
TEST(PublishedVolume, AnUnblurredRefillIsPublishedByTheUpdateThatAskedForIt) {
  ProbeCache cache = rowLitAtTen();
  const VolumeOptions o;
  PublishedVolume published(o, 4);
  const glm::ivec3 origin = volumeOriginFor(o, {0.0, 30.0, 12.0});
  for (int frame = 0; frame < 3; ++frame) {
    published.invalidateAll();
    const uint64_t before = published.read().sequence();
    published.update(origin, cache);
    EXPECT_GT(published.read().sequence(), before) << "frame " << frame;
  }
}

}  // namespace
}  // namespace drtv::runtime
