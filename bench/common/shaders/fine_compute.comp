// fine_compute.comp — a compute entry point that runs runtime/shaders/fine.glsl's drtvFine over a
// list of points, for the tests (tests/runtime/fine_shader_run_test.cpp). Linked with the
// production file as a second compilation unit, so the function under test is its text itself:
//   glslangValidator -V -S comp -DDRTV_FINE_BINDING=2 runtime/shaders/fine.glsl
//     bench/common/shaders/fine_compute.comp -o fine_compute.spv      (one line)
// Bindings 0 and 1 are the points in and the results out (xyz: the shaded colours, w: the
// weight); fine.glsl's four follow from 2. The dispatch covers the points in whole workgroups of
// 64; the caller pads.
#version 450

layout(local_size_x = 64) in;

vec4 drtvFine(vec3 posWS, vec3 normalWS);  // defined in runtime/shaders/fine.glsl

struct FinePoint {
  vec4 position;  // xyz: world metres, w unused
  vec4 normal;    // xyz: surface normal (normalised here), w unused
};
layout(std430, binding = 0) readonly buffer Points { FinePoint points[]; };
layout(std430, binding = 1) writeonly buffer Results { vec4 results[]; };

void main() {
  const uint i = gl_GlobalInvocationID.x;
  results[i] = drtvFine(points[i].position.xyz, normalize(points[i].normal.xyz));
}
