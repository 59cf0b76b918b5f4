#include "solvers/aggregation.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace qbond {

namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Block = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor, 6, 6>;

// [e]× w = e × w.
Mat3 cross_matrix(const Vec3& e) {
  Mat3 m;
  m << 0, -e.z(), e.y(), e.z(), 0, -e.x(), -e.y(), e.x(), 0;
  return m;
}

}  // namespace

Index aggregate(const BlockMatrix& A, std::vector<Index>& agg, int radius) {
  const Index n = A.rows;
  agg.assign(n, kNone);
  Index count = 0;
  auto neighbours = [&](Index i, auto&& f) {
    for (Index k = A.offset[i]; k < A.offset[i + 1]; ++k)
      if (A.col[k] != i) f(A.col[k]);
  };
  // A point and all its neighbours, none aggregated yet.
  for (Index i = 0; i < n; ++i) {
    if (agg[i] != kNone) continue;
    bool free = true;
    neighbours(i, [&](Index j) { free = free && agg[j] == kNone; });
    if (!free) continue;
    agg[i] = count;
    neighbours(i, [&](Index j) { agg[j] = count; });
    if (radius > 1)
      neighbours(i, [&](Index j) {
        neighbours(j, [&](Index k) {
          if (agg[k] == kNone) agg[k] = count;
        });
      });
    ++count;
  }
  // Left-over points join their first neighbour's aggregate from the first pass.
  std::vector<Index> first = agg;
  for (Index i = 0; i < n; ++i) {
    if (agg[i] != kNone) continue;
    neighbours(i, [&](Index j) {
      if (agg[i] == kNone && first[j] != kNone) agg[i] = first[j];
    });
  }
  // What remains (no aggregated neighbour) groups with its free neighbours.
  for (Index i = 0; i < n; ++i) {
    if (agg[i] != kNone) continue;
    agg[i] = count;
    neighbours(i, [&](Index j) {
      if (agg[j] == kNone) agg[j] = count;
    });
    ++count;
  }
  return count;
}

void NearNullSpace::rigid_modes(const std::vector<Vec3>& x) {
  bs = 3;
  position = x;
  origin = Vec3::Zero();
  for (const Vec3& p : x) origin += p;
  if (!x.empty()) origin /= static_cast<double>(x.size());
  double s2 = 0;
  for (const Vec3& p : x) s2 += (p - origin).squaredNorm();
  scale = x.empty() || !(s2 > 0) ? 1.0 : std::sqrt(s2 / static_cast<double>(x.size()));
  B.assign(x.size() * 18, 0.0);
  for (std::size_t i = 0; i < x.size(); ++i) {
    Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> b(B.data() + 18 * i);
    b.leftCols<3>().setIdentity();
    b.rightCols<3>() = -cross_matrix((x[i] - origin) / scale);
  }
}

void tentative_prolongator(const NearNullSpace& fine, const std::vector<Index>& agg, Index count,
                           BlockMatrix& P0, NearNullSpace& coarse) {
  const int bs = fine.bs;
  const auto n = static_cast<Index>(fine.position.size());
  const std::size_t bsz = static_cast<std::size_t>(bs) * 6;
  // The aggregates' points, in index order.
  std::vector<Index> start(static_cast<std::size_t>(count) + 1, 0), members(n);
  for (Index i = 0; i < n; ++i) ++start[agg[i] + 1];
  for (Index a = 0; a < count; ++a) start[a + 1] += start[a];
  {
    std::vector<Index> next(start.begin(), start.end() - 1);
    for (Index i = 0; i < n; ++i) members[next[agg[i]]++] = i;
  }
  P0.br = bs;
  P0.bc = 6;
  P0.rows = n;
  P0.cols = count;
  P0.offset.resize(static_cast<std::size_t>(n) + 1);
  for (Index i = 0; i <= n; ++i) P0.offset[i] = i;
  P0.col.assign(agg.begin(), agg.end());
  P0.val.assign(static_cast<std::size_t>(n) * bsz, 0.0);
  coarse.bs = 6;
  coarse.origin = fine.origin;
  coarse.scale = fine.scale;
  coarse.position.assign(count, Vec3::Zero());
  coarse.B.assign(static_cast<std::size_t>(count) * 36, 0.0);
  std::vector<double> centred;
  for (Index a = 0; a < count; ++a) {
    Vec3 c = Vec3::Zero();
    for (Index m = start[a]; m < start[a + 1]; ++m) c += fine.position[members[m]];
    c /= static_cast<double>(start[a + 1] - start[a]);
    coarse.position[a] = c;
    // Rotations about c: B S⁻¹ with S⁻¹ = [I [e]×; 0 I], e = (c − origin)/scale.
    const Mat3 ex = cross_matrix((c - fine.origin) / fine.scale);
    centred.resize((start[a + 1] - start[a]) * bsz);
    Mat6 G = Mat6::Zero();
    for (Index m = start[a]; m < start[a + 1]; ++m) {
      Eigen::Map<const Block> b(fine.B.data() + members[m] * bsz, bs, 6);
      Eigen::Map<Block> bc(centred.data() + (m - start[a]) * bsz, bs, 6);
      bc = b;
      bc.rightCols<3>() += b.leftCols<3>() * ex;
      G.noalias() += bc.transpose() * bc;
    }
    const Eigen::SelfAdjointEigenSolver<Mat6> eig(G);
    const Eigen::Matrix<double, 6, 1> lambda = eig.eigenvalues();
    const double lmax = lambda.maxCoeff();
    Mat6 T = Mat6::Zero(), Bc = Mat6::Zero();
    for (int k = 0; k < 6; ++k)
      if (lambda[k] > 1e-9 * lmax) {
        T.col(k) = eig.eigenvectors().col(k) / std::sqrt(lambda[k]);
        Bc.row(k) = std::sqrt(lambda[k]) * eig.eigenvectors().col(k).transpose();
      }
    // Back to rotations about the origin: B_c S, S = [I −[e]×; 0 I].
    Mat6 S = Mat6::Identity();
    S.topRightCorner<3, 3>() = -ex;
    Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(coarse.B.data() +
                                                             36 * static_cast<std::size_t>(a)) = Bc * S;
    for (Index m = start[a]; m < start[a + 1]; ++m) {
      Eigen::Map<const Block> bc(centred.data() + (m - start[a]) * bsz, bs, 6);
      Eigen::Map<Block>(P0.val.data() + members[m] * bsz, bs, 6) = bc * T;
    }
  }
}

}  // namespace qbond
