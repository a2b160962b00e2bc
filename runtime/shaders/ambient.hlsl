// ambient.hlsl — the talk's ambient shader [1, slides 40-44] for drtv's volumes (HLSL SM5).
// Kept equal to drtv::runtime::sampleVolume and ambient.glsl line by line (A1..A9,
// docs/runtime.md). Compile check:
//   glslangValidator -D -V -e main -S frag runtime/shaders/ambient.hlsl -o ambient.hlsl.spv
// The tests #include this file from a compute entry point and run it as Vulkan compute
// (bench/common/shaders/ambient_compute.hlsl, which gives the command).
// The sh-l1 representation (drtv/formats/representation.h): compiled with -DDRTV_SH_L1, the
// texels hold each channel's band-1 irradiance SH e0..e3 (bytes 1..3 offset binary) and lines
// S5-S6 replace A5-A9 (the C++ has the same S lines).
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012.

Texture3D<float4> VolumeTexture_R : register(t0);
Texture3D<float4> VolumeTexture_G : register(t1);
Texture3D<float4> VolumeTexture_B : register(t2);
SamplerState VolumeSampler : register(s0);  // trilinear, clamp addressing (the talk: 5x faster than wrap)

cbuffer VolumeConstants : register(b0) {
  float3 SnappedCamera;
  float HdrScale;
  float3 UVScale;
  float OffsetLength;
  float3 VolumeWrapOffset;
  float Pad0;
  float3 UVRemapScale;
  float Pad1;
  float3 UVRemapBias;
  float Pad2;
};

static const float3 Basis_0 = float3(-0.408248, -0.707107, 0.577350);
static const float3 Basis_1 = float3(-0.408248, 0.707107, 0.577350);
static const float3 Basis_2 = float3(0.816497, 0.0, 0.577350);
static const float3 Basis_3 = float3(0.0, 0.0, -1.0);

float3 drtvAmbient(float3 posWS, float3 normalWS) {
  float3 samplingOffset = normalWS * OffsetLength;                                      // A1
  float3 ws = (posWS - SnappedCamera) + samplingOffset;                                 // A2
  float3 volumeUV = frac(ws * UVScale + 0.5 + VolumeWrapOffset) * UVRemapScale + UVRemapBias;  // A3
  float4 fetchR = VolumeTexture_R.SampleLevel(VolumeSampler, volumeUV, 0) * HdrScale;   // A4
  float4 fetchG = VolumeTexture_G.SampleLevel(VolumeSampler, volumeUV, 0) * HdrScale;
  float4 fetchB = VolumeTexture_B.SampleLevel(VolumeSampler, volumeUV, 0) * HdrScale;
#ifdef DRTV_SH_L1
  // Bytes 1..3 are 128 + 127 e / HdrScale: fetch.yzw = HdrScale (255 v - 128) / 127.
  fetchR.yzw = (fetchR.yzw * 255.0 - 128.0 * HdrScale) / 127.0;
  fetchG.yzw = (fetchG.yzw * 255.0 - 128.0 * HdrScale) / 127.0;
  fetchB.yzw = (fetchB.yzw * 255.0 - 128.0 * HdrScale) / 127.0;
  float4 shBasis = float4(1.0, normalWS.y, normalWS.z, normalWS.x);                     // S5
  return max(float3(dot(shBasis, fetchR), dot(shBasis, fetchG), dot(shBasis, fetchB)), 0.0);  // S6
#else
  float4 basisWeights;                                                                  // A5
  basisWeights.x = dot(normalWS, Basis_0);
  basisWeights.y = dot(normalWS, Basis_1);
  basisWeights.z = dot(normalWS, Basis_2);
  basisWeights.w = dot(normalWS, Basis_3);
  basisWeights = basisWeights * float4(1.0, 1.0, 1.0, 0.5) + float4(0.0, 0.0, 0.0, 0.5);  // A6
  basisWeights.xyz *= saturate(basisWeights.xyz);                                       // A7
  // A8: one texture per channel, RGBA = the four basis intensities.
  return float3(dot(basisWeights, fetchR), dot(basisWeights, fetchG), dot(basisWeights, fetchB));  // A9
#endif
}

float4 main(float3 positionWS : TEXCOORD0, float3 normalWS : TEXCOORD1) : SV_Target {
  return float4(drtvAmbient(positionWS, normalize(normalWS)), 1.0);
}
