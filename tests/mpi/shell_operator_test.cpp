// The two operators of the implicit solve over ranks (src/distributed/coupled_over_ranks.hpp) are
// one matrix: run under mpiexec over several ranks, the matrix-free product of the block-Jacobi
// solve (qbond's bond pass over each rank's piece, its ghosts' rows brought from their owners) and
// PETSc's assembled matrix of the multigrid solve, applied to the same random vectors, agree with
// each other and with the whole world's product on one rank, to the rounding of a sum of their
// terms. Exits 1 on a mismatch.
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <vector>

#include "distributed/coupled_over_ranks.hpp"
#include "distributed/local_world.hpp"
#include "distributed/partition.hpp"
#include "integrators/backward_euler.hpp"
#include "qbond/builders/samples.hpp"

namespace qbond {
namespace {

// A number in [-1, 1] from (a, b, c) alone (splitmix64), the same on every rank.
double uniform(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  std::uint64_t z = a * 0x9e3779b97f4a7c15ULL + b * 0xbf58476d1ce4e5b9ULL + c * 0x94d049bb133111ebULL + 1;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return 2.0 * static_cast<double>(z >> 11) / static_cast<double>(1ULL << 53) - 1.0;
}

// The canonical lattice (x = 0 face anchored: kinematic rows eliminated) with every quanta moved
// and set moving at random, so that its bonds' blocks differ from one another.
World shaken_lattice(int n) {
  World w = canonical_lattice(n).world;
  for (std::size_t q = 0; q < w.num_quanta(); ++q)
    for (int c = 0; c < 3; ++c) {
      if (!w.model.is_kinematic(static_cast<Index>(q))) w.state.x[q][c] += 2e-3 * uniform(q, c, 101);
      w.state.v[q][c] = 0.5 * uniform(q, c, 202);
    }
  return w;
}

// The step's system (h = 1 ms: h² k / m = 1, the bonds' blocks as large as the masses') on `w`.
ImplicitSystem step_system(const World& w, const Adjacency& adj) {
  std::vector<Vec3> f(w.num_quanta());
  for (std::size_t q = 0; q < f.size(); ++q) f[q] = w.model.mass[q] * w.model.gravity;
  ImplicitSystem sys;
  Projection kin;
  begin_implicit_step(w.model, w.state, adj, f, {.h = 1e-3}, /*edges=*/false, 1, kin, sys);
  return sys;
}

// Σ |A_ij| |y_j| over row i's blocks, component c: the scale of the rounding of (A y)_i.
double magnitude(const Adjacency& adj, const ImplicitSystem& sys, const std::vector<std::int64_t>& row, Index i,
                 const std::vector<Vec3>& y, int c) {
  double s = 0;
  for (int d = 0; d < 3; ++d) s += std::abs(sys.diag[i](c, d)) * std::abs(y[i][d]);
  for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
    if (row[adj.other[e]] < 0) continue;
    const Index b = adj.bond[e];
    const Vec3 u = sys.bonds.u(b).cwiseAbs(), yj = y[adj.other[e]].cwiseAbs();
    s += std::abs(sys.bonds.Ba[b]) * u[c] * u.dot(yj) + std::abs(sys.bonds.Bb[b]) * yj[c];
  }
  return s;
}

int run() {
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  const World whole = shaken_lattice(8);
  Adjacency whole_adj;
  build_adjacency(whole.model, whole.state, whole_adj);
  FreeComponents components;
  free_components(whole.model, whole_adj, components);
  const std::vector<int> owner = distributed::parts_of(distributed::bisect(whole.state.x, ranks), whole.state.x);
  const distributed::Piece piece = distributed::make_piece(whole, owner, rank);
  const distributed::SolveLayout layout = distributed::solve_layout(
      whole, owner, rank, ranks, piece.global, piece.owned_quanta, components);
  const World& w = piece.world;
  Adjacency adj;
  build_adjacency(w.model, w.state, adj);
  const ImplicitSystem sys = step_system(w, adj), whole_sys = step_system(whole, whole_adj);

  IntegratorConfig config;
  config.type = IntegratorType::coupled_implicit;
  config.threads = 1;
  // The rows coupled to another rank's: the ghosts the product needs must come from their owners.
  std::size_t free_ghosts = 0;
  for (std::size_t l = 0; l < w.num_quanta(); ++l)
    if (!piece.owned[l] && layout.row[l] >= 0) ++free_ghosts;
  int failures = 0;
  if (ranks > 1 && free_ghosts == 0) {
    std::fprintf(stderr, "rank %d: no free ghosts, nothing couples the ranks\n", rank);
    ++failures;
  }
  // Rounding of a sum of K terms: γ_K = K u / (1 − K u), K the terms of a row's product (3 a
  // block, the diagonal's and each bond's) plus the few roundings of forming a block's entries.
  Index most = 0;
  for (Index i : layout.owned_free) most = std::max(most, adj.offset[i + 1] - adj.offset[i]);
  const double u = std::numeric_limits<double>::epsilon() / 2, K = 3.0 * (most + 1) + 6;
  const double gamma = K * u / (1 - K * u);
  double worst = 0;  // the largest difference over its bound
  for (std::uint64_t trial = 0; trial < 3; ++trial) {
    // y: the same whole-world vector on any rank count, each rank holding its owned free rows.
    std::vector<Vec3> y_whole(whole.num_quanta(), Vec3::Zero()), y_local(w.num_quanta(), Vec3::Zero());
    for (std::size_t q = 0; q < y_whole.size(); ++q)
      if (!whole.model.is_kinematic(static_cast<Index>(q)))
        for (int c = 0; c < 3; ++c) y_whole[q][c] = uniform(q, static_cast<std::uint64_t>(c), 1000 + trial);
    for (std::size_t l = 0; l < w.num_quanta(); ++l) y_local[l] = y_whole[piece.global[l]];
    std::vector<double> y(3 * layout.owned_free.size());
    for (std::size_t k = 0; k < layout.owned_free.size(); ++k)
      for (int c = 0; c < 3; ++c) y[3 * k + static_cast<std::size_t>(c)] = y_local[layout.owned_free[k]][c];
    std::vector<double> matrix_free, assembled, alone;
    distributed::apply_both_operators(layout, w.model, w.state, adj, sys, config, y, matrix_free, assembled);
    std::vector<Vec3> product;
    apply_system(whole.model, whole.state.bonds, whole_sys, y_whole, 1, product);
    if (matrix_free.size() != y.size() || assembled.size() != y.size()) {
      std::fprintf(stderr, "rank %d: the operators gave %zu and %zu rows' entries, not %zu\n", rank,
                   matrix_free.size(), assembled.size(), y.size());
      return 1;
    }
    for (std::size_t k = 0; k < layout.owned_free.size(); ++k) {
      const Index i = layout.owned_free[k];
      for (int c = 0; c < 3; ++c) {
        const std::size_t e = 3 * k + static_cast<std::size_t>(c);
        const double one = product[piece.global[i]][c];
        const double bound = 2 * gamma * magnitude(adj, sys, layout.row, i, y_local, c);
        const double off = std::max({std::abs(matrix_free[e] - assembled[e]), std::abs(matrix_free[e] - one),
                                     std::abs(assembled[e] - one)});
        worst = std::max(worst, off / bound);
        if (!(off <= bound)) {
          if (failures < 10)
            std::fprintf(stderr, "rank %d, quanta %u, component %d: matrix-free %.17g, assembled %.17g, alone %.17g "
                         "(bound %.3g)\n", rank, static_cast<unsigned>(piece.global[i]), c, matrix_free[e],
                         assembled[e], one, bound);
          ++failures;
        }
      }
    }
  }
  int all = 0;
  MPI_Allreduce(&failures, &all, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  double worst_all = 0;
  MPI_Allreduce(&worst, &worst_all, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  if (rank == 0)
    std::printf("%d ranks, %lld free quanta: the operators %s (largest difference %.3g of its rounding bound)\n", ranks,
                static_cast<long long>(layout.rows), all == 0 ? "agree" : "DIFFER", worst_all);
  return all == 0 ? 0 : 1;
}

}  // namespace
}  // namespace qbond

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int code = 1;
  try {
    code = qbond::run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  qbond::distributed::end_petsc();
  MPI_Finalize();
  return code;
}
