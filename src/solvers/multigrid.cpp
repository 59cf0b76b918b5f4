#include "solvers/multigrid.hpp"

#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"
#include "core/simd.hpp"

namespace qbond {

namespace {

constexpr std::size_t kMaxLevels = 12;

// Σ a_k b_k over [0, n), in fixed chunks (parallel.hpp).
double dot(std::size_t n, const double* a, const double* b, int threads) {
  return deterministic_sum(n, threads, [&](std::size_t k) { return a[k] * b[k]; });
}

// What block_scale also does with out: nothing, x = out, or x += out.
enum class AlsoX { none, set, add };

// out_i = s · Dinv_i v_i for block rows [lo, hi) (B × B blocks, symmetric: read by columns, a
// vector loop over the block's rows), and x_i set to it or added to it in the same pass.
template <int B, AlsoX kX>
QBOND_TEMPLATE_CLONES void block_scale_range(const double* Dinv, const double* v, double s, double* out, double* x,
                                           std::size_t lo, std::size_t hi) {
  for (std::size_t i = lo; i < hi; ++i) {
    const double* D = Dinv + i * B * B;
    const double* vi = v + i * B;
    double t[B] = {};
    for (int c = 0; c < B; ++c) {
      const double vc = vi[c];
      QBOND_SIMD for (int r = 0; r < B; ++r) t[r] += D[c * B + r] * vc;
    }
    QBOND_SIMD for (int r = 0; r < B; ++r) {
      const double o = s * t[r];
      out[i * B + r] = o;
      if constexpr (kX == AlsoX::set) x[i * B + r] = o;
      if constexpr (kX == AlsoX::add) x[i * B + r] += o;
    }
  }
}

// out_i = s · Dinv_i v_i for every block row i (bs × bs blocks), x as kX says.
template <AlsoX kX = AlsoX::none>
void block_scale(const std::vector<double>& Dinv, int bs, Index rows, const double* v, double s, double* out,
                 int threads, double* x = nullptr) {
  constexpr std::size_t kRange = 256;
  parallel_for(
      (rows + kRange - 1) / kRange, threads,
      [&](std::size_t g) {
        const std::size_t lo = g * kRange, hi = std::min<std::size_t>(rows, lo + kRange);
        if (bs == 3)
          block_scale_range<3, kX>(Dinv.data(), v, s, out, x, lo, hi);
        else
          block_scale_range<6, kX>(Dinv.data(), v, s, out, x, lo, hi);
      },
      1);
}

// One Chebyshev step on block rows [lo, hi) in one pass: r_i = r0_i − t_i (r0 may be r),
// d_i = c1 d_i + c2 Dinv_i r_i, x_i += d_i.
template <int B>
QBOND_TEMPLATE_CLONES void chebyshev_step_range(const double* Dinv, const double* r0, const double* t, double c1,
                                              double c2, double* r, double* d, double* x, std::size_t lo,
                                              std::size_t hi) {
  for (std::size_t i = lo; i < hi; ++i) {
    const double* D = Dinv + i * B * B;
    double ri[B], u[B] = {};
    QBOND_SIMD for (int k = 0; k < B; ++k) {
      ri[k] = r0[i * B + k] - t[i * B + k];
      r[i * B + k] = ri[k];
    }
    for (int c = 0; c < B; ++c) {
      const double rc = ri[c];
      QBOND_SIMD for (int k = 0; k < B; ++k) u[k] += D[c * B + k] * rc;
    }
    QBOND_SIMD for (int k = 0; k < B; ++k) {
      d[i * B + k] = c1 * d[i * B + k] + c2 * u[k];
      x[i * B + k] += d[i * B + k];
    }
  }
}

void chebyshev_step(const std::vector<double>& Dinv, int bs, Index rows, const double* r0, const double* t,
                    double c1, double c2, double* r, double* d, double* x, int threads) {
  constexpr std::size_t kRange = 256;
  parallel_for(
      (rows + kRange - 1) / kRange, threads,
      [&](std::size_t g) {
        const std::size_t lo = g * kRange, hi = std::min<std::size_t>(rows, lo + kRange);
        if (bs == 3)
          chebyshev_step_range<3>(Dinv.data(), r0, t, c1, c2, r, d, x, lo, hi);
        else
          chebyshev_step_range<6>(Dinv.data(), r0, t, c1, c2, r, d, x, lo, hi);
      },
      1);
}

template <int N>
void invert_block(const double* a, double* out) {
  using M = Eigen::Matrix<double, N, N, Eigen::RowMajor>;
  Eigen::Map<M> inv(out);
  inv = Eigen::Map<const M>(a).inverse();
}

}  // namespace

std::vector<std::size_t> Multigrid::unknowns() const {
  std::vector<std::size_t> u;
  for (const Level& L : levels_)
    u.push_back(static_cast<std::size_t>(L.A.rows) * static_cast<std::size_t>(L.A.br));
  return u;
}

void Multigrid::smoother(Level& L, bool symmetric, int threads) {
  const int bs = L.A.br;
  const auto b = static_cast<std::size_t>(bs);
  const std::size_t n = static_cast<std::size_t>(L.A.rows) * b;
  L.Dinv.assign(static_cast<std::size_t>(L.A.rows) * b * b, 0.0);
  parallel_for(L.A.rows, threads, [&](std::size_t i) {
    const std::size_t k = L.A.find(static_cast<Index>(i), static_cast<Index>(i));
    double* out = L.Dinv.data() + i * b * b;
    if (bs == 3)
      invert_block<3>(L.A.block(k), out);
    else
      invert_block<6>(L.A.block(k), out);
  });
  for (std::vector<double>* v : {&L.x, &L.b, &L.r, &L.d, &L.t}) v->assign(n, 0.0);
  // λ_max(D⁻¹A) by power iteration from a fixed start with every frequency in it, on A as the
  // cycle reads it.
  const std::size_t l = static_cast<std::size_t>(&L - levels_.data());
  if (l == 0 && fine_op_)
    L.Af = PackedMatrix<float>{};
  else
    pack(L.A, symmetric, L.Af, threads);
  std::vector<double>& v = L.d;
  for (std::size_t k = 0; k < n; ++k) v[k] = static_cast<double>((k * 2654435761u) % 1000u) / 1000.0 - 0.5;
  double lambda = 1;
  for (int it = 0; it < 10; ++it) {
    level_multiply(l, v.data(), L.t.data(), threads);
    block_scale(L.Dinv, bs, L.A.rows, L.t.data(), 1.0, L.r.data(), threads);
    const double vv = dot(n, v.data(), v.data(), threads), ww = dot(n, L.r.data(), L.r.data(), threads);
    if (!(vv > 0) || !(ww > 0)) break;
    lambda = std::sqrt(ww / vv);
    const double s = 1 / std::sqrt(ww);
    parallel_for(n, threads, [&](std::size_t k) { v[k] = s * L.r[k]; });
  }
  L.lambda = lambda;
}

void Multigrid::set_fine_diagonal(std::size_t row, const double* block) {
  invert_block<3>(block, levels_[0].Dinv.data() + 9 * row);
}

void Multigrid::galerkin(std::size_t l, int threads) {
  Level& L = levels_[l];
  multiply(L.A, L.P, L.AP, threads);
  // Pᵀ A P is symmetric: its upper blocks are formed, the lower ones copied from them.
  BlockMatrix upper;
  multiply(L.R, L.AP, upper, threads, /*upper=*/true);
  L.AP = BlockMatrix{};  // as large as P and more: not kept
  symmetric_from_upper(upper, levels_[l + 1].A);
  // A coarse unknown that P does not reach (a rigid mode its aggregate cannot carry) has a zero row
  // and column: a unit diagonal makes the operator definite without coupling it to anything.
  BlockMatrix& C = levels_[l + 1].A;
  for (Index i = 0; i < C.rows; ++i) {
    double* d = C.block(C.find(i, i));
    for (int c = 0; c < C.br; ++c)
      if (d[c * C.bc + c] == 0) d[c * C.bc + c] = 1;
  }
}

void Multigrid::factor_coarsest() {
  const BlockMatrix& A = levels_.back().A;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(A.val.size());
  for (Index i = 0; i < A.rows; ++i)
    for (Index k = A.offset[i]; k < A.offset[i + 1]; ++k)
      for (int r = 0; r < A.br; ++r)
        for (int c = 0; c < A.bc; ++c)
          t.emplace_back(static_cast<int>(i) * A.br + r, static_cast<int>(A.col[k]) * A.bc + c,
                         A.block(k)[r * A.bc + c]);
  const int n = static_cast<int>(A.rows) * A.br;
  Eigen::SparseMatrix<double> M(n, n);
  M.setFromTriplets(t.begin(), t.end());
  coarse_.compute(M);
}

void Multigrid::pack_levels(int threads) {
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    Level& L = levels_[l];
    if (l + 1 < levels_.size()) {
      pack(L.P, false, L.Pf, threads);
      pack(L.R, false, L.Rf, threads);
    }
  }
}

void Multigrid::build(const BlockMatrix& A, const std::vector<Vec3>& x, int threads) {
  levels_.clear();
  levels_.emplace_back();
  levels_[0].A = A;
  NearNullSpace ns;
  ns.rigid_modes(x);
  std::vector<Index> agg;
  for (std::size_t l = 0;; ++l) {
    smoother(levels_[l], l == 0, threads);
    const std::size_t n =
        static_cast<std::size_t>(levels_[l].A.rows) * static_cast<std::size_t>(levels_[l].A.br);
    if (n <= coarsest || l + 1 >= kMaxLevels) break;
    const Index count = aggregate(levels_[l].A, agg, l == 0 ? fine_aggregate_radius : 1);
    if (static_cast<double>(count) * 6 > 0.8 * static_cast<double>(n)) break;  // not coarsening
    BlockMatrix P0;
    NearNullSpace next;
    tentative_prolongator(ns, agg, count, P0, next);
    ns = std::move(next);
    // P = (I − ω D⁻¹ A) P0: AP0's pattern holds P0's (A's diagonal blocks are not 0).
    Level& L = levels_[l];
    multiply(L.A, P0, L.P, threads);
    const double omega = 4.0 / (3.0 * L.lambda);
    const int bs = L.A.br;
    parallel_for(L.P.rows, threads, [&](std::size_t i) {
      const double* D = L.Dinv.data() + i * static_cast<std::size_t>(bs * bs);
      const double* p0 = P0.block(i);
      double tmp[36];
      for (Index k = L.P.offset[i]; k < L.P.offset[i + 1]; ++k) {
        double* p = L.P.block(k);
        for (int r = 0; r < bs; ++r)
          for (int c = 0; c < 6; ++c) {
            double s = 0;
            for (int m = 0; m < bs; ++m) s += D[r * bs + m] * p[m * 6 + c];
            tmp[r * 6 + c] = -omega * s + (L.P.col[k] == P0.col[i] ? p0[r * 6 + c] : 0.0);
          }
        std::copy(tmp, tmp + bs * 6, p);
      }
    });
    transpose(L.P, L.R);
    levels_.emplace_back();
    galerkin(l, threads);
  }
  factor_coarsest();
  pack_levels(threads);
  release_fine();
}

void Multigrid::release_fine() {
  // The cycle reads the fine operator packed (Af); its double copy, the hierarchy's largest
  // matrix, is only needed again by the next build or update, which bring their own.
  BlockMatrix& A = levels_[0].A;
  A.offset = {0};
  A.col = {};
  A.val = {};
}

void Multigrid::update(const BlockMatrix& A, int threads) {
  levels_[0].A = A;
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    smoother(levels_[l], l == 0, threads);
    if (l + 1 < levels_.size()) galerkin(l, threads);
  }
  factor_coarsest();
  pack_levels(threads);
  release_fine();
}

void Multigrid::level_multiply(std::size_t l, const double* x, double* y, int threads) {
  if (l == 0 && fine_op_)
    fine_op_(x, y);
  else
    multiply(levels_[l].Af, x, y, threads);
}

void Multigrid::level_residual(std::size_t l, const double* b, const double* x, double* r, int threads) {
  if (l == 0 && fine_op_) {
    fine_op_(x, r);
    parallel_for(levels_[0].x.size(), threads, [&](std::size_t k) { r[k] = b[k] - r[k]; });
  } else {
    residual(levels_[l].Af, b, x, r, threads);
  }
}

void Multigrid::chebyshev(Level& L, bool zero_start, int threads) {
  const std::size_t l = static_cast<std::size_t>(&L - levels_.data());
  const int bs = L.A.br;
  const double hi = 1.1 * L.lambda, lo = hi / 5;
  const double theta = (hi + lo) / 2, delta = (hi - lo) / 2, sigma = theta / delta;
  double rho = 1 / sigma;
  // From zero the residual is b itself: the first step reads it there, without a copy.
  const double* r0 = L.b.data();
  if (!zero_start) {
    level_residual(l, L.b.data(), L.x.data(), L.r.data(), threads);
    r0 = L.r.data();
  }
  // d = D⁻¹ r0 / θ, and x = d from zero or x += d, in one pass.
  if (zero_start)
    block_scale<AlsoX::set>(L.Dinv, bs, L.A.rows, r0, 1 / theta, L.d.data(), threads, L.x.data());
  else
    block_scale<AlsoX::add>(L.Dinv, bs, L.A.rows, r0, 1 / theta, L.d.data(), threads, L.x.data());
  for (int it = 1; it < smoothing_degree; ++it) {
    level_multiply(l, L.d.data(), L.t.data(), threads);
    const double rho_next = 1 / (2 * sigma - rho);
    chebyshev_step(L.Dinv, bs, L.A.rows, r0, L.t.data(), rho_next * rho, 2 * rho_next / delta, L.r.data(),
                   L.d.data(), L.x.data(), threads);
    r0 = L.r.data();
    rho = rho_next;
  }
}

void Multigrid::cycle(std::size_t l, int threads) {
  Level& L = levels_[l];
  if (l + 1 == levels_.size()) {
    Eigen::Map<Eigen::VectorXd>(L.x.data(), static_cast<Eigen::Index>(L.x.size())) =
        coarse_.solve(Eigen::Map<const Eigen::VectorXd>(L.b.data(), static_cast<Eigen::Index>(L.b.size())));
    return;
  }
  Level& C = levels_[l + 1];
  chebyshev(L, true, threads);
  level_residual(l, L.b.data(), L.x.data(), L.r.data(), threads);
  multiply(L.Rf, L.r.data(), C.b.data(), threads);
  cycle(l + 1, threads);
  multiply_add(L.Pf, C.x.data(), L.x.data(), threads);
  chebyshev(L, false, threads);
}

void Multigrid::apply(const double* r, double* z, int threads) {
  Level& L = levels_[0];
  std::copy(r, r + L.b.size(), L.b.begin());
  cycle(0, threads);
  std::copy(L.x.begin(), L.x.end(), z);
}

void Multigrid::apply_swapping(std::vector<double>& r, std::vector<double>& z, int threads) {
  // The cycle only reads the fine level's b and writes all of its x before reading it: r lends
  // its storage as b, and z takes x's (x then z's old storage), instead of two copies.
  Level& L = levels_[0];
  std::swap(r, L.b);
  cycle(0, threads);
  std::swap(r, L.b);
  std::swap(z, L.x);
}

void Multigrid::solve(const Operator& A, const std::vector<double>& b, double tolerance, int cap, int threads,
                      std::vector<double>& y, bool y_zero, SolveStats& stats, double scale) {
  const std::size_t n = b.size();
  for (std::vector<double>* v : {&r_, &z_, &p_, &q_}) v->resize(n);
  y.resize(n);
  const double bnorm = std::max(std::sqrt(dot(n, b.data(), b.data(), threads)), scale);
  auto rel = [&](double r2) { return bnorm > 0 ? std::sqrt(r2) / bnorm : std::sqrt(r2); };
  if (y_zero) {
    std::fill(y.begin(), y.end(), 0.0);
    r_ = b;
  } else {
    // The guess scaled by yᵀb / yᵀA y, the factor that minimises its error's A-norm.
    A(y.data(), q_.data());
    const double yAy = dot(n, y.data(), q_.data(), threads), yb = dot(n, y.data(), b.data(), threads);
    const double s = yAy > 0 ? yb / yAy : 0.0;
    parallel_for(n, threads, [&](std::size_t k) {
      y[k] *= s;
      r_[k] = b[k] - s * q_[k];
    });
  }
  stats.residual = rel(dot(n, r_.data(), r_.data(), threads));
  int it = 0;
  double rz = 0;
  while (it < cap && stats.residual > tolerance) {
    apply_swapping(r_, z_, threads);
    const double rz_next = dot(n, r_.data(), z_.data(), threads);
    const double beta = it == 0 ? 0.0 : rz_next / rz;
    rz = rz_next;
    parallel_for(n, threads, [&](std::size_t k) { p_[k] = z_[k] + beta * p_[k]; });
    A(p_.data(), q_.data());
    const double pq = dot(n, p_.data(), q_.data(), threads);
    if (!(pq > 0)) break;  // exact solution reached (p = 0) or loss of positivity
    const double alpha = rz / pq;
    // The update and rᵀr in one pass, summed in dot's chunks and order: the same bits.
    const double rr = reduce_chunks(
        n, threads, 0.0,
        [&](std::size_t lo, std::size_t hi) {
          double s = 0.0;
          for (std::size_t k = lo; k < hi; ++k) {
            y[k] += alpha * p_[k];
            r_[k] -= alpha * q_[k];
            s = s + r_[k] * r_[k];
          }
          return s;
        },
        [](double u, double v) { return u + v; });
    ++it;
    stats.residual = rel(rr);
  }
  stats.iterations = it;
}

}  // namespace qbond
