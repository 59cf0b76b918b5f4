#pragma once
// QBOND_VECTOR_CLONES compiles a function three times, for the baseline x86-64 (SSE2) and for
// x86-64-v3 (AVX2, FMA) and x86-64-v4 (AVX-512), and the loader picks the widest the CPU has (GCC
// and Clang function multiversioning, an ifunc). The bond kernels' vectorised loops then use the
// wide registers where they exist while the build stays portable: no -march=native.
// The build turns off fused multiply-adds (-ffp-contract=off, CMakeLists.txt), so every clone
// rounds as the baseline code does: the same bits on any CPU and for any thread count.
// QBOND_VECTOR_INLINE marks the helpers such a function calls: inlined into each clone, they are
// compiled for its instruction set (called, they would run the baseline code); QBOND_LAMBDA_INLINE
// does the same for a lambda (after its parameter list).
// With QBOND_NO_CLONES (CMake's QBOND_ARCH) the functions are compiled once, for the build's
// -march: scripts/test --sanitize builds for x86-64-v3 so that the suite also runs the AVX2 code
// (the Release run takes the clone the CPU picks, AVX-512 where it exists).
#if defined(__x86_64__) && defined(__ELF__) && (defined(__GNUC__) || defined(__clang__)) && !defined(QBOND_NO_CLONES)
#define QBOND_VECTOR_CLONES __attribute__((target_clones("default", "arch=x86-64-v3", "arch=x86-64-v4")))
#define QBOND_VECTOR_INLINE inline __attribute__((always_inline))
#define QBOND_LAMBDA_INLINE __attribute__((always_inline))
#else
#define QBOND_VECTOR_CLONES
#define QBOND_VECTOR_INLINE inline
#define QBOND_LAMBDA_INLINE
#endif
// Function templates: clang (14) cannot multiversion them, so there they take the baseline code.
#if defined(__clang__)
#define QBOND_TEMPLATE_CLONES
#else
#define QBOND_TEMPLATE_CLONES QBOND_VECTOR_CLONES
#endif

// QBOND_SIMD before a loop whose iterations are independent: lets the compiler vectorise it
// without proving that its gathers and stores do not alias (OpenMP's simd; nothing without
// OpenMP).
// QBOND_SIMD_OR(x): the same for a loop that also ORs into x; QBOND_SIMD_SUM(x): that adds into x
// (in any order: only for sums whose order does not matter); QBOND_SIMD_SAFELEN(n): for a loop
// whose iterations depend only on iterations at least n earlier (at most n run together).
// QBOND_UNROLL(n) before a loop of n iterations: unrolled before the enclosing loop is vectorised.
// In such a loop, a select tests its condition itself (inv_mass[q] != 0 ? a : b) rather than a
// bool the enclosing loop computed: GCC 12 leaves verlet_stage, start_build and first_residual
// scalar in every clone with the bool, and vectorises them without it. A value a select picks
// is loaded before the select, not in it (a load under the test stays a branch).
#define QBOND_STRINGIFY(s) #s
#ifdef _OPENMP
#define QBOND_SIMD _Pragma("omp simd")
#define QBOND_SIMD_OR(x) _Pragma(QBOND_STRINGIFY(omp simd reduction(| : x)))
#define QBOND_SIMD_SUM(x) _Pragma(QBOND_STRINGIFY(omp simd reduction(+ : x)))
#define QBOND_SIMD_SAFELEN(n) _Pragma(QBOND_STRINGIFY(omp simd safelen(n)))
#else
#define QBOND_SIMD
#define QBOND_SIMD_OR(x)
#define QBOND_SIMD_SUM(x)
#define QBOND_SIMD_SAFELEN(n)
#endif
#if defined(__clang__)
#define QBOND_UNROLL(n) _Pragma(QBOND_STRINGIFY(unroll n))
#elif defined(__GNUC__)
#define QBOND_UNROLL(n) _Pragma(QBOND_STRINGIFY(GCC unroll n))
#else
#define QBOND_UNROLL(n)
#endif
