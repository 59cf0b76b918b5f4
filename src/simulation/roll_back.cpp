#include "simulation/stages.hpp"

namespace qbond::stage {

namespace {

// Arrays moved out of a state and back, so that a copy of the state leaves them out: positions,
// velocities and the integrator's carry-over (always: see copy_last_good below) and, with `with_bonds`,
// the bonds.
struct KeptArrays {
  std::vector<Vec3> x, v;
  Carry carry;
  Bonds bonds;
  KeptArrays(State& s, bool with_bonds) : x(std::move(s.x)), v(std::move(s.v)) {
    carry.swap(s.carry);
    if (with_bonds) bonds = std::move(s.bonds);
  }
  void put_back(State& s, bool with_bonds) {
    s.x = std::move(x);
    s.v = std::move(v);
    s.carry.swap(carry);
    if (with_bonds) s.bonds = std::move(bonds);
  }
};

// The state before the step into k.last_good (save), or back from it; applied: the step's
// positions, velocities and carry-over are already in the state (apply), the ones before it in
// the scratch's next state and the projection.
void copy_last_good(State& s, bool save, bool applied, StepScratch& k) {
  // Only heuristics edit bonds during a step: without them the copy leaves out the bond arrays,
  // most of a lattice's state, and the world's state keeps its own. Positions, velocities and the
  // carry-over are never copied: until apply swaps in the step's own they are the ones before the
  // step, and after the swap the scratch's next state and the projection hold those.
  const bool bonds = !k.last_good_has_bonds;
  KeptArrays kept(s, bonds);
  if (save)
    k.last_good = s;
  else
    s = k.last_good;
  kept.put_back(s, bonds);
  if (applied) {
    s.x.swap(k.next.x);
    s.v.swap(k.next.v);
    s.carry.swap(k.projection.carry);
  }
}

}  // namespace

void save_last_good(State& state, bool with_bonds, StepScratch& k) {
  k.last_good_has_bonds = with_bonds;
  copy_last_good(state, true, false, k);
}

StepReport roll_back(StepReport r, State& state, bool applied, StepScratch& k) {
  copy_last_good(state, false, applied, k);  // heuristics may have edited bonds already
  k.events.clear();
  if (applied) r.message += "; the world keeps the state before this step";
  return r;
}

}  // namespace qbond::stage
