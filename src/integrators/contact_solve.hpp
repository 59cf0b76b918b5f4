#pragma once
// Quanta–obstacle contact inside the implicit step's linear solve (Model::obstacles).
//
// Each contact of quanta i with an obstacle is a penalty spring along the obstacle's normal n,
// linearised about a reference point r on i's path (its start position, or where the path
// enters the obstacle grown by its margin): the gap φ(x) = φ(r) + n·(x − r), exact for a plane.
// With Δx = h (v + Δv) (backward Euler) and k = κ m / h² (Obstacle::penalty), the force at the
// end of the step k (g* − φ(x₁)) n adds to the system (backward_euler.hpp)
//     A_ii += h² k n nᵀ,   b_i += h k c n,   c = g* − φ(r) − n·(x − r) − h n·v,
// a diagonal 3×3 block, so CG, multigrid and the direct solvers take it as they take the mass.
// g* is 0, or for an impact (a quanta on the free side at the start, approaching at v_in) with
// restitution e the gap at which it would end after bouncing, e (h v_in − φ(x))⁺. A lone quanta
// (no bonds) under its constant external force (normal part a toward the surface) is followed
// exactly: it meets the surface at t with φ(x) = v_in t + ½ a t², at v_c = v_in + a t, and ends the
// step e v_c τ − ½ a τ² above it (τ = h − t) at the normal velocity e v_c − a τ, set after the
// solve (a bonded quanta's velocity is its body's solve).
// Coulomb friction is a tangential damper in the same system: the force −c P w₁ (P = I − n nᵀ,
// w₁ the end-of-step tangential velocity, relative for a pair) adds A_ii += h c P,
// b_i −= h c P v. A sticking contact has c = h k_t, k_t = 100 k (a spring to the start position);
// it slides once c |P w₁| passes μ_s f_n, and a sliding contact has c = μ_k f_n / |P w₁| from the
// last solve, re-solved until c settles (the fixed point is Coulomb's −μ_k f_n t with the solve's
// own f_n and direction), back to sticking when that c reaches h k_t. A contact that starts
// sliding within the step first feels the constant −μ_k f_n t while f_n and t settle (the damper's
// speed then starts right), and the step's last solve has dampers only. A damper's power at the
// end velocity is −c |P w₁|² ≤ 0 at any c: unsettled friction takes energy out, never puts it in,
// and cannot reverse a sliding.
// The active set (which quanta touch which obstacle, stick or slide, f_n) is found by solving,
// checking every contact against the solution, and solving again while it changes.
//
// Quanta–quanta contact (Model::quanta_contact) is the same spring on the gap of a pair,
// φ = |x_j − x_i| − 2R, linearised about the pair's reference separation d_r (its start, or where
// the relative path enters 2R) along n = d_r/|d_r|: φ ≈ φ(d_r) + n·(x_j − x_i − d_r), k = κ μ / h²
// (μ the reduced mass). Its block B = h² k n nᵀ (plus the friction's h c P) enters A_ii and
// A_jj, and −B the off-diagonal A_ij, A_ji (ImplicitSystem::couplings, which CG's product, the
// multigrid's fine level and the direct solvers' assembly read); b_j gains h k c n and b_i loses
// it. Candidates are the unbonded pairs whose relative path predicted for the step comes within
// 2R plus one radius (a spatial hash of the paths' midpoints): the active set is chosen among them.
#include <utility>
#include <vector>

#include "heuristics/spatial_hash.hpp"
#include "integrators/backward_euler.hpp"

namespace qbond {

class ContactSolve {
 public:
  // Active-set passes of a step at most (each a solve).
  static constexpr int kPasses = 8;
  // Finds the contacts of the step predicted from x + h v + h² f_ext/m and adds their terms to
  // sys. False (sys untouched) when the model has no such obstacle. The springs' stiffness is
  // κ m / spring_h²: spring_h is the whole step's length, so that a substep of it (energy guard)
  // holds its contacts with the springs the step holds them with.
  bool begin(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& f_ext,
             double h, double spring_h, int threads, ImplicitSystem& sys);
  // Checks the contacts against the solve's Δv (y): drops those pulling, switches stick and
  // slide, adds those whose path now enters an obstacle. True (and sys updated) when the set
  // changed and the step must be solved again. `last`: the solve it prepares is the step's last
  // (every sliding contact's friction is then a damper).
  bool update(const Model& model, const State& state, double h, int threads, bool last,
              const std::vector<Vec3>& y, ImplicitSystem& sys);
  // After an update that changed nothing (over every rank): takes back the contacts released twice
  // whose paths enter their obstacles again (sweep). True (and sys updated) when there were some.
  bool admit(const Model& model, const State& state, double h, int threads, bool last,
             const std::vector<Vec3>& y, ImplicitSystem& sys);
  // Whether the last update left contacts released twice whose paths enter again (admit's work).
  bool waiting() const { return waiting_; }
  // Quanta with a contact (1), for the momentum restoration to leave their components alone:
  // the obstacle's impulse is part of their momentum change. Empty when there is none.
  const std::vector<std::uint8_t>& touching() const { return touching_; }
  // Over MPI ranks: contacts with obstacles for the quanta with owned[i] set alone (a rank's own;
  // the others' are their owners'). Quanta–quanta contacts are every pair's, each rank holding the
  // whole world (a pair's ends may have two owners, and its active set reads both). The books
  // (finish) count the owned quanta's impulses and the springs of the owned quanta's obstacle
  // contacts and of the pairs whose first free end is owned.
  void only_quanta(std::vector<std::uint8_t> owned) { owned_ = std::move(owned); }
  // After the last solve and write_free_rows: the end normal velocity e v_in of a lone quanta's
  // impact (no bonds) in out.dv, and out.contact's energies (the contact impulses' work at the
  // mean velocity, the springs' energy).
  void finish(const Model& model, const State& state, const Adjacency& adj, double h, const std::vector<Vec3>& y,
              Projection& out);

 private:
  struct Contact {
    Index i = 0;
    std::uint32_t obstacle = 0;
    Vec3 n = Vec3::UnitZ();   // unit normal to the free side
    Vec3 ref = Vec3::Zero();  // reference point, gap there `gap_ref`
    double gap_ref = 0;
    double target = 0;  // g*
    double v_in = 0;    // approach speed of an impact (0: none)
    double v_out = 0;   // the normal speed a lone quanta's impact leaves with (finish)
    double k = 0;       // κ m / h²
    double fn = 0;      // normal force of the last solve [N]
    bool slide = false;
    double drag = 0;                       // c, the friction's tangential damping [N s/m]
    double last_drag = 0, last_speed = 0;  // a sliding contact's c and |P w₁| of the solve before
    bool push = false;                     // this solve: the constant force −push_force push_dir
    double push_force = 0;
    Vec3 push_dir = Vec3::Zero();
    std::uint8_t reversals = 0;  // times this step it stuck again after sliding
    bool unrubbed = false;       // its friction was turned off this step (sweep)
  };
  // A contact of quanta i and j (i < j): what Contact holds, for their relative motion.
  struct PairContact {
    std::uint32_t candidate = 0;  // its index in candidates_
    Index i = 0, j = 0;
    Vec3 n = Vec3::UnitZ();     // unit, from i to j
    Vec3 d_ref = Vec3::Zero();  // reference separation x_j − x_i, gap there `gap_ref`
    double gap_ref = 0, target = 0, v_in = 0, k = 0, fn = 0;
    bool slide = false;
    double drag = 0;  // c, on j's motion relative to i along the surface
    double last_drag = 0, last_speed = 0;
    bool push = false;
    double push_force = 0;
    Vec3 push_dir = Vec3::Zero();
    std::uint8_t reversals = 0;
    bool unrubbed = false;
  };
  // The contact of the pair of candidate c given that its relative path from the start to the end
  // separation d1 enters 2R (or ends inside it); false when it does not.
  bool make_pair(const Model& model, const State& state, double h, std::uint32_t c, const Vec3& d1,
                 PairContact& p) const;
  // The pair's normal force on j at Δv = y (negative: pulls), and all the force the solve applied on j.
  double pair_normal_force(const State& s, double h, const PairContact& p, const std::vector<Vec3>& y) const;
  Vec3 pair_force(const Model& model, const State& s, double h, const PairContact& p,
                  const std::vector<Vec3>& y) const;
  // candidates_: the unbonded pairs (rule permitting) whose relative path predicted from x1 comes
  // within 2R plus one radius, in increasing i then j.
  void find_candidates(const Model& model, const State& state, const Adjacency& adj,
                       const std::vector<Vec3>& x1);
  // Whether quanta i's obstacle contacts are this solve's (only_quanta).
  bool mine(Index i) const { return owned_.empty() || owned_[i] != 0; }
  // The row of quanta i saved before the contacts were first written.
  void save_row(Index i, const ImplicitSystem& sys);
  // The contact of quanta i with obstacle o, given that its path x → x1 enters it; false when it does not.
  bool make(const Model& model, const State& state, double h, Index i, std::uint32_t o, const Vec3& x1,
            Contact& c) const;
  // The normal force k (g* − φ(x₁)) at Δv = y (negative: the spring pulls).
  double normal_force(const State& s, double h, const Contact& c, const Vec3& y) const;
  // The force the solve applied at Δv = y: normal, and the friction's damper.
  Vec3 contact_force(const Model& model, const State& s, double h, const Contact& c, const Vec3& y) const;
  void write(const Model& model, const State& state, double h, int threads, ImplicitSystem& sys);
  // update's and admit's pass over the contacts: true, and the new set in contacts_ and pairs_,
  // when it changed. A contact released twice in the step stays released while the set changes
  // otherwise (it cannot cycle; waiting_ says one would enter again); once nothing else changes,
  // or for the last solve (`admit`), it returns if its path enters the obstacle, without friction,
  // and is never released again, even if its spring then pulls: no quanta may end the step deep
  // inside an obstacle with no spring holding it (the next step's would push it out with energy
  // from nowhere). The last solve releases nothing, for the same reason.
  bool sweep(const Model& model, const State& state, double h, bool last, bool admit,
             const std::vector<Vec3>& y);
  // The springs' energy at positions x: Σ ½ k φ² over the obstacles' and the candidates' overlaps.
  double stored(const Model& model, const std::vector<Vec3>& x) const;

  std::vector<Contact> contacts_;       // by quanta, then obstacle
  std::vector<Contact> next_;           // update's new set (scratch)
  std::vector<std::uint8_t> released_;  // per quanta and obstacle: times its contact was dropped this step
  std::vector<std::uint8_t> touching_;
  std::vector<std::uint8_t> owned_;  // only_quanta's; empty: every quanta
  std::vector<Index> saved_;  // quanta whose diagonal block and rhs are saved
  std::vector<Index> slot_;   // per quanta: its index in saved_, or -1
  std::vector<Mat3> base_diag_;
  std::vector<Vec3> base_rhs_;
  std::vector<Vec3> x1_;  // end positions (scratch)
  std::vector<std::pair<Index, Index>> candidates_;
  std::vector<PairContact> pairs_, next_pairs_;  // by candidate
  std::vector<std::uint8_t> pair_released_;      // per candidate: times its contact was dropped this step
  bool waiting_ = false;                         // sweep: a contact released twice would enter again
  std::vector<Vec3> mid_;                        // the predicted paths' midpoints (scratch)
  std::vector<double> reach_;                    // half the predicted paths' lengths (scratch)
  std::vector<Vec3> impulse_;                    // per quanta: the contacts' impulse this step (finish)
  double spring_h_ = 0;                          // the step length that sets the springs' stiffness
  const Adjacency* adj_ = nullptr;               // the step's bonds and external forces (begin)
  const std::vector<Vec3>* f_ext_ = nullptr;
  SpatialHash grid_;
};

}  // namespace qbond
