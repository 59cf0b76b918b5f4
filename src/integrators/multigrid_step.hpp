#pragma once
// The implicit step's system (M + h C + h² K) Δv = b solved by multigrid-preconditioned CG
// (solvers/multigrid.hpp), with the hierarchy kept from step to step.
//
// CG and the cycle apply A matrix-free (SystemProduct); A is assembled into 3×3 blocks over the free
// quanta only to build or update the hierarchy (its pattern redone only when the bonds change). The hierarchy is built on the first step and whenever the free quanta change;
// otherwise it is kept, a fixed symmetric positive definite preconditioner, and updated (same
// aggregates and prolongators, operators from the current A) when h changes by more than a
// quarter (an adaptive step's small changes keep it) or when a solve takes more than 1.5 × (plus
// 2) the iterations the solve right after the last build took. After bonds break or form it is
// rebuilt only once more than a tenth of A's blocks differ from the built pattern, or when an
// update did not bring the iterations back down. While the system holds contact springs, its
// fine smoother takes the diagonal blocks that moved far from those it inverts (a sticking
// contact's damper came or went: Multigrid::set_fine_diagonal), and once they stop moving the
// hierarchy is updated beside them.
#include <cstdint>
#include <vector>

#include "integrators/backward_euler.hpp"
#include "solvers/multigrid.hpp"

namespace qbond {

struct MultigridStep {
  /// Solves A y = sys.rhs over the free quanta (y's kinematic rows 0) from the guess in y (y_zero:
  /// zero), to a relative residual of `tolerance` or `cap` iterations; fills stats. `contacts`: sys
  /// holds contact springs, which come and go from solve to solve and can stiffen their quanta's
  /// diagonal blocks far beyond the kept hierarchy's: its fine smoother then takes those blocks.
  void solve(const Model& model, const State& state, const Adjacency& adj, const ImplicitSystem& sys,
             bool contacts, double h, double tolerance, int cap, int threads, std::vector<Vec3>& y,
             bool y_zero, SolveStats& stats);

  Multigrid mg;
  int builds = 0, updates = 0;  ///< hierarchy builds and numeric updates so far
  double setup_seconds = 0;     ///< the last solve's time in building or updating the hierarchy
  double solve_seconds = 0;     ///< the last solve's time in CG
  /// The same two as the calling thread's CPU time (on a shared host, what the work cost; with
  /// one thread, all of it).
  double setup_cpu_seconds = 0, solve_cpu_seconds = 0;

 private:
  void assemble_pattern(const Model& model, const Adjacency& adj);
  std::size_t changed_blocks() const;

  std::vector<Index> row_of;   // each quanta's block row, kNone for kinematic quanta
  std::vector<Index> quanta;   // each block row's quanta
  std::vector<Index> edge_at;  // each adjacency entry's block in A (kNone: not coupled)
  std::vector<Index> diag_at;  // each block row's diagonal block
  BlockMatrix A;                // assembled only when the hierarchy is built or updated
  SystemProduct product;        // A as CG and the cycle's fine level apply it
  Multigrid::Operator fine;
  std::uint64_t adj_version = ~0ull;
  std::size_t num_quanta = 0;
  // The hierarchy's: its free quanta, A's pattern when built, h when last built or updated.
  std::vector<Index> built_quanta, built_offset, built_col;
  double built_h = 0;
  int base_iterations = -1, last_iterations = 0;
  bool updated_since_check = false;
  std::vector<double> b, x;
  std::vector<Mat3> smoothed;       // the diagonal blocks the fine smoother inverts, by block row
  std::vector<std::uint8_t> moved;  // rows whose block in sys moved far from `smoothed` (contacts)
  bool smoothed_moved = false;      // some row of `smoothed` taken anew since the last build or update
};

}  // namespace qbond
