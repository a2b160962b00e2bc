// fine.hlsl — the fine level near surfaces (issue 35) for drtv's shaders (HLSL SM5). Kept equal to
// drtv::runtime::ProbeCache::fineLookup and fine.glsl line by line (F1..F9); the buffers are
// drtv::runtime::packFineLevel's (fine_shader.h). The engine blends
//   float4 fine = drtvFine(posWS, normalWS);  ambient = lerp(ambient, fine.rgb, fine.a);
// Registers b1 and t3-t5, after ambient.hlsl's b0 and t0-t2. The tests #include this file from a
// compute entry point (bench/common/shaders/fine_compute.hlsl, which gives the command).
// Compiled with -DDRTV_SH_L1 for the sh-l1 representation, as ambient.hlsl.

cbuffer FineConstants : register(b1) {
  float3 FineBoxMin;
  float FineCellM;
  float3 FineBoxMax;
  float FineRadiusM;
  int3 FineCells;
  float FineNormalBiasM;
  float FineMinVisibility;
  float FineFullWeight;
  float FineFadeM;
  uint FineProbeCount;
};
struct FineProbe {
  float4 position;    // xyz world metres
  float4 colours[4];  // basis colours, rgb
};
StructuredBuffer<FineProbe> FineProbes : register(t3);
StructuredBuffer<uint> FineVisibility : register(t4);
StructuredBuffer<uint> FineCellList : register(t5);

// drtv/formats/visibility.h.
static const int kDrtvVisDim = 16;
static const float kDrtvVisRangeM = 16.0;
static const float kDrtvVisMaxSigmaM = 8.0;
static const float kDrtvVisMinVariance = 1e-3;

float2 drtvOctEncode(float3 d) {  // octEncode
  float l1 = abs(d.x) + abs(d.y) + abs(d.z);
  float2 p = l1 > 0.0 ? d.xy / l1 : float2(0.0, 0.0);
  if (d.z < 0.0) p = (1.0 - abs(p.yx)) * float2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
  return p * 0.5 + 0.5;
}

// Texel (x, y) of probe `probe`'s map as the moments (mean, mean^2 + sigma^2): decodeVisTexel.
float2 drtvVisTexel(uint probe, int x, int y) {
  uint i = uint(y * kDrtvVisDim + x) * 2u;  // even: both bytes in one uint
  uint word = FineVisibility[probe * 128u + i / 4u] >> ((i % 4u) * 8u);
  float q = float(word & 255u) / 255.0;
  float mean = q * q * kDrtvVisRangeM;
  float sigma = float((word >> 8u) & 255u) / 255.0 * kDrtvVisMaxSigmaM;
  return float2(mean, mean * mean + sigma * sigma);
}

// visibilityWeight: bilinear moments at d, then Chebyshev's bound, cubed.
float drtvVisibility(uint probe, float3 d, float r) {
  float2 t = clamp(drtvOctEncode(d) * float(kDrtvVisDim) - 0.5, float2(0.0, 0.0), float2(kDrtvVisDim - 1, kDrtvVisDim - 1));
  int x0 = min(int(t.x), kDrtvVisDim - 2), y0 = min(int(t.y), kDrtvVisDim - 2);
  float fx = t.x - float(x0), fy = t.y - float(y0);
  float2 a = lerp(drtvVisTexel(probe, x0, y0), drtvVisTexel(probe, x0 + 1, y0), fx);
  float2 b = lerp(drtvVisTexel(probe, x0, y0 + 1), drtvVisTexel(probe, x0 + 1, y0 + 1), fx);
  float2 m = lerp(a, b, fy);
  if (!(r > m.x)) return 1.0;
  float variance = max(m.y - m.x * m.x, kDrtvVisMinVariance);
  float e = r - m.x;
  float p = variance / (variance + e * e);
  return p * p * p;
}

float4 drtvFine(float3 posWS, float3 normalWS) {
  float3 at = posWS + normalWS * FineNormalBiasM;                                       // F1
  float3 edge = min(at - FineBoxMin, FineBoxMax - at);
  float fade = clamp(min(edge.x, min(edge.y, edge.z)) / FineFadeM, 0.0, 1.0);           // F2
  if (!(fade > 0.0)) return float4(0.0, 0.0, 0.0, 0.0);
  int3 c = clamp(int3(floor((at - FineBoxMin) / FineCellM)), int3(0, 0, 0), FineCells - 1);  // F3
  uint cell = uint(c.x + FineCells.x * (c.y + FineCells.y * c.z));
  uint first = FineCellList[2u * cell], count = FineCellList[2u * cell + 1u];
  float r2max = FineRadiusM * FineRadiusM;
  float3 sum0 = 0.0, sum1 = 0.0, sum2 = 0.0, sum3 = 0.0;
  float weights = 0.0;
  for (uint k = 0u; k < count; ++k) {
    uint i = FineCellList[first + k];
    float3 d = at - FineProbes[i].position.xyz;                                         // F4
    float r2 = dot(d, d);
    if (!(r2 < r2max)) continue;
    float r = sqrt(r2);
    float3 dir = r > 1e-6 ? d / r : float3(0.0, 0.0, 1.0);
    float falloff = (1.0 - r2 / r2max) * (1.0 - r2 / r2max);                            // F5
    float facing = 0.5 * (1.0 + dot(-dir, normalWS));
    float back = facing * facing + 0.2;                                                 // F6
    float v = drtvVisibility(i, dir, r);                                                // F7
    if (!(v >= FineMinVisibility)) continue;
    float w = falloff * back * v;
    if (w < 0.2) w = w * w * w / 0.04;                                                  // F8
    if (!(w > 0.0)) continue;
    sum0 += w * FineProbes[i].colours[0].rgb;
    sum1 += w * FineProbes[i].colours[1].rgb;
    sum2 += w * FineProbes[i].colours[2].rgb;
    sum3 += w * FineProbes[i].colours[3].rgb;
    weights += w;
  }
  if (!(weights > 0.0)) return float4(0.0, 0.0, 0.0, 0.0);
  float3 c0 = sum0 / weights, c1 = sum1 / weights, c2 = sum2 / weights, c3 = sum3 / weights;
  // F9: shaded for the normal as runtime::shade (ambient.hlsl's A5-A9, S5-S6).
#ifdef DRTV_SH_L1
  float3 shaded = max(c0 + c1 * normalWS.y + c2 * normalWS.z + c3 * normalWS.x, float3(0.0, 0.0, 0.0));
#else
  float4 bw = float4(dot(normalWS, float3(-0.408248, -0.707107, 0.577350)), dot(normalWS, float3(-0.408248, 0.707107, 0.577350)),
                     dot(normalWS, float3(0.816497, 0.0, 0.577350)), dot(normalWS, float3(0.0, 0.0, -1.0)));
  bw = bw * float4(1.0, 1.0, 1.0, 0.5) + float4(0.0, 0.0, 0.0, 0.5);
  bw.xyz *= saturate(bw.xyz);
  float3 shaded = bw.x * c0 + bw.y * c1 + bw.z * c2 + bw.w * c3;
#endif
  return float4(shaded, min(1.0, weights / FineFullWeight) * fade);
}
