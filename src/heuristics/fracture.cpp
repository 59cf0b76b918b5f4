#include "qbond/heuristics/fracture.hpp"

#include <cmath>

#include "core/parallel.hpp"
#include "qbond/analysis/stress.hpp"

namespace qbond {
namespace {

// Whether a rule selecting `quanta` covers bond b (both ends selected). Masks are per quanta, so
// they hold for bonds formed during the run too.
bool applies(const std::vector<std::uint8_t>& quanta, const Bonds& bonds, std::size_t b) {
  return quanta.empty() || (quanta[bonds.i[b]] && quanta[bonds.j[b]]);
}

// Length, strain and elastic tension of bond b at the projected end-of-step positions.
struct Stretch {
  double r = 0, strain = 0, tension = 0;
};
Stretch stretch(const Model& m, const State& s, const Projection& p, std::size_t b) {
  Stretch st;
  st.r = (projected(s, p, s.bonds.j[b]) - projected(s, p, s.bonds.i[b])).norm();
  const double L = s.bonds.rest[b];
  st.strain = L > 0 ? (st.r - L) / L : 0.0;
  st.tension = s.bonds.law_at(m.shapes, b, st.r, L).T;
  return st;
}

// Breaks bond b at the end of this step: records the event and charges its stored energy.
void break_now(const Model& m, State& s, const HeuristicContext& ctx, std::size_t b, const Stretch& st,
               BondEvent::Reason why) {
  s.energy.dissipated_heuristics += s.bonds.law_at(m.shapes, b, st.r, s.bonds.rest[b]).U;
  s.break_bond(static_cast<Index>(b));
  BondEvent e;
  e.kind = BondEvent::Kind::broken;
  e.reason = why;
  e.step = ctx.step.step;
  e.time = ctx.step.t + ctx.step.h;
  e.bond = static_cast<Index>(b);
  e.i = s.bonds.i[b];
  e.j = s.bonds.j[b];
  e.strain = st.strain;
  e.tension = st.tension;
  ctx.events.push_back(e);
}

class BreakHeuristic final : public Heuristic {
 public:
  explicit BreakHeuristic(BreakRule r) : rule_(std::move(r)) {}
  std::string_view name() const override { return "break"; }

  void apply(const Model& m, State& s, Projection& p, const HeuristicContext& ctx) override {
    const Bonds& bonds = s.bonds;
    const std::size_t nb = bonds.size();
    // Which bonds are over a threshold is independent per bond (parallel); the draws and breaks
    // then go in bond order, so the outcome depends on the seed only.
    why_.resize(nb);
    const bool by_stress = std::isfinite(rule_.max_stress) || std::isfinite(rule_.max_von_mises);
    if (by_stress) {
      const std::size_t n = m.num_quanta();
      x_.resize(n);
      v_.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        x_[i] = s.x[i] + p.dx[i];
        v_[i] = s.v[i] + p.dv[i];
      }
      virial_stress(m, s, x_, v_, sigma_);
    }
    parallel_for(nb, bond_pass_threads(m.num_quanta(), ctx.threads), [&](std::size_t b) {
      why_[b] = kNone;
      if (!bonds.alive[b]) return;
      const bool can_fail = law_breaks(bonds.law[b]);
      if (!can_fail && !applies(rule_.quanta, bonds, b)) return;
      const Stretch st = stretch(m, s, p, b);
      if (can_fail && st.r - bonds.rest[b] >= bonds.failure_stretch_at(m.shapes, b, bonds.rest[b])) {
        why_[b] = static_cast<std::uint8_t>(BondEvent::Reason::failure);
        return;
      }
      if (!applies(rule_.quanta, bonds, b)) return;
      if (st.strain > rule_.max_strain)
        why_[b] = static_cast<std::uint8_t>(BondEvent::Reason::strain);
      else if (-st.strain > rule_.max_compression)
        why_[b] = static_cast<std::uint8_t>(BondEvent::Reason::compression);
      else if (st.tension > rule_.max_tension)
        why_[b] = static_cast<std::uint8_t>(BondEvent::Reason::tension);
      else if (by_stress) {
        const Index i = bonds.i[b], j = bonds.j[b];
        const Vec3 n = (x_[j] - x_[i]).normalized();
        if (0.5 * n.dot((sigma_[i] + sigma_[j]) * n) > rule_.max_stress)
          why_[b] = static_cast<std::uint8_t>(BondEvent::Reason::stress);
        else if (0.5 * (von_mises(sigma_[i]) + von_mises(sigma_[j])) > rule_.max_von_mises)
          why_[b] = static_cast<std::uint8_t>(BondEvent::Reason::von_mises);
      }
    });
    for (std::size_t b = 0; b < nb; ++b) {
      if (why_[b] == kNone) continue;
      const bool failed = why_[b] == static_cast<std::uint8_t>(BondEvent::Reason::failure);
      if (!failed && rule_.probability < 1 && !(s.rng.uniform() < rule_.probability)) continue;
      break_now(m, s, ctx, b, stretch(m, s, p, b), static_cast<BondEvent::Reason>(why_[b]));
    }
  }

 private:
  static constexpr std::uint8_t kNone = 0xff;
  BreakRule rule_;
  std::vector<std::uint8_t> why_;  // per bond: the reason it is over a threshold, or kNone
  std::vector<Vec3> x_, v_;        // projected state, for the stress criteria
  std::vector<Mat3> sigma_;
};

class PlasticHeuristic final : public Heuristic {
 public:
  explicit PlasticHeuristic(PlasticRule r) : rule_(std::move(r)) {}
  std::string_view name() const override { return "plastic"; }

  void apply(const Model& m, State& s, Projection& p, const HeuristicContext& ctx) override {
    Bonds& bonds = s.bonds;  // rest lengths only: no topology change
    const std::size_t nb = bonds.size();
    edit_.resize(nb);
    // Each bond's flow is its own; the energy it releases is summed in a fixed order.
    const double released =
        deterministic_sum(nb, bond_pass_threads(m.num_quanta(), ctx.threads), [&](std::size_t b) {
          edit_[b] = kKept;
          if (!bonds.alive[b] || !applies(rule_.quanta, bonds, b)) return 0.0;
          const double L0 = bonds.rest0[b], L = bonds.rest[b];
          const Stretch st = stretch(m, s, p, b);
          const double L1 = plastic_rest_length(rule_, st.r, L, L0);
          if (L1 == L) return 0.0;
          bonds.rest[b] = L1;
          edit_[b] = std::abs(L1 - L0) > rule_.max_plastic_strain * L0 ? kDuctile : kFlowed;
          return bonds.law_at(m.shapes, b, st.r, L).U - bonds.law_at(m.shapes, b, st.r, L1).U;
        });
    s.energy.dissipated_heuristics += released;
    for (std::size_t b = 0; b < nb; ++b) {
      p.bonds_edited |= edit_[b] != kKept;
      if (edit_[b] == kDuctile) break_now(m, s, ctx, b, stretch(m, s, p, b), BondEvent::Reason::ductility);
    }
  }

 private:
  enum : std::uint8_t { kKept, kFlowed, kDuctile };
  PlasticRule rule_;
  std::vector<std::uint8_t> edit_;  // per bond this step: rest length kept, flowed, or past the ductility limit
};

}  // namespace

double plastic_rest_length(const PlasticRule& rule, double r, double L, double L0) {
  if (!(L0 > 0)) return L;
  const double a = rule.hardening;
  const double c = a / (1 - a);
  const double over = (r - L) / L0 - c * (L - L0) / L0;  // e - c p
  if (std::abs(over) <= rule.yield_strain) return L;
  const double sign = over > 0 ? 1.0 : -1.0;
  return (r + c * L0 - sign * rule.yield_strain * L0) / (1 + c);
}

std::unique_ptr<Heuristic> make_break_heuristic(BreakRule rule) {
  return std::make_unique<BreakHeuristic>(std::move(rule));
}

std::unique_ptr<Heuristic> make_plastic_heuristic(PlasticRule rule) {
  return std::make_unique<PlasticHeuristic>(std::move(rule));
}

}  // namespace qbond
