#include "solvers/block_matrix.hpp"

#include <algorithm>
#include <cassert>
#include <type_traits>

#include "core/parallel.hpp"
#include "core/simd.hpp"

namespace qbond {

namespace {

int thread_id() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}

// Row i of y = A x (or of r = b − A x), blocks R × C known at compile time where they are common.
template <int R, int C, bool kResidual>
void row_times(const BlockMatrix& A, const double* x, const double* b, double* y, std::size_t i) {
  double s[R] = {};
  for (Index k = A.offset[i]; k < A.offset[i + 1]; ++k) {
    const double* a = A.block(k);
    const double* xj = x + static_cast<std::size_t>(A.col[k]) * C;
    for (int r = 0; r < R; ++r)
      for (int c = 0; c < C; ++c) s[r] += a[r * C + c] * xj[c];
  }
  for (int r = 0; r < R; ++r) y[i * R + r] = kResidual ? b[i * R + r] - s[r] : s[r];
}

template <bool kResidual>
void row_times_any(const BlockMatrix& A, const double* x, const double* b, double* y, std::size_t i) {
  const int R = A.br, C = A.bc;
  double s[6] = {};
  for (Index k = A.offset[i]; k < A.offset[i + 1]; ++k) {
    const double* a = A.block(k);
    const double* xj = x + static_cast<std::size_t>(A.col[k]) * static_cast<std::size_t>(C);
    for (int r = 0; r < R; ++r)
      for (int c = 0; c < C; ++c) s[r] += a[r * C + c] * xj[c];
  }
  for (int r = 0; r < R; ++r)
    y[i * static_cast<std::size_t>(R) + static_cast<std::size_t>(r)] =
        kResidual ? b[i * static_cast<std::size_t>(R) + static_cast<std::size_t>(r)] - s[r] : s[r];
}

template <int R, int C, bool kResidual>
void rows_times(const BlockMatrix& A, const double* x, const double* b, double* y, int threads) {
  parallel_for(A.rows, threads, [&](std::size_t i) {
    if constexpr (R == 0)
      row_times_any<kResidual>(A, x, b, y, i);
    else
      row_times<R, C, kResidual>(A, x, b, y, i);
  });
}

template <bool kResidual>
void times(const BlockMatrix& A, const double* x, const double* b, double* y, int threads) {
  assert(A.br <= 6 && A.bc <= 6);
  if (A.br == 3 && A.bc == 3)
    rows_times<3, 3, kResidual>(A, x, b, y, threads);
  else if (A.br == 6 && A.bc == 6)
    rows_times<6, 6, kResidual>(A, x, b, y, threads);
  else if (A.br == 3 && A.bc == 6)
    rows_times<3, 6, kResidual>(A, x, b, y, threads);
  else if (A.br == 6 && A.bc == 3)
    rows_times<6, 3, kResidual>(A, x, b, y, threads);
  else
    rows_times<0, 0, kResidual>(A, x, b, y, threads);
}

// c += a b for an R × K block a and a K × C block b (each entry's sum in k's order: the vector
// clones give the same bits).
template <int R, int K, int C>
QBOND_VECTOR_INLINE void gemm_add(const double* __restrict a, const double* __restrict b, double* __restrict c) {
  for (int r = 0; r < R; ++r)
    for (int k = 0; k < K; ++k) {
      const double ark = a[r * K + k];
      QBOND_SIMD for (int j = 0; j < C; ++j) c[r * C + j] += ark * b[k * C + j];
    }
}
void gemm_add_any(const double* a, const double* b, double* c, int R, int K, int C) {
  for (int r = 0; r < R; ++r)
    for (int k = 0; k < K; ++k) {
      const double ark = a[r * K + k];
      for (int j = 0; j < C; ++j) c[r * C + j] += ark * b[k * C + j];
    }
}
// Block rows a thread takes at a time in the packed products: a vector-clone call each.
constexpr std::size_t kRowRange = 64;

// Row i of C += the products A_ik B_kj in A's row order, then B's, each into C's block at pos[j]
// (skipped where pos[j] is kNone: a column the row does not keep).
template <int R, int K, int Cc>
QBOND_VECTOR_INLINE void row_products(const BlockMatrix& A, const BlockMatrix& B, BlockMatrix& C, const Index* pos,
                                      std::size_t i) {
  for (Index k = A.offset[i]; k < A.offset[i + 1]; ++k) {
    const double* a = A.block(k);
    for (Index l = B.offset[A.col[k]]; l < B.offset[A.col[k] + 1]; ++l) {
      const Index p = pos[B.col[l]];
      if (p == kNone) continue;
      if constexpr (R == 0)
        gemm_add_any(a, B.block(l), C.block(p), A.br, A.bc, B.bc);
      else
        gemm_add<R, K, Cc>(a, B.block(l), C.block(p));
    }
  }
}

// The block sizes the hierarchy multiplies, compiled for the wide vector units (simd.hpp).
QBOND_VECTOR_CLONES void row_products_336(const BlockMatrix& A, const BlockMatrix& B, BlockMatrix& C,
                                          const Index* pos, std::size_t i) {
  row_products<3, 3, 6>(A, B, C, pos, i);
}
QBOND_VECTOR_CLONES void row_products_636(const BlockMatrix& A, const BlockMatrix& B, BlockMatrix& C,
                                          const Index* pos, std::size_t i) {
  row_products<6, 3, 6>(A, B, C, pos, i);
}
QBOND_VECTOR_CLONES void row_products_666(const BlockMatrix& A, const BlockMatrix& B, BlockMatrix& C,
                                          const Index* pos, std::size_t i) {
  row_products<6, 6, 6>(A, B, C, pos, i);
}

// C's columns and values, its row offsets counted (multiply): row i's columns gathered (with
// `upper` only those ≥ i), sorted, then each product A_ik B_kj added in A's row order, then B's.
void numeric_product(const BlockMatrix& A, const BlockMatrix& B, BlockMatrix& C, bool upper,
                     std::vector<std::vector<Index>>& mark, int threads) {
  auto kernel = [&]() -> void (*)(const BlockMatrix&, const BlockMatrix&, BlockMatrix&, const Index*, std::size_t) {
    if (A.br == 3 && A.bc == 3 && B.bc == 6) return row_products_336;
    if (A.br == 6 && A.bc == 3 && B.bc == 6) return row_products_636;
    if (A.br == 6 && A.bc == 6 && B.bc == 6) return row_products_666;
    if (A.br == 3 && A.bc == 3 && B.bc == 3) return row_products<3, 3, 3>;
    return row_products<0, 0, 0>;
  }();
  parallel_for(A.rows, threads, [&](std::size_t i) {
    std::vector<Index>& m = mark[static_cast<std::size_t>(thread_id())];
    Index p = C.offset[i];
    for (Index k = A.offset[i]; k < A.offset[i + 1]; ++k)
      for (Index l = B.offset[A.col[k]]; l < B.offset[A.col[k] + 1]; ++l)
        if (const Index j = B.col[l]; m[j] != i && (!upper || j >= i)) {
          m[j] = static_cast<Index>(i);
          C.col[p++] = j;
        }
    std::sort(C.col.begin() + C.offset[i], C.col.begin() + C.offset[i + 1]);
    // m maps the row's columns to their positions while it is summed, then is cleared.
    for (Index q = C.offset[i]; q < C.offset[i + 1]; ++q) m[C.col[q]] = q;
    kernel(A, B, C, m.data(), i);
    for (Index q = C.offset[i]; q < C.offset[i + 1]; ++q) m[C.col[q]] = kNone;
  });
}

// What a packed product does with A x.
constexpr int kStore = 0, kSubtract = 1, kAdd = 2;

// Rows [lo, hi) of y = A x (kStore), r = b − A x (kSubtract) or y += A x (kAdd) for a packed
// matrix: E stored entries a block, column-major when it has six rows. A general block's product keeps one partial sum per block
// entry, a_e x_c(e) added over the row's blocks in order, then sums each row's partials over the
// columns in order: a vector loop whose additions chain only from block to block, not through a
// block's columns (the same bits in every clone).
template <class T, int R, int C, bool kSym, int kMode>
QBOND_VECTOR_INLINE void packed_range(const PackedMatrix<T>& A, const double* x, const double* b, double* y,
                                      std::size_t lo, std::size_t hi) {
  constexpr int E = kSym ? 6 : R * C;
  for (std::size_t i = lo; i < hi; ++i) {
    double s[R] = {};
    const T* a = A.val.data() + static_cast<std::size_t>(A.offset[i]) * E;
    if constexpr (kSym) {
      for (Index k = A.offset[i]; k < A.offset[i + 1]; ++k, a += E) {
        const double* xj = x + static_cast<std::size_t>(A.col[k]) * C;
        const double a0 = a[0], a1 = a[1], a2 = a[2], a3 = a[3], a4 = a[4], a5 = a[5];
        s[0] += a0 * xj[0] + a3 * xj[1] + a4 * xj[2];
        s[1] += a3 * xj[0] + a1 * xj[1] + a5 * xj[2];
        s[2] += a4 * xj[0] + a5 * xj[1] + a2 * xj[2];
      }
    } else {
      double part[E] = {};
      for (Index k = A.offset[i]; k < A.offset[i + 1]; ++k, a += E) {
        const double* xj = x + static_cast<std::size_t>(A.col[k]) * C;
        if constexpr (R == 6) {  // column-major
          for (int c = 0; c < C; ++c) {
            const double xc = xj[c];
            QBOND_SIMD for (int r = 0; r < R; ++r) part[c * R + r] += static_cast<double>(a[c * R + r]) * xc;
          }
        } else {
          for (int r = 0; r < R; ++r)
            QBOND_SIMD for (int c = 0; c < C; ++c) part[r * C + c] += static_cast<double>(a[r * C + c]) * xj[c];
        }
      }
      for (int r = 0; r < R; ++r)
        for (int c = 0; c < C; ++c) s[r] += R == 6 ? part[c * R + r] : part[r * C + c];
    }
    for (int r = 0; r < R; ++r) {
      if constexpr (kMode == kSubtract)
        y[i * R + r] = b[i * R + r] - s[r];
      else if constexpr (kMode == kAdd)
        y[i * R + r] += s[r];
      else
        y[i * R + r] = s[r];
    }
  }
}

// The hierarchy's float products, compiled for the wide vector units (simd.hpp).
template <int R, int C, int kMode>
QBOND_TEMPLATE_CLONES void float_range(const PackedMatrix<float>& A, const double* x, const double* b, double* y,
                                     std::size_t lo, std::size_t hi) {
  packed_range<float, R, C, false, kMode>(A, x, b, y, lo, hi);
}

template <class T, int R, int C, bool kSym, int kMode>
void packed_rows(const PackedMatrix<T>& A, const double* x, const double* b, double* y, int threads) {
  parallel_for(
      (A.rows + kRowRange - 1) / kRowRange, threads,
      [&](std::size_t g) {
        const std::size_t lo = g * kRowRange, hi = std::min<std::size_t>(A.rows, lo + kRowRange);
        if constexpr (std::is_same_v<T, float> && !kSym)
          float_range<R, C, kMode>(A, x, b, y, lo, hi);
        else
          packed_range<T, R, C, kSym, kMode>(A, x, b, y, lo, hi);
      },
      1);
}

template <class T, int kMode>
void packed_times(const PackedMatrix<T>& A, const double* x, const double* b, double* y, int threads) {
  if (A.symmetric)
    packed_rows<T, 3, 3, true, kMode>(A, x, b, y, threads);
  else if (A.br == 3 && A.bc == 3)
    packed_rows<T, 3, 3, false, kMode>(A, x, b, y, threads);
  else if (A.br == 6 && A.bc == 6)
    packed_rows<T, 6, 6, false, kMode>(A, x, b, y, threads);
  else if (A.br == 3 && A.bc == 6)
    packed_rows<T, 3, 6, false, kMode>(A, x, b, y, threads);
  else {
    assert(A.br == 6 && A.bc == 3);
    packed_rows<T, 6, 3, false, kMode>(A, x, b, y, threads);
  }
}

}  // namespace

template <class T>
void pack(const BlockMatrix& A, bool symmetric, PackedMatrix<T>& out, int threads) {
  assert(!symmetric || (A.br == 3 && A.bc == 3));
  out.br = A.br;
  out.bc = A.bc;
  out.rows = A.rows;
  out.cols = A.cols;
  out.symmetric = symmetric;
  out.offset = A.offset;
  out.col = A.col;
  const std::size_t e = symmetric ? 6 : A.block_size();
  out.val.resize(A.blocks() * e);
  constexpr int kEntry[6] = {0, 4, 8, 1, 2, 5};  // xx, yy, zz, xy, xz, yz of a row-major 3×3
  parallel_for(A.rows, threads, [&](std::size_t i) {
    for (Index k = A.offset[i]; k < A.offset[i + 1]; ++k) {
      const double* a = A.block(k);
      T* o = out.val.data() + k * e;
      if (symmetric)
        for (std::size_t m = 0; m < e; ++m) o[m] = static_cast<T>(a[kEntry[m]]);
      else if (A.br != 6)
        for (std::size_t m = 0; m < e; ++m) o[m] = static_cast<T>(a[m]);
      else  // column-major (packed_range)
        for (int r = 0; r < A.br; ++r)
          for (int c = 0; c < A.bc; ++c) o[c * A.br + r] = static_cast<T>(a[r * A.bc + c]);
    }
  });
}

template <class T>
void multiply(const PackedMatrix<T>& A, const double* x, double* y, int threads) {
  packed_times<T, kStore>(A, x, nullptr, y, threads);
}
template <class T>
void residual(const PackedMatrix<T>& A, const double* b, const double* x, double* r, int threads) {
  packed_times<T, kSubtract>(A, x, b, r, threads);
}
template <class T>
void multiply_add(const PackedMatrix<T>& A, const double* x, double* y, int threads) {
  packed_times<T, kAdd>(A, x, nullptr, y, threads);
}

template void pack(const BlockMatrix&, bool, PackedMatrix<float>&, int);
template void pack(const BlockMatrix&, bool, PackedMatrix<double>&, int);
template void multiply(const PackedMatrix<float>&, const double*, double*, int);
template void multiply(const PackedMatrix<double>&, const double*, double*, int);
template void residual(const PackedMatrix<float>&, const double*, const double*, double*, int);
template void residual(const PackedMatrix<double>&, const double*, const double*, double*, int);
template void multiply_add(const PackedMatrix<float>&, const double*, double*, int);
template void multiply_add(const PackedMatrix<double>&, const double*, double*, int);

std::size_t BlockMatrix::find(Index i, Index j) const {
  const auto first = col.begin() + offset[i], last = col.begin() + offset[i + 1];
  const auto it = std::lower_bound(first, last, j);
  return it != last && *it == j ? static_cast<std::size_t>(it - col.begin()) : blocks();
}

void multiply(const BlockMatrix& A, const double* x, double* y, int threads) {
  times<false>(A, x, nullptr, y, threads);
}

void residual(const BlockMatrix& A, const double* b, const double* x, double* r, int threads) {
  times<true>(A, x, b, r, threads);
}

void transpose(const BlockMatrix& A, BlockMatrix& At) {
  At.br = A.bc;
  At.bc = A.br;
  At.rows = A.cols;
  At.cols = A.rows;
  At.offset.assign(static_cast<std::size_t>(A.cols) + 1, 0);
  for (const Index j : A.col) ++At.offset[j + 1];
  for (Index j = 0; j < A.cols; ++j) At.offset[j + 1] += At.offset[j];
  At.col.resize(A.blocks());
  At.val.resize(A.val.size());
  std::vector<Index> next(At.offset.begin(), At.offset.end() - 1);
  const int R = A.br, C = A.bc;
  for (Index i = 0; i < A.rows; ++i)
    for (Index k = A.offset[i]; k < A.offset[i + 1]; ++k) {
      const Index p = next[A.col[k]]++;
      At.col[p] = i;
      const double* a = A.block(k);
      double* t = At.block(p);
      for (int r = 0; r < R; ++r)
        for (int c = 0; c < C; ++c) t[c * R + r] = a[r * C + c];
    }
}

void multiply(const BlockMatrix& A, const BlockMatrix& B, BlockMatrix& C, int threads, bool upper) {
  assert(A.bc == B.br && A.cols == B.rows);
  C.br = A.br;
  C.bc = B.bc;
  C.rows = A.rows;
  C.cols = B.cols;
  const int nt = thread_count(threads);
  // Per thread: the last row that saw each block column (symbolic pass), then where it sits in
  // the row being summed (numeric pass).
  std::vector<std::vector<Index>> mark(static_cast<std::size_t>(nt));
  for (auto& m : mark) m.assign(B.cols, kNone);
  std::vector<Index> count(A.rows);
  parallel_for(A.rows, threads, [&](std::size_t i) {
    std::vector<Index>& m = mark[static_cast<std::size_t>(thread_id())];
    Index c = 0;
    for (Index k = A.offset[i]; k < A.offset[i + 1]; ++k)
      for (Index l = B.offset[A.col[k]]; l < B.offset[A.col[k] + 1]; ++l)
        if (const Index j = B.col[l]; m[j] != i && (!upper || j >= i)) {
          m[j] = static_cast<Index>(i);
          ++c;
        }
    count[i] = c;
  });
  C.offset.assign(static_cast<std::size_t>(A.rows) + 1, 0);
  for (Index i = 0; i < A.rows; ++i) C.offset[i + 1] = C.offset[i] + count[i];
  C.col.resize(C.offset.back());
  C.val.assign(C.blocks() * C.block_size(), 0.0);
  for (auto& m : mark) std::fill(m.begin(), m.end(), kNone);
  numeric_product(A, B, C, upper, mark, threads);
}

void symmetric_from_upper(const BlockMatrix& U, BlockMatrix& S) {
  assert(U.rows == U.cols && U.br == U.bc);
  BlockMatrix L;
  transpose(U, L);  // row i: the blocks (k, i) of U, k ≤ i, transposed
  const std::size_t bs = U.block_size();
  S.br = S.bc = U.br;
  S.rows = S.cols = U.rows;
  S.offset.assign(static_cast<std::size_t>(U.rows) + 1, 0);
  S.col.clear();
  S.val.clear();
  S.col.reserve(2 * U.blocks());
  S.val.reserve(2 * U.val.size());
  for (Index i = 0; i < U.rows; ++i) {
    for (Index k = L.offset[i]; k < L.offset[i + 1] && L.col[k] < i; ++k) {
      S.col.push_back(L.col[k]);
      S.val.insert(S.val.end(), L.block(k), L.block(k) + bs);
    }
    for (Index k = U.offset[i]; k < U.offset[i + 1]; ++k) {
      S.col.push_back(U.col[k]);
      S.val.insert(S.val.end(), U.block(k), U.block(k) + bs);
    }
    S.offset[i + 1] = static_cast<Index>(S.col.size());
  }
}

}  // namespace qbond
