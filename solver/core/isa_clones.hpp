#pragma once
// CELLDEM_ISA_CLONES before a hot function compiles it for AVX-512, AVX2 and the baseline, chosen at load
// time. Every clone is the same source built with no contraction or reassociation (CMakeLists.txt), so all
// give the same bits. Under the sanitizers, and off x86-64, only the baseline: the clones are the same
// source, and three instrumented copies of every law made the sanitizer build's slowest file take minutes
// (and clang 14 has no target_clones on templates).
#include "core/sanitizers.hpp"

#if defined(CELLDEM_SANITIZED) || !defined(__x86_64__)
#define CELLDEM_ISA_CLONES
#else
#define CELLDEM_ISA_CLONES [[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#endif

// CELLDEM_SIMD(clauses) before a loop asks for it in SIMD lanes (`omp simd clauses`: a reduction named there may
// run in any order, so only an order-free one such as a maximum belongs there). Under the sanitizers the pragma
// is left out: clang could not vectorise these loops there and reports that as an error with -Werror (the
// compiler may still vectorise them on its own; the bits are the same either way).
#define CELLDEM_PRAGMA(text) _Pragma(#text)
#if defined(CELLDEM_SANITIZED)
#define CELLDEM_SIMD(clauses)
#else
#define CELLDEM_SIMD(clauses) CELLDEM_PRAGMA(omp simd clauses)
#endif
