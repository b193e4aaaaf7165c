#pragma once
// EPMAP_HOT_LOOP marks a function whose loops carry a frame's per-pixel work. On x86-64 with
// GCC it is compiled twice, for the x86-64-v3 level (AVX2, FMA: 8 floats per instruction
// instead of SSE2's 4) and for the baseline, and the dynamic loader picks the one the CPU
// runs (GCC's target_clones, an ifunc): one binary for every x86-64 machine, the wide one where
// it can. Inline functions it calls are compiled into each copy. The wide copy may fuse a
// multiply and an add into one FMA instruction (one rounding instead of two): results can differ
// from the baseline copy's in the last bits (the EP benchmark's figures came out identical).
// Measured on the EP benchmark's head scenario: the generator ~12% faster (see
// perception/ep/README.md).
// Elsewhere (other compilers, other architectures) it is empty: the compiler's default target.

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__linux__)
#define EPMAP_HOT_LOOP __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define EPMAP_HOT_LOOP
#endif
