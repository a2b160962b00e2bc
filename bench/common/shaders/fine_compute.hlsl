// fine_compute.hlsl — a compute entry point that runs runtime/shaders/fine.hlsl's drtvFine over a
// list of points, for the tests (tests/runtime/fine_shader_run_test.cpp). The production file is
// #included. Through glslang's HLSL front end, with the shift that gives the same bindings as
// fine_compute.comp (t0 -> 0, u1 -> 1, b1 -> 2, t3-t5 -> 3-5):
//   glslangValidator -D -V -S comp -e computeMain -Iruntime/shaders --shift-cbuffer-binding 1
//     bench/common/shaders/fine_compute.hlsl -o fine_compute_hlsl.spv      (one line)
// The dispatch covers the points in whole workgroups of 64; the caller pads.
#include "fine.hlsl"

struct FinePoint {
  float4 position;  // xyz: world metres, w unused
  float4 normal;    // xyz: surface normal (normalised here), w unused
};
StructuredBuffer<FinePoint> Points : register(t0);
RWStructuredBuffer<float4> Results : register(u1);

[numthreads(64, 1, 1)]
void computeMain(uint3 id : SV_DispatchThreadID) {
  const FinePoint p = Points[id.x];
  Results[id.x] = drtvFine(p.position.xyz, normalize(p.normal.xyz));
}
