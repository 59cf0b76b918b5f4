#pragma once
// Breaking a bond at the projected end of a step, as fracture, ductility and a law's own failure
// do it: the bond's stretch there, and the break recorded as an event with its stored energy
// charged as dissipated.
#include <vector>

#include "qbond/heuristics/heuristics.hpp"

namespace qbond {

// Length, strain and elastic tension of bond b at the projected end-of-step positions.
struct Stretch {
  double r = 0, strain = 0, tension = 0;
};

inline Stretch stretch(const Model& m, const State& s, const Projection& p, std::size_t b) {
  Stretch st;
  st.r = (projected(s, p, s.bonds.j[b]) - projected(s, p, s.bonds.i[b])).norm();
  const double L = s.bonds.rest[b];
  st.strain = L > 0 ? (st.r - L) / L : 0.0;
  st.tension = s.bonds.law_at(m.shapes, b, st.r, L).T;
  return st;
}

// Whether bond b has reached its law's failure stretch (the cohesive law's s_f) at `st`.
inline bool past_failure(const Model& m, const State& s, std::size_t b, const Stretch& st) {
  return st.r - s.bonds.rest[b] >= s.bonds.failure_stretch_at(m.shapes, b, s.bonds.rest[b]);
}

// Breaks bond b at the end of this step: records the event and charges its stored energy at
// the projected length (for a failed cohesive bond, its fracture energy G).
inline void break_now(const Model& m, State& s, const StepContext& step, std::vector<BondEvent>& events,
                      std::size_t b, const Stretch& st, BondEvent::Reason why) {
  s.energy.dissipated_heuristics += s.bonds.law_at(m.shapes, b, st.r, s.bonds.rest[b]).U;
  s.break_bond(static_cast<Index>(b));
  BondEvent e;
  e.kind = BondEvent::Kind::broken;
  e.reason = why;
  e.step = step.step;
  e.time = step.t + step.h;
  e.bond = static_cast<Index>(b);
  e.i = s.bonds.i[b];
  e.j = s.bonds.j[b];
  e.strain = st.strain;
  e.tension = st.tension;
  events.push_back(e);
}

}  // namespace qbond
