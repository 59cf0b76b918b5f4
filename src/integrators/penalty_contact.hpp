#pragma once
// Penalty contact for the explicit integrators (ContactMethod::penalty): obstacles and quanta–quanta
// contact as forces of the positions and velocities, evaluated wherever the integrator evaluates
// the bond forces.
//
// A quanta i at depth δ = margin − distance(x) > 0 in an obstacle, with normal n to the free side
// and approach speed δ̇ = −n·v, feels a spring and a dashpot along n that never pull:
//     f_n = max(0, k δ + c δ̇),   k = κ m / h²,   c = 2 ζ √(k m),
// with the damping ratio ζ at which a lone quanta arriving at v leaves at e v (restitution_of in
// the .cpp: the contact ends when f_n reaches zero), at most 1 / (2 √κ): c h / m = 2 ζ √κ ≤ 1 keeps
// the damper stable, so a restitution below that ζ's (0.009 at κ = 0.01) gets that ζ's. With κ ≤ 1
// the spring's ω h = √κ ≤ 1 keeps velocity Verlet, symplectic Euler and RK4 stable (default
// κ = 0.01; explicit Euler gains energy on any spring), and the depth under a weight W is
// W h² / (κ m): the contact stiffens as the step shrinks.
// Friction is Coulomb's regularised by a damper: f_t = −min(μ_k f_n, c_t |v_t|) v_t/|v_t| with
// c_t = m / h (one step stops a lone quanta's sliding when μ_k f_n allows it); a body held by
// static friction creeps at |v_t| ≤ F_t h / m per quanta instead of sticking.
// A pair of unbonded quanta closer than 2R is the same contact on δ = 2R − |x_j − x_i| along the
// line of centres, with the reduced mass μ = m_i m_j / (m_i + m_j) for m and their relative
// velocity; the pair's forces are equal and opposite (momentum is kept exactly).
//
// The springs hold U = ½ k δ² (the ledger's contact energy).
#include <cstdint>
#include <span>
#include <vector>

#include "heuristics/spatial_hash.hpp"
#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

// Positions and velocities of n quanta as the integrators hold them: quanta q's component c at
// x[c][q * step] (step 3 for arrays of Vec3, 1 for rows of components).
struct PointsView {
  const double* x[3];
  const double* v[3];
  std::size_t step;
  Vec3 x_at(std::size_t q) const { return {x[0][q * step], x[1][q * step], x[2][q * step]}; }
  Vec3 v_at(std::size_t q) const { return {v[0][q * step], v[1][q * step], v[2][q * step]}; }
  // Arrays of Vec3.
  static PointsView of(const Vec3* x, const Vec3* v) {
    return {{x->data(), x->data() + 1, x->data() + 2}, {v->data(), v->data() + 1, v->data() + 2}, 3};
  }
};

// Whether integrator `type` holds penalty contacts: the explicit ones, which evaluate forces.
inline bool holds_penalty_contact(IntegratorType type) {
  return type == IntegratorType::explicit_euler || type == IntegratorType::symplectic_euler ||
         type == IntegratorType::velocity_verlet || type == IntegratorType::rk4;
}

// The restitution a lone quanta gets from a contact of restitution e and penalty κ: e, or, below
// what the most damping the step takes reaches, that.
double penalty_restitution(double e, double kappa);

class PenaltyContact {
 public:
  // A contact force on one free quanta (f on quanta i) [N].
  struct Force {
    Index i;
    Vec3 f;
  };

  // Whether the model has penalty contacts.
  static bool used(const Model& model);

  // The contact forces at the points p for steps of length h, into forces() in increasing quanta
  // order (a quanta's terms in a fixed order: its pairs, then its obstacles). `counted`: 1 for each
  // quanta whose springs stored() sums (a pair's by its first end), empty for all.
  void evaluate(const Model& model, const Adjacency& adj, double h, const PointsView& p,
                std::span<const std::uint8_t> counted = {});
  const std::vector<Force>& forces() const { return forces_; }
  // The counted springs' energy U = Σ ½ k δ² at the positions of the last evaluate [J].
  double stored() const { return stored_; }

 private:
  // The unbonded pairs (rule permitting) within 2R plus the skin at the list's positions: rebuilt
  // when a quanta has moved more than half the skin since, so that every pair within 2R is listed.
  void update_pairs(const Model& model, const Adjacency& adj, const PointsView& p);
  // The normal and friction force of a contact of mass m (reduced, for a pair) at depth δ along n
  // with velocity w (relative, for a pair) added to f; its spring's energy added to stored_ when
  // `counted`.
  void add(const ContactMaterial& mat, double kappa, double m, double h, double depth, const Vec3& n,
           const Vec3& w, bool counted, Vec3& f);

  // The damping ratio ζ for restitution e at penalty κ, computed once for each pair of them.
  double damping_ratio(double e, double kappa);
  struct Damping {
    double e, kappa, zeta;
  };
  std::vector<Damping> damping_;

  std::vector<Force> forces_;
  std::vector<Vec3> sum_;  // per quanta: its pairs' forces (scratch)
  std::vector<std::pair<Index, Index>> pairs_;
  std::vector<std::uint8_t> touched_;  // per quanta: whether a pair touches it (scratch)
  std::vector<Vec3> listed_at_;        // the positions the pair list was made at
  std::uint64_t listed_version_ = 0;   // the adjacency's version it was made with
  SpatialHash grid_;
  double stored_ = 0;
};

}  // namespace qbond
