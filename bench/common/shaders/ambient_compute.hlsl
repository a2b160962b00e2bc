// ambient_compute.hlsl — a compute entry point that runs runtime/shaders/ambient.hlsl's drtvAmbient
// over a list of points, for the tests (tests/runtime/shader_run_test.cpp). The production file is
// #included, so the function under test is its text itself, not a copy. Through glslang's HLSL
// front end, with the register shifts that give the same bindings as ambient.glsl (t0-t2 -> 0-2,
// b0 -> 3, t4 -> 4, u5 -> 5, s0 -> 6):
//   glslangValidator -D -V -S comp -e computeMain -Iruntime/shaders --shift-cbuffer-binding 3
//     --shift-sampler-binding 6 bench/common/shaders/ambient_compute.hlsl -o ambient_compute_hlsl.spv
//   (one line)
// The dispatch covers the points in whole workgroups of 64; the caller pads.
#include "ambient.hlsl"

struct AmbientPoint {
  float4 position;  // xyz: world position (the frame SnappedCamera is given in), w unused
  float4 normal;    // xyz: surface normal (normalised here, as the pixel entry does), w unused
};
StructuredBuffer<AmbientPoint> Points : register(t4);
RWStructuredBuffer<float4> Results : register(u5);

[numthreads(64, 1, 1)]
void computeMain(uint3 id : SV_DispatchThreadID) {
  const AmbientPoint p = Points[id.x];
  Results[id.x] = float4(drtvAmbient(p.position.xyz, normalize(p.normal.xyz)), 1.0);
}
