#include "drtv/formats/probe.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>

namespace drtv {
namespace {
float finiteOrZero(float v) { return std::isfinite(v) ? v : 0.f; }
}  // namespace

ProbeRecord packProbe(const ProbeData& p) {
  ProbeRecord r;
  std::memset(&r, 0, sizeof r);
  for (int i = 0; i < 3; ++i) r.position[i] = finiteOrZero(p.position[i]);
  r.flags = p.flags & kProbeKnownFlags;
  r.interior = p.interior;
  float range = 0.f;
  for (const auto& channel : p.prt)
    for (const auto& t : channel)
      for (int k = 0; k < 4; ++k) range = std::max(range, std::fabs(finiteOrZero(t[k])));
  r.prt_range = range > 0.f ? std::clamp(range, kMinQuantizationRange, kMaxPrtRange) : 1.f;
  for (int c = 0; c < 3; ++c)
    for (int b = 0; b < 4; ++b)
      for (int k = 0; k < 4; ++k) r.prt[c][b][k] = quantizeSnorm16(finiteOrZero(p.prt[c][b][k]), r.prt_range);
  for (int b = 0; b < 4; ++b) r.sky_vis[b] = quantizeUnorm16(p.sky_vis[b]);
  const bool fit = r.flags & kProbeSkyFit;
  for (int k = 0; k < 4; ++k) r.sky_vis_sh[k] = quantizeSnorm16(fit ? p.sky_fit_h[k] : p.sky_vis_sh[k], kSkyVisShRange);
  r.lprt_range = 0.f;
  r.backface_frac = quantizeUnorm16(p.backface_frac);
  const float cm = std::clamp(finiteOrZero(p.height_m) * 100.f, 0.f, 65535.f);
  r.height_cm = static_cast<uint16_t>(std::lround(cm));
  r.mean_hit_m = std::max(0.f, finiteOrZero(p.mean_hit_m));
  if (fit) {
    for (int k = 0; k < 4; ++k) r.sky_terms[k] = quantizeSnorm16(finiteOrZero(p.sky_fit_delta[k]), kSkyFitRange);
  } else if (r.flags & kProbeSkyMoments) {
    for (int k = 0; k < 3; ++k) r.sky_terms[k] = quantizeSnorm16(finiteOrZero(p.sky_moments[k]), 1.f);
  }
  return r;
}

ProbeData unpackProbe(const ProbeRecord& r) {
  ProbeData p;
  p.position = glm::vec3(r.position[0], r.position[1], r.position[2]);
  p.flags = r.flags;
  p.interior = r.interior;
  for (int c = 0; c < 3; ++c)
    for (int b = 0; b < 4; ++b)
      for (int k = 0; k < 4; ++k) p.prt[c][b][k] = dequantizeSnorm16(r.prt[c][b][k], r.prt_range);
  for (int b = 0; b < 4; ++b) p.sky_vis[b] = dequantizeUnorm16(r.sky_vis[b]);
  const bool fit = r.flags & kProbeSkyFit;
  for (int k = 0; k < 4; ++k) (fit ? p.sky_fit_h : p.sky_vis_sh)[k] = dequantizeSnorm16(r.sky_vis_sh[k], kSkyVisShRange);
  p.backface_frac = dequantizeUnorm16(r.backface_frac);
  p.height_m = r.height_cm / 100.f;
  p.mean_hit_m = r.mean_hit_m;
  if (fit) {
    for (int k = 0; k < 4; ++k) p.sky_fit_delta[k] = dequantizeSnorm16(r.sky_terms[k], kSkyFitRange);
  } else {
    for (int k = 0; k < 3; ++k) p.sky_moments[k] = dequantizeSnorm16(r.sky_terms[k], 1.f);
  }
  return p;
}

Result<void> validateProbe(const ProbeRecord& r) {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(r.position[i])) return fail("position is not finite");
  if (r.position[0] < 0.f || r.position[0] > 64.f || r.position[1] < 0.f || r.position[1] > 64.f)
    return fail("position (" + std::to_string(r.position[0]) + ", " + std::to_string(r.position[1]) +
           ") outside the sector's [0, 64] m square");
  if (!(std::fabs(r.position[2]) < kMaxProbeHeightM)) return fail("position z " + std::to_string(r.position[2]) + " m is absurd (|z| < 1e6)");
  if (r.flags & ~kProbeKnownFlags) return fail("unknown flag bits " + std::to_string(r.flags & ~kProbeKnownFlags));
  if ((r.flags & kProbeLightSource) && (r.flags & (kProbeCovered | kProbeInterior)))
    return fail("a light source is flagged covered or interior: no lookup reads it");
  if ((r.flags & kProbeStacked) && !(r.flags & kProbeCovered)) return fail("a stacked probe is not flagged covered: only a space under a roof is stacked");
  auto number = [](float v) {
    std::ostringstream s;
    s << v;
    return s.str();
  };
  if (!(r.prt_range >= kMinQuantizationRange && r.prt_range <= kMaxPrtRange))
    return fail("prt_range " + number(r.prt_range) + " outside [" + number(kMinQuantizationRange) + ", " + number(kMaxPrtRange) + "]");
  if (!(r.lprt_range == 0.f || (r.lprt_range >= kMinQuantizationRange && r.lprt_range <= kMaxLprtRange)))
    return fail("lprt_range " + number(r.lprt_range) + " is neither 0 nor in [" + number(kMinQuantizationRange) + ", " +
           number(kMaxLprtRange) + "]");
  if (!(r.mean_hit_m >= 0.f && r.mean_hit_m <= kMaxMeanHitM))
    return fail("mean_hit_m " + number(r.mean_hit_m) + " outside [0, " + number(kMaxMeanHitM) + "]");
  // Min and or reductions (every streamed probe passes here): they vectorise, where an early
  // exit per coefficient would not.
  int16_t min_prt = INT16_MAX, min_sh = INT16_MAX;
  const int16_t* prt = &r.prt[0][0][0];
  for (int i = 0; i < 48; ++i) min_prt = std::min(min_prt, prt[i]);
  if (min_prt == -32768) return fail("prt coefficient -32768 is never written");
  for (int k = 0; k < 4; ++k) min_sh = std::min(min_sh, r.sky_vis_sh[k]);
  if (min_sh == -32768) return fail("sky_vis_sh coefficient -32768 is never written");
  int16_t min_term = INT16_MAX, any_term = 0;
  for (int16_t v : r.sky_terms) min_term = std::min(min_term, v), any_term |= v;
  if (min_term == -32768) return fail("sky_terms coefficient -32768 is never written");
  const bool moments = r.flags & kProbeSkyMoments, fit = r.flags & kProbeSkyFit;
  if (moments && fit) return fail("both the sky-moments and the sky-fit flags are set");
  if (any_term != 0 && !moments && !fit) return fail("sky_terms are not zero without the sky-moments or sky-fit flag");
  if (moments && r.sky_terms[3] != 0) return fail("sky_terms[3] is not zero with the sky-moments flag");
  return {};
}

}  // namespace drtv
