// ambient.glsl — the talk's ambient shader [1, slides 40-44] for drtv's volumes (GLSL 4.50).
// Kept equal to drtv::runtime::sampleVolume (runtime/src/volume.cpp); the numbered lines (A1..A9)
// correspond one to one with the C++ and ambient.hlsl (docs/runtime.md). Compile check:
//   glslangValidator -V -S frag runtime/shaders/ambient.glsl -o ambient.glsl.spv
// The tests run drtvAmbient as Vulkan compute, this file linked with a compute entry point:
//   glslangValidator -V -S comp -DDRTV_AMBIENT_NO_ENTRY runtime/shaders/ambient.glsl
//     bench/common/shaders/ambient_compute.comp -o ambient_compute.spv      (one line)
// The sh-l1 representation (drtv/formats/representation.h): compiled with -DDRTV_SH_L1, the
// texels hold each channel's band-1 irradiance SH e0..e3 (bytes 1..3 offset binary) and lines
// S5-S6 replace A5-A9 (the C++ has the same S lines).
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012.
#version 450

// Three RGBA8 volumes (R, G, B channels; RGBA = bases B0..B3), clamp-to-edge, trilinear.
layout(binding = 0) uniform sampler3D VolumeTexture_R;
layout(binding = 1) uniform sampler3D VolumeTexture_G;
layout(binding = 2) uniform sampler3D VolumeTexture_B;

// drtv::runtime::VolumeShaderConstants (SnappedCamera is relative to the engine's origin).
layout(binding = 3, std140) uniform VolumeConstants {
  vec3 SnappedCamera;
  float HdrScale;
  vec3 UVScale;
  float OffsetLength;
  vec3 VolumeWrapOffset;
  vec3 UVRemapScale;
  vec3 UVRemapBias;
};

const vec3 Basis_0 = vec3(-0.408248, -0.707107, 0.577350);
const vec3 Basis_1 = vec3(-0.408248, 0.707107, 0.577350);
const vec3 Basis_2 = vec3(0.816497, 0.0, 0.577350);
const vec3 Basis_3 = vec3(0.0, 0.0, -1.0);

vec3 drtvAmbient(vec3 posWS, vec3 normalWS) {
  vec3 samplingOffset = normalWS * OffsetLength;                                        // A1
  vec3 ws = (posWS - SnappedCamera) + samplingOffset;                                   // A2
  vec3 volumeUV = fract(ws * UVScale + 0.5 + VolumeWrapOffset) * UVRemapScale + UVRemapBias;  // A3
  vec4 fetchR = texture(VolumeTexture_R, volumeUV) * HdrScale;                          // A4
  vec4 fetchG = texture(VolumeTexture_G, volumeUV) * HdrScale;
  vec4 fetchB = texture(VolumeTexture_B, volumeUV) * HdrScale;
#ifdef DRTV_SH_L1
  // Bytes 1..3 are 128 + 127 e / HdrScale: fetch.yzw = HdrScale (255 v - 128) / 127.
  fetchR.yzw = (fetchR.yzw * 255.0 - 128.0 * HdrScale) / 127.0;
  fetchG.yzw = (fetchG.yzw * 255.0 - 128.0 * HdrScale) / 127.0;
  fetchB.yzw = (fetchB.yzw * 255.0 - 128.0 * HdrScale) / 127.0;
  vec4 shBasis = vec4(1.0, normalWS.y, normalWS.z, normalWS.x);                          // S5
  return max(vec3(dot(shBasis, fetchR), dot(shBasis, fetchG), dot(shBasis, fetchB)), vec3(0.0));  // S6
#else
  vec4 basisWeights = vec4(dot(normalWS, Basis_0), dot(normalWS, Basis_1),             // A5
                           dot(normalWS, Basis_2), dot(normalWS, Basis_3));
  basisWeights = basisWeights * vec4(1.0, 1.0, 1.0, 0.5) + vec4(0.0, 0.0, 0.0, 0.5);  // A6
  basisWeights.xyz *= clamp(basisWeights.xyz, 0.0, 1.0);                                // A7
  // A8: each texture holds one channel's four basis intensities, so the weighted sum of the
  // basis colours is one dot product per channel.
  return vec3(dot(basisWeights, fetchR), dot(basisWeights, fetchG), dot(basisWeights, fetchB));  // A9
#endif
}

// The fragment entry point. DRTV_AMBIENT_NO_ENTRY leaves it out, so that another entry point can
// be linked with this file as a second compilation unit of its stage (the tests' compute pass,
// bench/common/shaders/ambient_compute.comp).
#ifndef DRTV_AMBIENT_NO_ENTRY
layout(location = 0) in vec3 inPositionWS;
layout(location = 1) in vec3 inNormalWS;
layout(location = 0) out vec4 outAmbient;

void main() { outAmbient = vec4(drtvAmbient(inPositionWS, normalize(inNormalWS)), 1.0); }
#endif
