#pragma once
// Thread parallelism whose results do not depend on the thread count: loops whose
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
// The threads a pass over a world's bonds gets: one for a world of fewer than kParallelMin
// quanta, which then steps on the calling thread alone, as its quanta passes and bond partitions
// (BondPartition) do. A bond pass of its own in OpenMP would gain microseconds and leave the
// other threads spinning in the runtime between steps: a whole core busy for nothing.
inline int bond_pass_threads(std::size_t quanta, int threads) { return quanta < kParallelMin ? 1 : threads; }

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
// the calling thread when n < min_parallel or one thread is asked for, without entering the
// OpenMP runtime: a parallel region whose `if` clause is false still costs libgomp a futex call
// (about ten a step of a 10³ lattice, each a system call).
template <class Body>
void parallel_for(std::size_t n, int threads, Body&& body, std::size_t min_parallel = kParallelMin) {
  const auto m = static_cast<std::ptrdiff_t>(n);
#ifdef _OPENMP
  if (const int t = thread_count(threads); t > 1 && n >= min_parallel) {
#pragma omp parallel for schedule(static) num_threads(t)
    for (std::ptrdiff_t i = 0; i < m; ++i) body(static_cast<std::size_t>(i));
    return;
  }
#else
  (void)threads;
  (void)min_parallel;
#endif
  for (std::ptrdiff_t i = 0; i < m; ++i) body(static_cast<std::size_t>(i));
}

// body(begin, end) for consecutive ranges of [0, n) of kRange indices (the last shorter): for
// kernels that run a vector loop over a range of quanta, each range written by one thread.
inline constexpr std::size_t kRange = 1024;
template <class Body>
void parallel_ranges(std::size_t n, int threads, Body&& body) {
  parallel_for(
      (n + kRange - 1) / kRange, threads, [&](std::size_t r) { body(r * kRange, std::min(n, (r + 1) * kRange)); },
      kParallelMin / kRange);
}

// fold_chunk(begin, end) over the chunks of [0, n) (at least kSumChunk indices each, at most
// kMaxPartials of them: fixed by n), each chunk's result combined in chunk order,
// combine(combine(r0, r1), r2)...: the same result for any thread count, and no allocation.
// `init` when n = 0.
template <class T, class FoldChunk, class Combine>
T reduce_chunks(std::size_t n, int threads, const T& init, FoldChunk&& fold_chunk, Combine&& combine) {
  const std::size_t chunk = std::max(kSumChunk, (n + kMaxPartials - 1) / kMaxPartials);
  const std::size_t chunks = (n + chunk - 1) / chunk;
  std::array<T, kMaxPartials> partial;
  parallel_for(
      chunks, threads, [&](std::size_t c) { partial[c] = fold_chunk(c * chunk, std::min(n, (c + 1) * chunk)); },
      kParallelMin / kSumChunk);
  if (chunks == 0) return init;
  T total = partial[0];
  for (std::size_t c = 1; c < chunks; ++c) total = combine(total, partial[c]);
  return total;
}

// fold(acc, i) for i in [0, n), each chunk of reduce_chunks folded from `init` in index order.
template <class T, class Fold, class Combine>
T deterministic_reduce(std::size_t n, int threads, const T& init, Fold&& fold, Combine&& combine) {
  auto fold_chunk = [&](std::size_t begin, std::size_t end) {
    T acc = init;
    for (std::size_t i = begin; i < end; ++i) acc = fold(acc, i);
    return acc;
  };
  return reduce_chunks(n, threads, init, fold_chunk, combine);
}

// Σ term(i) for i in [0, n), summed in chunks (each in index order) whose size depends on n
// only, then the chunk sums in chunk order: the same bits for any thread count. Up to kSumChunk
// terms it is the plain left-to-right sum.
template <class Term>
double deterministic_sum(std::size_t n, int threads, Term&& term) {
  auto plus = [](double a, double b) { return a + b; };
  return deterministic_reduce(n, threads, 0.0, [&](double s, std::size_t i) { return s + term(i); }, plus);
}

}  // namespace qbond
