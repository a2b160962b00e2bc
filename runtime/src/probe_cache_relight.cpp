// probe_cache_relight.cpp — part of ProbeCache (probe_cache.h: the references [1-3] and the
// layout). Relighting: the sky, the sun and the local lights through each slot's transfer
// (relight_kernels.h).
#include "drtv/runtime/probe_cache.h"

#include "drtv/runtime/lighting_sh.h"
#include "probe_cache_impl.h"

namespace drtv::runtime {

using namespace detail;

const int16_t* ProbeCache::Impl::sourcePlanes(int s, size_t j) {
  Slot& sl = slots[s];
  std::vector<int16_t>& planes = sl.lprt[j];
  if (planes.empty()) {
    const size_t stride = size_t(this->stride(s)), row = sl.sources.size() * 12;
    planes.assign(12 * stride, 0);
    const int16_t* src = sl.lprt_coeffs + j * 12;
    for (int i = 0; i < sl.count; ++i)
      for (size_t k = 0; k < 12; ++k) planes[k * stride + size_t(i)] = src[size_t(i) * row + k];
  }
  return planes.data();
}

void ProbeCache::Impl::relightSlot(int s, const RelightInput& li, const std::vector<LitSource>* lit) {
  Slot& sl = slots[s];
  const int n = sl.count;
  // Per-relight constants: the bounce lighting L = sky + sun, and the direct-sky colour of each
  // basis before masking, dot(cosineLobe(B_b), SkySH) with the sky continued through the horizon
  // (lighting_sh.h, "Direct sky").
  float lc[3][4], direct[3][4];
  for (int c = 0; c < 3; ++c) {
    const sh::Sh4 bounce = (li.components & kComponentSkyBounce ? li.sky_sh[c] : sh::Sh4(0.f)) +
                           (li.components & kComponentSunBounce ? li.sun_sh[c] : sh::Sh4(0.f));
    for (int k = 0; k < 4; ++k) lc[c][k] = bounce[k];
    for (int b = 0; b < 4; ++b)
      direct[c][b] = li.components & kComponentDirectSky ? glm::dot(sh::cosineLobe(sh::kBasis[b]), li.sky_direct_sh[c]) : 0.f;
  }
  // Local lights: only sources that received light cost anything, and only when they (or their
  // shares) changed since the slot's last relight; an hour's relight adds the kept sum.
  thread_local std::vector<LitSource> now;
  if (lit)
    now.assign(lit->begin(), lit->end());
  else
    litSources(s, li, now);
  const bool lprt = !now.empty();
  if (lprt && !(sl.local_of_lit && now == sl.lit)) sumLocalLights(s, now);
  std::swap(sl.lit, now);
  sl.local_of_lit = lprt;
  sl.relit = true;
  ++slot_relights;
  const float* local = lprt ? sl.local.data : nullptr;
  const int stride = this->stride(s);
  const int n16 = (n + 15) & ~15;
  if (opt.representation == Representation::kShL1) {
    ShL1Weights w{};
    std::memcpy(w.lc, lc, sizeof lc);
    for (int c = 0; c < 3; ++c) {
      const bool on = li.components & kComponentDirectSky;
      w.d0[c] = on ? li.sky_direct_sh[c][0] : 0.f;
      w.d2[c] = on ? li.sky_direct_sh[c][2] : 0.f;
    }
    const size_t K = sl.sun_dirs.size();
    const bool sun = K > 0 && li.sun_transfer && (li.components & kComponentSunBounce) && li.sun_irradiance != glm::vec3(0.f);
    if (sun && (li.sun_direction != sun_seen || sl.sun_dirs != sun_dirs_seen)) {
      sunTransferWeights(sl.sun_dirs, li.sun_direction, std::span<float>(sun_w_seen.data(), K));
      sun_seen = li.sun_direction;
      sun_dirs_seen = sl.sun_dirs;
    }
    // e_i += kLobe_i E_c sum_k w_k C[k][c][i] (sector.h SunBlock), in the relight's own pass.
    // At most two samples weigh (sunTransferWeights): the first and the last with a weight.
    size_t k0 = K, k1 = K;
    if (sun)
      for (size_t k = 0; k < K; ++k)
        if (sun_w_seen[k] != 0.f) (k0 == K ? k0 : k1) = k;
    int32_t bits = 0;
    const float* blocks = in.data + size_t(s) * kInputPlanes * kSlotProbes;
    if (k0 < K) {
      if (k1 == K) k1 = k0;
      for (int q = 0; q < 12; ++q) {
        const float e = li.sun_irradiance[q / 4] * kLobe[q % 4];
        w.a[q] = sun_w_seen[k0] * e;
        w.b[q] = k1 == k0 ? 0.f : sun_w_seen[k1] * e;
      }
      bits = relightBlocksShL1(blocks, outPlane(s, 0), n16, stride, w, sl.sun.data + k0 * 12 * size_t(stride),
                               sl.sun.data + k1 * 12 * size_t(stride), local);
    } else {
      bits = relightBlocksShL1(blocks, outPlane(s, 0), n16, stride, w, nullptr, nullptr, local);
    }
    sl.max_colour = std::bit_cast<float>(bits);
    return;
  }
  sl.max_colour = std::bit_cast<float>(relightPlanes(inPlane(s, 0), outPlane(s, 0), n16, stride, lc, direct, local));
}

void ProbeCache::Impl::sumLocalLights(int s, std::span<const LitSource> lit) {
  Slot& sl = slots[s];
  const int stride = this->stride(s);
  const int n16 = (sl.count + 15) & ~15;
  ++local_sums;
  float* acc = sl.local.data;
  std::fill_n(acc, size_t(12) * stride, 0.f);
  for (const LitSource& a : lit) {
    float colour[12];
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 4; ++k) colour[c * 4 + k] = a.colour[c];
    accumulateSource(acc, sourcePlanes(s, a.j), sl.lprt_scale.data(), n16, stride, colour);
  }
  if (sl.on_bases) return;  // the sums are basis irradiance already
  // In SH: turned into the colour planes' units, in place (the padding lanes stay 0).
  if (opt.representation == Representation::kShL1) {
    for (int q = 0; q < 12; ++q) {
      float* x = acc + size_t(q) * stride;
      for (int i = 0; i < n16; ++i) x[i] = kLobe[q % 4] * x[i];
    }
    return;
  }
  // fc3 with an SH block: basis irradiance with the clamped-cosine lobes.
  sh::Sh4 lobe[4];
  for (int b = 0; b < 4; ++b) lobe[b] = sh::cosineLobe(sh::kBasis[b]);
  for (int c = 0; c < 3; ++c) {
    float* q = acc + size_t(c) * 4 * stride;
    for (int i = 0; i < n16; ++i) {
      const float r[4] = {q[i], q[stride + i], q[2 * stride + i], q[3 * stride + i]};
      for (int b = 0; b < 4; ++b) q[b * stride + i] = lobe[b][0] * r[0] + lobe[b][1] * r[1] + lobe[b][2] * r[2] + lobe[b][3] * r[3];
    }
  }
}

void ProbeCache::relightAll(const RelightInput& in) {
  Impl& m = *impl_;
  m.setLights(in.components & kComponentLocalLights ? in.lights : std::span<const PointLight>{});
  thread_local std::vector<std::vector<LitSource>> lit;
  m.litSourcesOfAll(in, lit);
  for (size_t s = 0; s < m.slots.size(); ++s)
    if (m.slots[s].used) m.relightSlot(int(s), in, &lit[s]);
}

std::vector<int> ProbeCache::relightChangedLights(const RelightInput& in) {
  Impl& m = *impl_;
  m.setLights(in.components & kComponentLocalLights ? in.lights : std::span<const PointLight>{});
  std::vector<int> relit;
  // Every slot's lit sources from the lit probes (a test of all 51 x 128 sources per frame was a
  // sixth of BM_RelightChangedWith32MovingLights, perf).
  thread_local std::vector<std::vector<LitSource>> now;
  m.litSourcesOfAll(in, now);
  for (size_t s = 0; s < m.slots.size(); ++s) {
    Slot& sl = m.slots[s];
    if (!sl.used) continue;
    if (sl.relit && now[s] == sl.lit) continue;  // the same shares on the same sources: the same colours
    m.relightSlot(int(s), in, &now[s]);
    relit.push_back(int(s));
  }
  return relit;
}

void ProbeCache::setInteriorBoxes(std::vector<std::pair<glm::dvec3, glm::dvec3>> boxes) {
  Impl& m = *impl_;
  if (boxes == m.interior_boxes) return;
  m.interior_boxes = std::move(boxes);
  for (size_t s = 0; s < m.slots.size(); ++s)
    if (m.slots[s].used) m.fillCells(int(s));
}

uint64_t ProbeCache::slotRelightCount() const { return impl_->slot_relights; }
uint64_t ProbeCache::localSumCount() const { return impl_->local_sums; }

void ProbeCache::relightSector(SectorKey key, const RelightInput& in) {
  Impl& m = *impl_;
  const int s = m.slotOf(key);
  DRTV_CHECK(s >= 0);
  m.setLights(in.components & kComponentLocalLights ? in.lights : std::span<const PointLight>{});
  m.relightSlot(s, in);
}

float ProbeCache::maxColour(int slot) const {
  DRTV_CHECK(slot >= 0 && slot < int(impl_->slots.size()));
  return impl_->slots[slot].used ? impl_->slots[slot].max_colour : 0.f;
}
float ProbeCache::maxColour() const {
  float mx = 0.f;
  for (const Slot& s : impl_->slots)
    if (s.used) mx = std::max(mx, s.max_colour);
  return mx;
}

}  // namespace drtv::runtime
