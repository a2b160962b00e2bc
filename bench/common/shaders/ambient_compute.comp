// ambient_compute.comp — a compute entry point that runs runtime/shaders/ambient.glsl's
// drtvAmbient over a list of points, for the tests (tests/runtime/shader_run_test.cpp). It is linked
// with the production file as a second compilation unit, so the function under test is the
// production text itself, not a copy:
//   glslangValidator -V -S comp -DDRTV_AMBIENT_NO_ENTRY runtime/shaders/ambient.glsl
//     bench/common/shaders/ambient_compute.comp -o ambient_compute.spv      (one line)
// Bindings 0-3 are ambient.glsl's (three volumes, VolumeConstants); 4 and 5 are the points in
// and the results out. The dispatch covers the points in whole workgroups of 64; the caller pads.
#version 450

layout(local_size_x = 64) in;

vec3 drtvAmbient(vec3 posWS, vec3 normalWS);  // defined in runtime/shaders/ambient.glsl

struct AmbientPoint {
  vec4 position;  // xyz: world position (the frame SnappedCamera is given in), w unused
  vec4 normal;    // xyz: surface normal (normalised here, as the fragment entry does), w unused
};
layout(std430, binding = 4) readonly buffer Points { AmbientPoint points[]; };
layout(std430, binding = 5) writeonly buffer Results { vec4 results[]; };

void main() {
  const uint i = gl_GlobalInvocationID.x;
  results[i] = vec4(drtvAmbient(points[i].position.xyz, normalize(points[i].normal.xyz)), 1.0);
}
