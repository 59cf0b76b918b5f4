#pragma once
// The linearised backward-Euler step shared by the hybrid and coupled integrators.
//
// Backward Euler, M Δv = h f(x + Δx, v + Δv) with Δx = h (v + Δv), linearised about the start of
// the step (f(x+Δx, v+Δv) ≈ f - K Δx - C Δv) gives, for the free quanta (Eq. 13 linearised):
//     (M + h C + h² K) Δv = h f - h K Δx₀ - h C Δv_k,
// where Δx₀ = h v for free quanta and the prescribed displacement for kinematic ones, and Δv_k is
// the prescribed velocity change of kinematic quanta (0 for free ones). Kinematic unknowns are
// eliminated, so A = M + h C + h² K only couples free quanta. Per bond b = (i, j):
//     A_ii += B_b,  A_jj += B_b,  A_ij = A_ji = -B_b,   B_b = h C_b + h² K_b.
// The paper's hybrid (`frozen`) keeps only the diagonal blocks and drops the neighbours' terms
// from the right-hand side: A_ii Δv_i = h f_i - h² (Σ_b K_b) v_i (Eq. 12).
#include <vector>

#include "forces.hpp"
#include "qbond/integrators.hpp"

namespace qbond {

struct ImplicitSystem {
  BondLinearisation bonds;
  std::vector<Mat3> B;         // h C_b + h² K_b (nb)
  std::vector<Vec3> g;         // bond b's right-hand-side term on bond_i (bond_j gets -g) (nb)
  std::vector<Mat3> diag;      // A_ii (n); identity for kinematic quanta
  std::vector<Mat3> diag_inv;  // A_ii⁻¹ (n)
  std::vector<Vec3> rhs;       // b (n); 0 for kinematic quanta
  double rhs_norm = 0;         // ‖b‖ over free quanta
};

// Starts an implicit step: sizes `out` and fills its kinematic rows (project_kinematic), then
// builds A's blocks and b (each quanta gathers its bonds in bond order, so any thread count gives
// the same bits). With `frozen`, b omits the neighbours' motion (Eq. 12 literally).
void begin_implicit_step(const Model& model, const State& state, const Adjacency& adj,
                         const std::vector<Vec3>& f_ext, const StepContext& ctx, bool frozen, int threads,
                         Projection& out, ImplicitSystem& sys);

// out = A y over free quanta (y's kinematic rows are ignored; out's kinematic rows are 0).
void apply_system(const Model& model, const Adjacency& adj, const ImplicitSystem& sys, const std::vector<Vec3>& y,
                  int threads, std::vector<Vec3>& out);

}  // namespace qbond
