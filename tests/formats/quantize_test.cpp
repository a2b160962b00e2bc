#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "drtv/formats/probe.h"
#include "drtv/formats/quantize.h"

namespace drtv {
namespace {

// The bounds hold in exact arithmetic; float evaluation of v / range and q * range / 32767 adds
// up to a few ulps of v on top.
float slack(float v) { return 4.f * std::numeric_limits<float>::epsilon() * std::fabs(v); }

TEST(Quantize, Unorm16RoundTripIsWithinHalfAStep) {
  for (int i = 0; i <= 100000; ++i) {
    const float v = i / 100000.f;
    EXPECT_LE(std::fabs(dequantizeUnorm16(quantizeUnorm16(v)) - v), unorm16MaxError() + slack(v)) << v;
  }
}

TEST(Quantize, Snorm16RoundTripIsWithinHalfAStepOfTheRange) {
  std::mt19937 rng(5);
  for (float range : {1e-3f, 1.f, 4.f, 1000.f}) {
    std::uniform_real_distribution<float> u(-range, range);
    for (int i = 0; i < 20000; ++i) {
      const float v = u(rng);
      EXPECT_LE(std::fabs(dequantizeSnorm16(quantizeSnorm16(v, range), range) - v), snorm16MaxError(range) + slack(v))
          << v << " in " << range;
    }
  }
}

TEST(Quantize, SaturatesAndMapsNanToZero) {
  EXPECT_EQ(quantizeUnorm16(-1.f), 0);
  EXPECT_EQ(quantizeUnorm16(2.f), 65535);
  EXPECT_EQ(quantizeUnorm16(NAN), 0);
  EXPECT_EQ(quantizeSnorm16(5.f, 1.f), 32767);
  EXPECT_EQ(quantizeSnorm16(-5.f, 1.f), -32767);
  EXPECT_EQ(quantizeSnorm16(NAN, 1.f), 0);
}

TEST(ProbeRecord, PackUnpackKeepsEveryQuantityWithinItsDocumentedBound) {
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  ProbeData p;
  p.position = {12.5f, 63.25f, 217.125f};
  p.flags = kProbeRelocated | kProbeVegetation;
  p.interior = 3;
  float max_abs = 0;
  for (auto& c : p.prt)
    for (auto& b : c)
      for (int k = 0; k < 4; ++k) {
        b[k] = 2.f * u(rng);
        max_abs = std::max(max_abs, std::fabs(b[k]));
      }
  p.sky_vis = {0.1f, 0.5f, 0.9f, 0.f};
  p.sky_vis_sh = {3.5f, -1.2f, 1.5f, 0.3f};
  p.backface_frac = 0.25f;
  p.height_m = 3.37f;
  p.mean_hit_m = 42.f;
  const ProbeRecord r = packProbe(p);
  EXPECT_TRUE(validateProbe(r)) << validateProbe(r).error().message;
  const ProbeData q = unpackProbe(r);
  EXPECT_EQ(q.position, p.position);  // positions are stored as float32: exact
  EXPECT_EQ(q.flags, p.flags);
  EXPECT_EQ(q.interior, p.interior);
  EXPECT_FLOAT_EQ(r.prt_range, max_abs);
  for (int c = 0; c < 3; ++c)
    for (int b = 0; b < 4; ++b)
      for (int k = 0; k < 4; ++k) EXPECT_LE(std::fabs(q.prt[c][b][k] - p.prt[c][b][k]), snorm16MaxError(max_abs) + slack(p.prt[c][b][k]));
  for (int b = 0; b < 4; ++b) EXPECT_LE(std::fabs(q.sky_vis[b] - p.sky_vis[b]), unorm16MaxError());
  for (int k = 0; k < 4; ++k) EXPECT_LE(std::fabs(q.sky_vis_sh[k] - p.sky_vis_sh[k]), snorm16MaxError(kSkyVisShRange));
  EXPECT_NEAR(q.height_m, p.height_m, 0.005f);  // centimetres
  EXPECT_FLOAT_EQ(q.mean_hit_m, p.mean_hit_m);
}

TEST(ProbeRecord, ValidateRejectsWhatPackNeverWrites) {
  ProbeRecord r = packProbe(ProbeData{});
  ASSERT_TRUE(validateProbe(r));
  auto bad = [&](auto mutate) { ProbeRecord x = r; mutate(x); return !validateProbe(x); };
  EXPECT_TRUE(bad([](ProbeRecord& x) { x.position[0] = NAN; }));
  EXPECT_TRUE(bad([](ProbeRecord& x) { x.position[1] = 65.f; }));
  EXPECT_TRUE(bad([](ProbeRecord& x) { x.flags = 0x100; }));
  EXPECT_TRUE(bad([](ProbeRecord& x) { x.prt_range = 0.f; }));
  EXPECT_TRUE(bad([](ProbeRecord& x) { x.prt_range = INFINITY; }));
  EXPECT_TRUE(bad([](ProbeRecord& x) { x.lprt_range = -1.f; }));
  EXPECT_TRUE(bad([](ProbeRecord& x) { x.prt[1][2][3] = -32768; }));
  EXPECT_TRUE(bad([](ProbeRecord& x) { x.sky_terms[3] = 1; }));
  EXPECT_TRUE(bad([](ProbeRecord& x) { x.flags |= kProbeSkyMoments; x.sky_terms[3] = 1; }));
  EXPECT_TRUE(bad([](ProbeRecord& x) { x.flags |= kProbeSkyMoments | kProbeSkyFit; }));
  EXPECT_FALSE(bad([](ProbeRecord& x) { x.flags |= kProbeSkyFit; x.sky_terms[3] = 1; }));
  EXPECT_TRUE(bad([](ProbeRecord& x) { x.sky_terms[1] = 5; }));  // moments without kProbeSkyMoments
  EXPECT_FALSE(bad([](ProbeRecord& x) { x.flags |= kProbeSkyMoments, x.sky_terms[1] = 5; }));
}

}  // namespace
}  // namespace drtv
