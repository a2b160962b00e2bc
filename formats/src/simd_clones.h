// The one list of instruction sets the engine's hot loops are compiled for, private to the
// libraries that use it (runtime, sweep and lpv name formats/src as a private include directory;
// src/ is not installed, so an engine never sees these macros).
//
// DRTV_SIMD_CLONES before a function compiles it three times, for x86-64-v4 (AVX-512), x86-64-v3
// (AVX2 and FMA) and the baseline, and GCC picks one at load time by what the CPU supports (GCC
// function multi-versioning, target_clones). DRTV_SIMD_MULTIVERSION is 1 where that happens:
// GCC on x86-64 only, not Clang, and not under the sanitizers, whose run-time is not up when
// the ifunc resolvers run. Elsewhere the macro is empty and the baseline's code is all there is.
//
// The same bits on every CPU: the clones do the same IEEE operations in the same order, unless
// GCC fuses a * b + c where FMA is enabled (the v3 and v4 clones). A file whose results must not
// depend on the CPU compiles with -ffp-contract=off (the sweep, the LPV: their CMakeLists.txt).
// The sweep and the LPV cloned for "avx2" (no FMA) before this list was shared: under
// -ffp-contract=off the v3 clone is the same arithmetic, and their pinned hashes did not change.
#pragma once

#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__) && !defined(__SANITIZE_ADDRESS__) && \
    !defined(__SANITIZE_THREAD__)
#define DRTV_SIMD_MULTIVERSION 1
#define DRTV_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define DRTV_SIMD_MULTIVERSION 0
#define DRTV_SIMD_CLONES
#endif
