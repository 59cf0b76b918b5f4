#pragma once
// The private paths between Simulation's integrate stage and the integrators (not public API).
//
// Advancing in place: when no stage after the integrator reads a step's dx and dv (no heuristic,
// no energy ledger), an integrator that owns a fused kernel (the frozen hybrid step, velocity
// Verlet) writes the state the step applies, x + dx and v + dv with the prescribed quanta placed,
// in the passes that form the step, and checks it there against the blow-up rule: one pass over
// the quanta fewer, and no dx, dv streamed out and back. The hybrid step's sweeps add their
// solution to the state in the pass that forms dx and dv (apply_solved). The others project and
// apply (apply_checked), as the check stage does after heuristics; the bits are the same either way.
#include <cmath>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/simd.hpp"
#include "integrators/prescribed.hpp"
#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

class RanksLink;  // integrators/ranks_link.hpp

class Simulation;

// The state a step applies and its blow-up check.
struct Advanced {
  double max_speed = HUGE_VAL;  // [m/s] the limit (the caller's): no free quanta may be faster
  std::vector<Vec3> x, v;       // x + dx, v + dv (n), the prescribed quanta placed on their paths
  bool ok = false;              // every value finite and no free quanta faster than max_speed
};

// The blow-up rule for one quanta, in the branch-free form a vector loop takes: add() each
// component of its new position and velocity; bad() is then 1 when a value is not finite (x − x is
// 0 for every finite x, NaN otherwise) or, for a free quanta, |v|² exceeds limit2.
struct QuantaCheck {
  double nan_if_bad = 0, speed2 = 0;
  QBOND_VECTOR_INLINE void add(double x1, double v1) {
    nan_if_bad += (x1 - x1) + (v1 - v1);
    speed2 += v1 * v1;
  }
  QBOND_VECTOR_INLINE std::uint64_t bad(double limit2, bool free) const {
    return static_cast<std::uint64_t>((nan_if_bad != 0) | ((speed2 > limit2) & free));
  }
};

// The same rule, to report a state that breaks it: the first quanta (by index) with a non-finite
// position or velocity, else the fastest free one (the first of equals), found by a reduction over
// fixed chunks (the same on any thread count); and the message naming the step, the quanta (its
// user id) and the value. Empty when the state keeps the rule.
struct Blowup {
  bool found = false;
  Index who = 0;
  std::string message;
};
Blowup find_blowup(const Model& model, std::span<const Vec3> x, std::span<const Vec3> v, double max_speed,
                   const StepContext& ctx, int threads);

// Receives each substep of a step that an integrator takes in substeps (the Newton integrators'
// fallback): the energy ledger charges them one by one, since its whole-step estimate from the
// composite dx, dv would not be what was applied. `p` is the substep's projection from `start`,
// (x1, v1) the state it reached, before the prescribed quanta are put on their paths.
class SubstepLedger {
 public:
  virtual void charge(const Model& model, const State& start, const Adjacency& adj, const Projection& p,
                      std::span<const Vec3> x1, std::span<const Vec3> v1, const std::vector<Vec3>& f_ext,
                      double h) = 0;

 protected:
  ~SubstepLedger() = default;
};

// Every integrator as the integrate stage sees it: the public projection and the private paths.
class StepIntegrator : public Integrator {
 public:
  // Whether advance() takes an empty f_ext for gravity alone, forming m_i g in its own passes:
  // the gather stage then skips the pass that fills it when no load or queued force adds to
  // gravity. (project() of such an integrator takes it too.)
  virtual bool forms_gravity() const { return false; }
  // Takes the step into `to` (against to.max_speed) instead of into out's dx and dv, which may be
  // left empty; `out` still receives the carry-over (Projection::carry). This default projects and
  // applies (apply_checked); an integrator with a fused kernel overrides it.
  virtual void advance(const Model& model, const State& state, const Adjacency& adj,
                       const std::vector<Vec3>& f_ext, const StepContext& ctx, Projection& out, Advanced& to);
  // The ledger that charges each substep of a step taken in substeps (null when it is off).
  void set_substep_ledger(SubstepLedger* ledger) { substeps_ = ledger; }
  // Whether this integrator can retake a step that creates energy in substeps (split_next_step).
  virtual bool splits_gaining_steps() const { return false; }
  // Asks that the next projection be taken in substeps, each split again while it would create
  // energy (Simulation's energy guard, after the whole step created some).
  virtual void split_next_step() {}
  // The quanta whose share of the penalty contacts' books (Projection::contact) the step counts,
  // 1 each, or empty for all: a run over ranks counts each rank's owned quanta (a pair's spring by
  // its first end) and adds the ranks' books up.
  void count_contact_books_of(std::vector<std::uint8_t> quanta) { counted_ = std::move(quanta); }
  // Links the step of one rank's piece to the other ranks' (`link` must outlive it): the hybrid's
  // sweeps and RK4's stages then bring the ghosts' values from their owners between passes.
  void link_to_ranks(RanksLink& link) { ranks_ = &link; }

 protected:
  using Integrator::Integrator;
  // Moves `sub` (the state a step taken in substeps has reached) by one substep's projection `p`
  // of length H to t1: charges the substep to the ledger, when on, and puts the kinematic quanta
  // exactly on their paths (as the step's apply_checked does). x1, v1: buffers.
  void apply_substep(const Model& model, const Adjacency& adj, const std::vector<Vec3>& f_ext, double H, double t1,
                     const Projection& p, State& sub, std::vector<Vec3>& x1, std::vector<Vec3>& v1);

  SubstepLedger* substeps_ = nullptr;
  std::vector<std::uint8_t> counted_;  // count_contact_books_of's
  RanksLink* ranks_ = nullptr;         // link_to_ranks's; null alone

 private:
  PrescribedAt placed_;  // the default advance's
};

// make_integrator's integrators, with their private paths.
std::unique_ptr<StepIntegrator> make_step_integrator(const IntegratorConfig& config);

// Gives `sim` an integrator make_step_integrator does not build (a run over ranks' coupled step,
// whose solve spans the ranks) in place of its own; drops the old one's carry-over.
void replace_step_integrator(Simulation& sim, std::unique_ptr<StepIntegrator> integrator);

// x + dx and v + dv of a projection from `state` into to.x, to.v, the prescribed quanta placed on
// their paths at t1 (place_kinematic, with their range: PrescribedAt), and the rule's verdict into
// to.ok: one branch-free pass over the quanta that vectorises.
void apply_checked(const Model& model, const State& state, const Projection& p, double t1, int threads,
                   PrescribedAt& prescribed, Advanced& to);

// apply_checked for a solve's step, whose free rows are dv = y and dx = h (v + dv)
// (write_free_rows) and whose kinematic rows `kin` holds: the same state and verdict, the free
// rows formed in the pass that adds them instead of written out and read back.
void apply_solved(const Model& model, const State& state, const Projection& kin, const std::vector<Vec3>& y,
                  double h, double t1, int threads, PrescribedAt& prescribed, Advanced& to);

}  // namespace qbond
