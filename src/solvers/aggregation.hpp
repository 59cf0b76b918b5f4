#pragma once
// Smoothed aggregation's coarsening (Vaněk, Mandel, Brezina 1996): the unknowns' points grouped
// into aggregates, and on each aggregate the rigid-body modes (3 translations, 3 rotations)
// orthonormalised into the columns of the tentative prolongator.
#include <vector>

#include "solvers/block_matrix.hpp"

namespace qbond {

/// Groups the block rows of A (graph: its off-diagonal blocks) into aggregates, in index order:
/// a point whose neighbours are all free starts an aggregate with them (radius 1; with 2 also with
/// its neighbours' free neighbours: about half as many aggregates); a point left over
/// joins the aggregate of its first aggregated neighbour; what remains groups with its free
/// neighbours. agg[i] is point i's aggregate; returns their count. The same aggregates for the
/// same pattern.
Index aggregate(const BlockMatrix& A, std::vector<Index>& agg, int radius = 1);

/// The near-null space of a level: for each of its points, a bs × 6 block (row-major) whose
/// columns are the rigid modes (translations, rotations about `origin` with lengths in units of
/// `scale`) on that point's unknowns, and the point's position.
struct NearNullSpace {
  int bs = 3;
  std::vector<double> B;       // rows · bs · 6
  std::vector<Vec3> position;  // rows
  Vec3 origin = Vec3::Zero();
  double scale = 1;
  /// For 3-unknown points at `x`: B_i = [I | −[(x_i − origin)/scale]×], origin and scale the
  /// points' centroid and RMS distance from it.
  void rigid_modes(const std::vector<Vec3>& x);
};

/// The tentative prolongator P0 (rows × count blocks of bs × 6, one a row) and the next level's
/// near-null space: on aggregate a, with B_a its points' blocks (rotations taken about the
/// aggregate's centroid, for conditioning), B_aᵀB_a = V Λ Vᵀ, P0 = B_a V Λ^{−1/2} on the
/// eigenvalues above 1e-9 λ_max (0 columns for the rest, the modes an aggregate too small or
/// too flat cannot carry), so that P0's columns on each aggregate are orthonormal, and the coarse
/// block Λ^{1/2} Vᵀ (about `origin` again), so that P0 B_c = B.
void tentative_prolongator(const NearNullSpace& fine, const std::vector<Index>& agg, Index count,
                           BlockMatrix& P0, NearNullSpace& coarse);

}  // namespace qbond
