// fine.glsl — the fine level near surfaces (issue 35) for drtv's shaders (GLSL 4.50): the covered
// probes around a point, each weighted by distance, by the side of the surface it stands on and by
// its visibility map, so that no light comes through a wall. Kept equal to
// drtv::runtime::ProbeCache::fineLookup (runtime/src/probe_cache_fine.cpp) and fine.hlsl; the
// buffers are drtv::runtime::packFineLevel's (fine_shader.h, which draws them). The engine blends
//   vec4 fine = drtvFine(posWS, normalWS);  ambient = mix(ambient, fine.rgb, fine.a);
// Compile check (a library of functions: link it with the stage's entry point):
//   glslangValidator -V -S frag -DDRTV_FINE_BINDING=4 runtime/shaders/fine.glsl <entry file>
// The tests run drtvFine as Vulkan compute (bench/common/shaders/fine_compute.comp). Compiled with
// -DDRTV_SH_L1 for the sh-l1 representation, as ambient.glsl.
//  [1] Majercik et al., "Dynamic Diffuse Global Illumination with Ray-Traced Irradiance Fields",
//      JCGT 8(2), 2019 (the weights; drtv/formats/visibility.h).
#version 450

// The first of the four bindings (set 0); ambient.glsl takes 0-3.
#ifndef DRTV_FINE_BINDING
#define DRTV_FINE_BINDING 4
#endif

// drtv::runtime::FineShaderConstants.
layout(binding = DRTV_FINE_BINDING, std140) uniform FineConstants {
  vec3 FineBoxMin;
  float FineCellM;
  vec3 FineBoxMax;
  float FineRadiusM;
  ivec3 FineCells;
  float FineNormalBiasM;
  float FineMinVisibility;
  float FineFullWeight;
  float FineFadeM;
  uint FineProbeCount;
};
struct FineProbe {
  vec4 position;    // xyz world metres
  vec4 colours[4];  // basis colours, rgb
};
layout(std430, binding = DRTV_FINE_BINDING + 1) readonly buffer FineProbes { FineProbe fineProbes[]; };
layout(std430, binding = DRTV_FINE_BINDING + 2) readonly buffer FineVisibility { uint fineVisibility[]; };
layout(std430, binding = DRTV_FINE_BINDING + 3) readonly buffer FineCellList { uint fineCells[]; };

// drtv/formats/visibility.h.
const int kDrtvVisDim = 16;
const float kDrtvVisRangeM = 16.0;
const float kDrtvVisMaxSigmaM = 8.0;
const float kDrtvVisMinVariance = 1e-3;

vec2 drtvOctEncode(vec3 d) {  // octEncode
  float l1 = abs(d.x) + abs(d.y) + abs(d.z);
  vec2 p = l1 > 0.0 ? d.xy / l1 : vec2(0.0);
  if (d.z < 0.0) p = (1.0 - abs(p.yx)) * vec2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
  return p * 0.5 + 0.5;
}

// Texel (x, y) of probe `probe`'s map as the moments (mean, mean^2 + sigma^2): decodeVisTexel.
vec2 drtvVisTexel(uint probe, int x, int y) {
  uint i = uint(y * kDrtvVisDim + x) * 2u;  // even: both bytes in one uint
  uint word = fineVisibility[probe * 128u + i / 4u] >> ((i % 4u) * 8u);
  float q = float(word & 255u) / 255.0;
  float mean = q * q * kDrtvVisRangeM;
  float sigma = float((word >> 8u) & 255u) / 255.0 * kDrtvVisMaxSigmaM;
  return vec2(mean, mean * mean + sigma * sigma);
}

// visibilityWeight: bilinear moments at d, then Chebyshev's bound, cubed.
float drtvVisibility(uint probe, vec3 d, float r) {
  vec2 t = clamp(drtvOctEncode(d) * float(kDrtvVisDim) - 0.5, vec2(0.0), vec2(float(kDrtvVisDim - 1)));
  int x0 = min(int(t.x), kDrtvVisDim - 2), y0 = min(int(t.y), kDrtvVisDim - 2);
  float fx = t.x - float(x0), fy = t.y - float(y0);
  vec2 a = mix(drtvVisTexel(probe, x0, y0), drtvVisTexel(probe, x0 + 1, y0), fx);
  vec2 b = mix(drtvVisTexel(probe, x0, y0 + 1), drtvVisTexel(probe, x0 + 1, y0 + 1), fx);
  vec2 m = mix(a, b, fy);
  if (!(r > m.x)) return 1.0;
  float variance = max(m.y - m.x * m.x, kDrtvVisMinVariance);
  float e = r - m.x;
  float p = variance / (variance + e * e);
  return p * p * p;
}

vec4 drtvFine(vec3 posWS, vec3 normalWS) {
  vec3 at = posWS + normalWS * FineNormalBiasM;                                         // F1
  vec3 edge = min(at - FineBoxMin, FineBoxMax - at);
  float fade = clamp(min(edge.x, min(edge.y, edge.z)) / FineFadeM, 0.0, 1.0);           // F2
  if (!(fade > 0.0)) return vec4(0.0);
  ivec3 c = clamp(ivec3(floor((at - FineBoxMin) / FineCellM)), ivec3(0), FineCells - 1);  // F3
  uint cell = uint(c.x + FineCells.x * (c.y + FineCells.y * c.z));
  uint first = fineCells[2u * cell], count = fineCells[2u * cell + 1u];
  float r2max = FineRadiusM * FineRadiusM;
  vec3 sum0 = vec3(0.0), sum1 = vec3(0.0), sum2 = vec3(0.0), sum3 = vec3(0.0);
  float weights = 0.0;
  for (uint k = 0u; k < count; ++k) {
    uint i = fineCells[first + k];
    vec3 d = at - fineProbes[i].position.xyz;                                           // F4
    float r2 = dot(d, d);
    if (!(r2 < r2max)) continue;
    float r = sqrt(r2);
    vec3 dir = r > 1e-6 ? d / r : vec3(0.0, 0.0, 1.0);
    float falloff = (1.0 - r2 / r2max) * (1.0 - r2 / r2max);                            // F5
    float facing = 0.5 * (1.0 + dot(-dir, normalWS));
    float back = facing * facing + 0.2;                                                 // F6
    float v = drtvVisibility(i, dir, r);                                                // F7
    if (!(v >= FineMinVisibility)) continue;
    float w = falloff * back * v;
    if (w < 0.2) w = w * w * w / 0.04;                                                  // F8
    if (!(w > 0.0)) continue;
    sum0 += w * fineProbes[i].colours[0].rgb;
    sum1 += w * fineProbes[i].colours[1].rgb;
    sum2 += w * fineProbes[i].colours[2].rgb;
    sum3 += w * fineProbes[i].colours[3].rgb;
    weights += w;
  }
  if (!(weights > 0.0)) return vec4(0.0);
  vec3 c0 = sum0 / weights, c1 = sum1 / weights, c2 = sum2 / weights, c3 = sum3 / weights;
  // F9: shaded for the normal as runtime::shade (ambient.glsl's A5-A9, S5-S6).
#ifdef DRTV_SH_L1
  vec3 shaded = max(c0 + c1 * normalWS.y + c2 * normalWS.z + c3 * normalWS.x, vec3(0.0));
#else
  vec4 bw = vec4(dot(normalWS, vec3(-0.408248, -0.707107, 0.577350)), dot(normalWS, vec3(-0.408248, 0.707107, 0.577350)),
                 dot(normalWS, vec3(0.816497, 0.0, 0.577350)), dot(normalWS, vec3(0.0, 0.0, -1.0)));
  bw = bw * vec4(1.0, 1.0, 1.0, 0.5) + vec4(0.0, 0.0, 0.0, 0.5);
  bw.xyz *= clamp(bw.xyz, 0.0, 1.0);
  vec3 shaded = bw.x * c0 + bw.y * c1 + bw.z * c2 + bw.w * c3;
#endif
  return vec4(shaded, min(1.0, weights / FineFullWeight) * fade);
}
