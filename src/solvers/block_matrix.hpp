#pragma once
// A sparse matrix of small dense blocks (block compressed rows), the storage of the multigrid
// hierarchy (multigrid.hpp): the implicit step's matrix with 3×3 blocks, prolongators with 3×6 or
// 6×6 blocks, coarse operators with 6×6 blocks. Every operation computes each block row on one
// thread in a fixed order, so the results are the same bits for any thread count.
#include <cstddef>
#include <vector>

#include "qbond/core/math.hpp"

namespace qbond {

/// rows × cols blocks of br × bc entries each; block row i's blocks are [offset[i], offset[i+1]),
/// their block columns `col` in increasing order, their entries in `val` row-major, br·bc a block.
struct BlockMatrix {
  int br = 3, bc = 3;
  Index rows = 0, cols = 0;
  std::vector<Index> offset{0};
  std::vector<Index> col;
  std::vector<double> val;

  std::size_t blocks() const { return col.size(); }
  std::size_t block_size() const { return static_cast<std::size_t>(br) * static_cast<std::size_t>(bc); }
  double* block(std::size_t k) { return val.data() + k * block_size(); }
  const double* block(std::size_t k) const { return val.data() + k * block_size(); }
  /// The position of block (i, j) in col/val, or blocks() when it is not stored.
  std::size_t find(Index i, Index j) const;
};

/// A BlockMatrix's values in precision T for the passes that only read them (the multigrid cycle
/// reads its matrices in float, half the bytes; a preconditioner needs no more digits), each block
/// row-major, or column-major when it has six rows (its product a vector loop over them), or with `symmetric` its 3×3 blocks,
/// each symmetric, as their six distinct entries (xx, yy, zz, xy, xz, yz): two thirds of the
/// bytes again.
template <class T>
struct PackedMatrix {
  int br = 3, bc = 3;
  Index rows = 0, cols = 0;
  bool symmetric = false;
  std::vector<Index> offset{0};
  std::vector<Index> col;
  std::vector<T> val;
};

/// out = A in precision T (symmetric: A's blocks are 3×3 and each symmetric).
template <class T>
void pack(const BlockMatrix& A, bool symmetric, PackedMatrix<T>& out, int threads);

/// y = A x and r = b − A x for a packed matrix.
template <class T>
void multiply(const PackedMatrix<T>& A, const double* x, double* y, int threads);
template <class T>
void residual(const PackedMatrix<T>& A, const double* b, const double* x, double* r, int threads);
/// y += A x for a packed matrix (each entry y_k + (A x)_k: the bits of y = y + t, t = A x).
template <class T>
void multiply_add(const PackedMatrix<T>& A, const double* x, double* y, int threads);

/// y = A x (x of A.cols·bc entries, y of A.rows·br).
void multiply(const BlockMatrix& A, const double* x, double* y, int threads);

/// r = b − A x.
void residual(const BlockMatrix& A, const double* b, const double* x, double* r, int threads);

/// Aᵀ, its blocks transposed.
void transpose(const BlockMatrix& A, BlockMatrix& At);

/// C = A B (A.bc = B.br, A.cols = B.rows): each row of C in increasing block column, each block the
/// sum over A's row in its order of A_ik B_kj. With `upper`, only C's blocks on and above the block
/// diagonal (j ≥ i): half the work of a product known to be symmetric.
void multiply(const BlockMatrix& A, const BlockMatrix& B, BlockMatrix& C, int threads, bool upper = false);

/// S = U + Uᵀ − diag(U) for U holding the blocks on and above the block diagonal of a symmetric S:
/// its blocks below the diagonal are U's above it, transposed.
void symmetric_from_upper(const BlockMatrix& U, BlockMatrix& S);

}  // namespace qbond
