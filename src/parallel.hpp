#pragma once
// Thread parallelism whose results do not depend on the thread count (DESIGN §13): loops whose
// iterations write disjoint data, and sums over fixed chunks added in chunk order. Any thread
// count, including one, gives the same bits.
#include <algorithm>
#include <array>
#include <cstddef>
#ifdef _OPENMP
#include <omp.h>
#endif

namespace qbond {

// Below this many iterations a loop runs on the calling thread (starting threads costs more).
inline constexpr std::size_t kParallelMin = 4096;
// Partial sums of deterministic_sum: each adds at least kSumChunk terms, and there are at most
// kMaxPartials of them (so they live on the stack). Both depend on the term count only.
inline constexpr std::size_t kSumChunk = 1024;
inline constexpr std::size_t kMaxPartials = 256;

// Threads a parallel region gets: `threads` > 0 as asked, 0 for OpenMP's default.
inline int thread_count(int threads) {
#ifdef _OPENMP
  return threads > 0 ? threads : omp_get_max_threads();
#else
  (void)threads;
  return 1;
#endif
}

// body(i) for i in [0, n); iterations must only write data no other iteration touches. Runs on
// the calling thread when n < min_parallel.
template <class Body>
void parallel_for(std::size_t n, int threads, Body&& body, std::size_t min_parallel = kParallelMin) {
  const auto m = static_cast<std::ptrdiff_t>(n);
#ifdef _OPENMP
  const int t = thread_count(threads);
#pragma omp parallel for schedule(static) num_threads(t) if (t > 1 && n >= min_parallel)
  for (std::ptrdiff_t i = 0; i < m; ++i) body(static_cast<std::size_t>(i));
#else
  (void)threads;
  (void)min_parallel;
  for (std::ptrdiff_t i = 0; i < m; ++i) body(static_cast<std::size_t>(i));
#endif
}

// Σ term(i) for i in [0, n), summed in chunks (each in index order) whose size depends on n
// only, then the chunk sums in chunk order: the same bits for any thread count, and no
// allocation. Up to kSumChunk terms it is the plain left-to-right sum.
template <class Term>
double deterministic_sum(std::size_t n, int threads, Term&& term) {
  const std::size_t chunk = std::max(kSumChunk, (n + kMaxPartials - 1) / kMaxPartials);
  auto chunk_sum = [&](std::size_t c) {
    double s = 0;
    const std::size_t end = std::min(n, (c + 1) * chunk);
    for (std::size_t i = c * chunk; i < end; ++i) s += term(i);
    return s;
  };
  const std::size_t chunks = (n + chunk - 1) / chunk;
  if (chunks <= 1) return chunks == 1 ? chunk_sum(0) : 0.0;
  std::array<double, kMaxPartials> partial;
  parallel_for(chunks, threads, [&](std::size_t c) { partial[c] = chunk_sum(c); }, kParallelMin / kSumChunk);
  double s = 0;
  for (std::size_t c = 0; c < chunks; ++c) s += partial[c];
  return s;
}

}  // namespace qbond
