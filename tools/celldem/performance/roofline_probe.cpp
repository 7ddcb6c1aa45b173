// The roofs of one core for tools/roofline.py (tools/celldem/performance/roofline.py compiles and runs this):
//   clock_ghz        a chain of dependent integer adds, one cycle each on any x86-64 core
//   fma_gflops       independent vector FMA chains (the widest the compiler may use), all lanes busy
//   div_glanes, sqrt_glanes  the same with vector divisions and square roots: lane-operations per ns (the
//                    divider is one slow, partly pipelined unit; the pair law needs several per pair)
//   triad_gbs SIZE   a[i] = b[i] + s c[i] over three arrays of SIZE bytes in all, STREAM's count of bytes
//                    (24 per element: the write-allocate read of a is not counted)
// Usage: roofline_probe TRIAD_BYTES...      (prints "key value" lines; best of several timings each)
#include <immintrin.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Ten dependent register-register adds per iteration: the loop's own counter and branch run beside them on
// other ports, so an iteration takes ten cycles whatever the clock. (Not `add $1`: recent Intel cores fold small
// immediate adds in the renamer, at no latency.) Best of 5 (the other job on the machine may interrupt one).
double clock_ghz() {
  const long iterations = 50'000'000;
  double best = 0.0;
  for (int repeat = 0; repeat < 5; ++repeat) {
    long x = 0, one = 1;
    asm volatile("" : "+r"(one));  // unknown to the compiler
    const auto t0 = Clock::now();
    for (long i = 0; i < iterations; ++i)
      asm volatile("add %1, %0\n\tadd %1, %0\n\tadd %1, %0\n\tadd %1, %0\n\tadd %1, %0\n\t"
                   "add %1, %0\n\tadd %1, %0\n\tadd %1, %0\n\tadd %1, %0\n\tadd %1, %0"
                   : "+r"(x)
                   : "r"(one));
    const double ghz = 10.0 * static_cast<double>(iterations) / seconds_since(t0) / 1e9;
    if (ghz > best) best = ghz;
  }
  return best;
}

#if defined(__AVX512F__)
using Vec = __m512d;
constexpr int kLanes = 8;
inline Vec splat(double x) { return _mm512_set1_pd(x); }
inline Vec fma(Vec a, Vec b, Vec c) { return _mm512_fmadd_pd(a, b, c); }
inline Vec div(Vec a, Vec b) { return _mm512_div_pd(a, b); }
inline Vec sqrt(Vec a) { return _mm512_sqrt_pd(a); }
inline double first_lane(Vec a) { return _mm512_cvtsd_f64(a); }
#elif defined(__AVX2__) && defined(__FMA__)
using Vec = __m256d;
constexpr int kLanes = 4;
inline Vec splat(double x) { return _mm256_set1_pd(x); }
inline Vec fma(Vec a, Vec b, Vec c) { return _mm256_fmadd_pd(a, b, c); }
inline Vec div(Vec a, Vec b) { return _mm256_div_pd(a, b); }
inline Vec sqrt(Vec a) { return _mm256_sqrt_pd(a); }
inline double first_lane(Vec a) { return _mm256_cvtsd_f64(a); }
#else
#define NO_FMA 1
#endif

#ifndef NO_FMA
// 16 independent chains of `op`: more than latency (4) x ports (2) needs to keep every FMA port busy, and enough
// to fill the divider's pipeline. Returns lane-operations per nanosecond; best of 3.
template <class Op>
double lane_rate(long iterations, Op op) {
  constexpr int kChains = 16;
  double best = 0.0, keep = 0.0;
  for (int repeat = 0; repeat < 3; ++repeat) {
    Vec acc[kChains];
    for (int k = 0; k < kChains; ++k) acc[k] = splat(1.0 + 1e-3 * k);
    const auto t0 = Clock::now();
    for (long i = 0; i < iterations; ++i) {
#pragma GCC unroll 16
      for (int k = 0; k < kChains; ++k) acc[k] = op(acc[k]);
    }
    const double s = seconds_since(t0);
    for (int k = 0; k < kChains; ++k) keep += first_lane(acc[k]);
    const double rate = static_cast<double>(kLanes) * kChains * static_cast<double>(iterations) / s / 1e9;
    if (rate > best) best = rate;
  }
  std::printf("checksum %.6g\n", keep);  // so that the chains are not optimised away
  return best;
}
#endif

// Repeats the triad in blocks of passes about 64 Mi elements long; the best block's rate.
double triad_gbs(std::size_t bytes) {
  const std::size_t n = bytes / (3 * sizeof(double));
  std::vector<double> a(n, 0.0), b(n, 1.0), c(n, 2.0);
  const double s = 3.0;
  const long passes = std::max<long>(1, (64L << 20) / static_cast<long>(n));
  double best = 0.0;
  for (int block = 0; block < 7; ++block) {
    const auto t0 = Clock::now();
    for (long p = 0; p < passes; ++p) {
      double* __restrict pa = a.data();
      const double* __restrict pb = b.data();
      const double* __restrict pc = c.data();
      for (std::size_t i = 0; i < n; ++i) pa[i] = pb[i] + s * pc[i];
      asm volatile("" : : "r"(pa) : "memory");  // every pass is done
    }
    const double gbs = 3.0 * sizeof(double) * static_cast<double>(n) * passes / seconds_since(t0) / 1e9;
    if (gbs > best) best = gbs;
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  std::printf("clock_ghz %.4f\n", clock_ghz());
#ifndef NO_FMA
  const Vec b = splat(0.999999), c = splat(1e-7);
  std::printf("fma_lanes %d\n", kLanes);
  std::printf("fma_gflops %.4f\n", 2.0 * lane_rate(20'000'000, [&](Vec a) { return fma(a, b, c); }));
  std::printf("div_glanes %.4f\n", lane_rate(1'000'000, [&](Vec a) { return div(a, b); }));
  std::printf("sqrt_glanes %.4f\n", lane_rate(1'000'000, [](Vec a) { return sqrt(a); }));
#endif
  for (int k = 1; k < argc; ++k) {
    const std::size_t bytes = std::strtoull(argv[k], nullptr, 10);
    std::printf("triad_gbs %zu %.4f\n", bytes, triad_gbs(bytes));
  }
  return 0;
}
