#include "integrators/multigrid_step.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>

#include "core/parallel.hpp"

namespace qbond {

namespace {

// The relative change (Frobenius norm) of a diagonal block beyond which the smoother takes it anew.
constexpr double kDiagonalMoved = 0.1;

double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}
}  // namespace

void MultigridStep::assemble_pattern(const Model& model, const Adjacency& adj) {
  const std::size_t n = model.num_quanta();
  row_of.assign(n, kNone);
  quanta.clear();
  for (std::size_t i = 0; i < n; ++i)
    if (!model.is_kinematic(static_cast<Index>(i))) {
      row_of[i] = static_cast<Index>(quanta.size());
      quanta.push_back(static_cast<Index>(i));
    }
  const auto rows = static_cast<Index>(quanta.size());
  A = BlockMatrix{};
  A.rows = A.cols = rows;
  A.offset.assign(static_cast<std::size_t>(rows) + 1, 0);
  edge_at.assign(adj.offset[n], kNone);
  diag_at.resize(rows);
  std::vector<Index> cols;
  for (Index r = 0; r < rows; ++r) {
    const Index i = quanta[r];
    cols.assign(1, r);
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e)
      if (const Index c = row_of[adj.other[e]]; c != kNone && c != r) cols.push_back(c);
    std::sort(cols.begin(), cols.end());
    cols.erase(std::unique(cols.begin(), cols.end()), cols.end());
    const Index first = A.offset[r];
    A.col.insert(A.col.end(), cols.begin(), cols.end());
    A.offset[r + 1] = first + static_cast<Index>(cols.size());
    diag_at[r] = first + static_cast<Index>(std::lower_bound(cols.begin(), cols.end(), r) - cols.begin());
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e)
      if (const Index c = row_of[adj.other[e]]; c != kNone && c != r)
        edge_at[e] = first + static_cast<Index>(std::lower_bound(cols.begin(), cols.end(), c) - cols.begin());
  }
  A.val.assign(A.blocks() * 9, 0.0);
  adj_version = adj.version;
  num_quanta = n;
}

std::size_t MultigridStep::changed_blocks() const {
  std::size_t changed = 0;
  for (Index r = 0; r < A.rows; ++r) {
    auto a = A.col.begin() + A.offset[r], a_end = A.col.begin() + A.offset[r + 1];
    auto b0 = built_col.begin() + built_offset[r], b_end = built_col.begin() + built_offset[r + 1];
    while (a != a_end || b0 != b_end) {
      if (b0 == b_end || (a != a_end && *a < *b0)) {
        ++changed;
        ++a;
      } else if (a == a_end || *b0 < *a) {
        ++changed;
        ++b0;
      } else {
        ++a;
        ++b0;
      }
    }
  }
  return changed;
}

void MultigridStep::solve(const Model& model, const State& state, const Adjacency& adj,
                          const ImplicitSystem& sys, bool contacts, double h, double tolerance, int cap,
                          int threads, std::vector<Vec3>& y, bool y_zero, SolveStats& stats) {
  const std::size_t n = model.num_quanta();
  bool same_free = n == num_quanta;
  for (std::size_t r = 0; same_free && r < quanta.size(); ++r) same_free = !model.is_kinematic(quanta[r]);
  if (same_free) {
    std::size_t free = 0;
    for (std::size_t i = 0; i < n; ++i) free += model.is_kinematic(static_cast<Index>(i)) ? 0 : 1;
    same_free = free == quanta.size();
  }
  if (!same_free || adj.version != adj_version) assemble_pattern(model, adj);
  if (quanta.empty()) {
    y.assign(n, Vec3::Zero());
    stats.iterations = 0;
    stats.residual = 0;
    return;
  }
  const std::size_t m = 3 * quanta.size();
  b.resize(m);
  x.resize(m);
  parallel_for(quanta.size(), threads, [&](std::size_t r) {
    for (int c = 0; c < 3; ++c) {
      b[3 * r + c] = sys.rhs[quanta[r]][c];
      x[3 * r + c] = y_zero ? 0.0 : y[quanta[r]][c];
    }
  });

  // The cycle's and CG's fine operator: CG's matrix-free product on this step's system.
  product.prepare(model, state.bonds, sys, quanta, threads);
  fine = [this, threads](const double* in, double* out) { product.apply(in, out, threads); };
  mg.set_fine_operator(fine);

  bool build = !mg.built() || built_quanta != quanta;
  bool update = false;
  if (!build && (A.offset != built_offset || A.col != built_col))
    build = 10 * changed_blocks() > built_col.size();  // bonds broke or formed
  if (!build) {
    if (std::abs(h - built_h) > 0.25 * built_h) {  // a kept hierarchy still serves a nearby h
      update = true;
    } else if (base_iterations >= 0 && last_iterations > 1.5 * base_iterations + 2) {
      build = updated_since_check;  // an update did not help: the aggregates no longer fit
      update = !build;
    }
  }
  // Contacts: the rows whose diagonal block moved a tenth or more from the one the fine smoother
  // inverts (a sticking contact's damper came or went). Once none moves after some did, the
  // contacts have settled: the hierarchy is updated beside them, once.
  bool any_moved = false;
  if (contacts && !build && !update) {
    moved.assign(quanta.size(), 0);
    parallel_for(quanta.size(), threads, [&](std::size_t r) {
      const Mat3& d = sys.diag[quanta[r]];
      moved[r] = (d - smoothed[r]).norm() > kDiagonalMoved * smoothed[r].norm();
    });
    any_moved = std::find(moved.begin(), moved.end(), 1) != moved.end();
    update = !any_moved && smoothed_moved;
  }
  updated_since_check = update;
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = thread_cpu_seconds();
  // A's values: the diagonal blocks, then −B_b for each bond to a free quanta, in adjacency order.
  auto fill_values = [&] {
    parallel_for(A.rows, threads, [&](std::size_t r) {
      const Index i = quanta[r];
      std::fill(A.val.begin() + A.offset[r] * 9, A.val.begin() + A.offset[r + 1] * 9, 0.0);
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(A.block(diag_at[r])) = sys.diag[i];
      for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
        if (edge_at[e] == kNone) continue;
        const Index bond = adj.bond[e];
        Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(A.block(edge_at[e])) -=
            block_matrix(sys.bonds.u(bond), sys.bonds.Ba[bond], sys.bonds.Bb[bond]);
      }
    });
  };
  if (build || update) fill_values();
  if (build) {
    std::vector<Vec3> points(quanta.size());
    for (std::size_t r = 0; r < quanta.size(); ++r) points[r] = state.x[quanta[r]];
    mg.build(A, points, threads);
    ++builds;
    built_quanta = quanta;
    built_offset = A.offset;
    built_col = A.col;
    built_h = h;
    base_iterations = -1;
  } else if (update) {
    mg.update(A, threads);
    ++updates;
    built_h = h;
  }
  // The blocks the smoother inverts: all of sys's after a build or update; else the moved rows'
  // taken anew, the others (which bonds turning or normal springs move a little) staying with the
  // coarse levels made beside them. Diagonal blocks are symmetric: either storage order is the
  // row-major block the smoother takes.
  auto keep_smoothed = [&] {
    smoothed.resize(quanta.size());
    parallel_for(quanta.size(), threads, [&](std::size_t r) { smoothed[r] = sys.diag[quanta[r]]; });
    smoothed_moved = false;
  };
  if (build || update) {
    keep_smoothed();
  } else if (any_moved) {
    parallel_for(quanta.size(), threads, [&](std::size_t r) {
      if (!moved[r]) return;
      smoothed[r] = sys.diag[quanta[r]];
      mg.set_fine_diagonal(r, smoothed[r].data());
    });
    smoothed_moved = true;
  }
  const auto t1 = std::chrono::steady_clock::now();
  const double c1 = thread_cpu_seconds();
  // A kept hierarchy can stop fitting within one step (an impact stiffens contacts, bonds turn
  // far): its solve is cut off at a few times the iterations it took when made, then the
  // hierarchy's values are refreshed and the solve goes on from where it stopped.
  const int kept_cap = build || update || base_iterations < 0 ? cap : std::min(cap, 4 * base_iterations + 20);
  mg.solve(fine, b, tolerance, kept_cap, threads, x, y_zero, stats, sys.load_norm);
  const auto t2 = std::chrono::steady_clock::now();
  const double c2 = thread_cpu_seconds();
  double refresh_seconds = 0, refresh_cpu_seconds = 0;
  if (stats.residual > tolerance && kept_cap < cap) {
    fill_values();
    mg.update(A, threads);
    keep_smoothed();
    ++updates;
    built_h = h;
    updated_since_check = true;
    const auto t3 = std::chrono::steady_clock::now();
    refresh_seconds = std::chrono::duration<double>(t3 - t2).count();
    refresh_cpu_seconds = thread_cpu_seconds() - c2;
    SolveStats more;
    mg.solve(fine, b, tolerance, cap - stats.iterations, threads, x, false, more, sys.load_norm);
    stats.iterations += more.iterations;
    stats.residual = more.residual;
  }
  setup_seconds = std::chrono::duration<double>(t1 - t0).count() + refresh_seconds;
  solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count() - refresh_seconds;
  setup_cpu_seconds = c1 - c0 + refresh_cpu_seconds;
  solve_cpu_seconds = thread_cpu_seconds() - c1 - refresh_cpu_seconds;
  last_iterations = stats.iterations;
  if (base_iterations < 0) base_iterations = stats.iterations;
  y.assign(n, Vec3::Zero());
  parallel_for(quanta.size(), threads,
               [&](std::size_t r) { y[quanta[r]] = Vec3(x[3 * r], x[3 * r + 1], x[3 * r + 2]); });
}

}  // namespace qbond
