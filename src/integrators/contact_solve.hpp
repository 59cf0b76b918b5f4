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
// restitution e the gap at which it would end after bouncing, e (h v_in − φ(x))⁺; its end
// normal velocity is then set to e v_in.
// Coulomb friction: a sticking contact is a tangential spring k_t = 100 k to the start position,
// A_ii += h² k_t P, b_i −= h² k_t P v (P = I − n nᵀ); it slides when that force passes μ_s f_n,
// and a sliding contact feels the constant −μ_k f_n t (t the sliding direction) in b_i.
// The active set (which quanta touch which obstacle, stick or slide, f_n) is found by solving,
// checking every contact against the solution, and solving again while it changes.
#include <utility>
#include <vector>

#include "integrators/backward_euler.hpp"

namespace qbond {

class ContactSolve {
 public:
  // Finds the contacts of the step predicted from x + h v + h² f_ext/m and adds their terms to
  // sys. False (sys untouched) when the model has no such obstacle.
  bool begin(const Model& model, const State& state, const std::vector<Vec3>& f_ext, double h, int threads,
             ImplicitSystem& sys);
  // Checks the contacts against the solve's Δv (y): drops those pulling, switches stick and
  // slide, adds those whose path now enters an obstacle. True (and sys updated) when the set
  // changed and the step must be solved again.
  bool update(const Model& model, const State& state, double h, int threads, const std::vector<Vec3>& y,
              ImplicitSystem& sys);
  // Quanta with a contact (1), for the momentum restoration to leave their components alone:
  // the obstacle's impulse is part of their momentum change. Empty when there is none.
  const std::vector<std::uint8_t>& touching() const { return touching_; }
  // After the last solve and write_free_rows: impacts' end normal velocity e v_in in out.dv, and
  // out.contact's energies (the contact impulses' work at the mean velocity, the springs' energy).
  void finish(const Model& model, const State& state, double h, const std::vector<Vec3>& y, Projection& out);

 private:
  struct Contact {
    Index i = 0;
    std::uint32_t obstacle = 0;
    Vec3 n = Vec3::UnitZ();   // unit normal to the free side
    Vec3 ref = Vec3::Zero();  // reference point, gap there `gap_ref`
    double gap_ref = 0;
    double target = 0;  // g*
    double v_in = 0;    // approach speed of an impact (0: none)
    double k = 0;       // κ m / h²
    double fn = 0;      // normal force of the last solve [N]
    bool slide = false;
    Vec3 slide_dir = Vec3::Zero();  // unit, the friction pushes along −slide_dir
    double slide_fn = 0;            // f_n the sliding force used
  };
  // The contact of quanta i with obstacle o, given that its path x → x1 enters it; false when it does not.
  bool make(const Model& model, const State& state, double h, Index i, std::uint32_t o, const Vec3& x1,
            Contact& c) const;
  // The normal force k (g* − φ(x₁)) at Δv = y (negative: the spring pulls).
  double normal_force(const State& s, double h, const Contact& c, const Vec3& y) const;
  // The force the solve applied at Δv = y: normal, and the stick spring's or the sliding friction.
  Vec3 contact_force(const Model& model, const State& s, double h, const Contact& c, const Vec3& y) const;
  void write(const Model& model, const State& state, double h, int threads, ImplicitSystem& sys);
  double stored(const Model& model, const std::vector<Vec3>& x, double h) const;

  std::vector<Contact> contacts_;       // by quanta, then obstacle
  std::vector<Contact> next_;  // update's new set (scratch)
  std::vector<std::uint8_t> released_;  // per quanta and obstacle: times its contact was dropped this step
  std::vector<std::uint8_t> touching_;
  std::vector<Index> saved_;  // quanta whose diagonal block and rhs are saved
  std::vector<Index> slot_;   // per quanta: its index in saved_, or -1
  std::vector<Mat3> base_diag_;
  std::vector<Vec3> base_rhs_;
  std::vector<Vec3> x1_;  // end positions (scratch)
};

}  // namespace qbond
