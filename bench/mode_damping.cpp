#include "mode_damping.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "integrators/backward_euler.hpp"  // internal: the system whose stiffness the modes are of
#include "qbond/simulation/simulation.hpp"

namespace qbond::bench {
namespace {

// The free quanta in order (the unknowns' numbering: 3 a quanta).
std::vector<Index> free_quanta(const Model& m) {
  std::vector<Index> f;
  for (std::size_t i = 0; i < m.num_quanta(); ++i)
    if (!m.is_kinematic(static_cast<Index>(i))) f.push_back(static_cast<Index>(i));
  return f;
}

// The mode's coordinate and velocity: q = φᵀ M (x − x_rest), q̇ = φᵀ M v.
std::pair<double, double> modal(const World& rest, const State& s, const std::vector<Index>& free,
                                const VibrationMode& mode) {
  double q = 0, qd = 0;
  for (std::size_t r = 0; r < free.size(); ++r) {
    const Index i = free[r];
    const double m = rest.model.mass[i];
    const Vec3 d = s.x[i] - rest.state.x[i];
    for (int c = 0; c < 3; ++c) {
      const double phi = mode.shape[static_cast<Eigen::Index>(3 * r + c)];
      q += phi * m * d[c];
      qd += phi * m * s.v[i][c];
    }
  }
  return {q, qd};
}

}  // namespace

double ModeDamping::damping_ratio() const { return -std::log(amplification) / (omega * h); }
double ModeDamping::backward_euler_amplification() const { return 1 / std::sqrt(1 + omega * omega * h * h); }
double ModeDamping::backward_euler_damping_ratio() const {
  return std::log1p(omega * omega * h * h) / (2 * omega * h);
}

std::vector<VibrationMode> vibration_modes(const World& world, int count) {
  World w = world;
  for (std::size_t b = 0; b < w.num_bonds(); ++b) w.state.bonds.damping[b] = 0;
  for (Vec3& v : w.state.v) v.setZero();
  const Model& m = w.model;
  Adjacency adj;
  build_adjacency(m, w.state, adj);
  const std::vector<Vec3> f_ext(w.num_quanta(), Vec3::Zero());
  ImplicitSystem sys;
  Projection kin;
  // At h = 1 s and without damping the system's matrix is M + K.
  begin_implicit_step(m, w.state, adj, f_ext, {.h = 1.0}, /*edges=*/false, 1, kin, sys);
  std::vector<Eigen::Index> dof;
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::SparseMatrix<double> A;
  Eigen::VectorXd b;
  assemble_system(m, w.state, sys, dof, triplets, A, b);
  Eigen::MatrixXd K(A), M = Eigen::MatrixXd::Zero(A.rows(), A.cols());
  for (std::size_t i = 0; i < dof.size(); ++i)
    if (dof[i] >= 0)
      for (int c = 0; c < 3; ++c) M(dof[i] + c, dof[i] + c) = m.mass[i];
  K -= M;
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(K, M);
  if (eig.info() != Eigen::Success) throw std::runtime_error("vibration_modes: the eigensolver failed");
  const double largest = eig.eigenvalues().cwiseAbs().maxCoeff();
  std::vector<VibrationMode> modes;
  for (Eigen::Index k = 0; k < eig.eigenvalues().size() && static_cast<int>(modes.size()) < count; ++k)
    if (eig.eigenvalues()[k] > 1e-9 * largest)  // rigid-body modes: zero to rounding
      modes.push_back({std::sqrt(eig.eigenvalues()[k]), eig.eigenvectors().col(k)});
  return modes;
}

ModeDamping measure_mode_damping(const World& world, const IntegratorConfig& config, double h,
                                 const VibrationMode& mode, double amplitude, double periods) {
  const std::vector<Index> free = free_quanta(world.model);
  if (mode.shape.size() != static_cast<Eigen::Index>(3 * free.size()))
    throw std::invalid_argument("measure_mode_damping: the mode is not of this world's free quanta");
  World w = world;
  const double a = amplitude / mode.shape.cwiseAbs().maxCoeff();
  for (std::size_t r = 0; r < free.size(); ++r)
    for (int c = 0; c < 3; ++c) w.state.x[free[r]][c] += a * mode.shape[static_cast<Eigen::Index>(3 * r + c)];
  auto energy = [&](const State& s) {
    const auto [q, qd] = modal(world, s, free, mode);
    return 0.5 * (qd * qd + mode.omega * mode.omega * q * q);
  };
  const double e0 = energy(w.state);
  Simulation sim(std::move(w), config, h);
  sim.set_track_energy(false);
  const double period = 2 * std::numbers::pi / mode.omega;
  const int steps = std::clamp(static_cast<int>(std::ceil(periods * period / h)), 1, 1000000);
  ModeDamping out{.omega = mode.omega, .h = h};
  double e = e0;
  for (int k = 0; k < steps; ++k) {
    const StepReport r = sim.step();
    e = energy(sim.world().state);
    ++out.steps;
    if (r.status == StepReport::Status::blowup || !std::isfinite(e) || e > 1e6 * e0) {
      out.stable = false;
      break;
    }
    if (e < 1e-12 * e0) break;
  }
  out.amplification = std::pow(e / e0, 1.0 / (2.0 * out.steps));
  return out;
}

}  // namespace qbond::bench
