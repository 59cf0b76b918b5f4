#include "qbond/heuristics/fracture.hpp"

#include <cmath>

#include "core/parallel.hpp"
#include "heuristics/break_criteria.hpp"
#include "heuristics/breaking.hpp"
#include "heuristics/plastic_flow.hpp"
#include "io/scene/heuristic_entry.hpp"
#include "qbond/analysis/stress.hpp"

namespace qbond {
namespace {

// Whether a rule selecting `quanta` covers bond b (both ends selected). Masks are per quanta, so
// they hold for bonds formed during the run too.
bool applies(const std::vector<std::uint8_t>& quanta, const Bonds& bonds, std::size_t b) {
  return quanta.empty() || (quanta[bonds.i[b]] && quanta[bonds.j[b]]);
}

class BreakHeuristic final : public Heuristic {
 public:
  explicit BreakHeuristic(BreakRule r) : rule_(std::move(r)) {}
  std::string_view name() const override { return "break"; }

  void apply(const Model& m, State& s, Projection& p, const HeuristicContext& ctx) override {
    // Which bonds are over a threshold is independent per bond (parallel); the draws and breaks
    // then go in bond order, so the outcome depends on the seed only.
    const std::vector<std::uint8_t>& why = criteria_.evaluate(rule_, m, s, p, ctx.threads);
    for (std::size_t b = 0; b < why.size(); ++b) {
      if (why[b] == BreakCriteria::kNone) continue;
      if (rule_.probability < 1 && !(s.rng.uniform() < rule_.probability)) continue;
      break_now(m, s, ctx.step, ctx.events, b, stretch(m, s, p, b), static_cast<BondEvent::Reason>(why[b]));
    }
  }

 private:
  BreakRule rule_;
  BreakCriteria criteria_;
};

class PlasticHeuristic final : public Heuristic {
 public:
  explicit PlasticHeuristic(PlasticRule r) : rule_(std::move(r)) {}
  std::string_view name() const override { return "plastic"; }

  void apply(const Model& m, State& s, Projection& p, const HeuristicContext& ctx) override {
    const std::vector<std::uint8_t>& edit = flow_.flow(rule_, m, s, p, ctx.threads);
    for (std::size_t b = 0; b < edit.size(); ++b) {
      p.bonds_edited |= edit[b] != PlasticFlow::kKept;
      if (edit[b] == PlasticFlow::kDuctile)
        break_now(m, s, ctx.step, ctx.events, b, stretch(m, s, p, b), BondEvent::Reason::ductility);
    }
  }

 private:
  PlasticRule rule_;
  PlasticFlow flow_;
};

}  // namespace

const std::vector<std::uint8_t>& BreakCriteria::evaluate(const BreakRule& rule, const Model& m, const State& s,
                                                         const Projection& p, int threads,
                                                         std::span<const Mat3> stress) {
  const Bonds& bonds = s.bonds;
  const std::size_t nb = bonds.size();
  why_.resize(nb);
  const bool by_stress = rule.reads_stress();
  if (by_stress) {
    const std::size_t n = m.num_quanta();
    x_.resize(n);
    for (std::size_t i = 0; i < n; ++i) x_[i] = s.x[i] + p.dx[i];
    if (stress.empty()) {
      v_.resize(n);
      for (std::size_t i = 0; i < n; ++i) v_[i] = s.v[i] + p.dv[i];
      virial_stress(m, s, x_, v_, sigma_);
      stress = sigma_;
    }
  }
  parallel_for(nb, bond_pass_threads(m.num_quanta(), threads), [&](std::size_t b) {
    why_[b] = kNone;
    if (!bonds.alive[b]) return;
    if (!applies(rule.quanta, bonds, b)) return;
    const Stretch st = stretch(m, s, p, b);
    // A bond past its law's failure stretch fails (the break_failed_bonds stage), whatever the rule.
    if (law_breaks(bonds.law[b]) && past_failure(m, s, b, st)) return;
    if (st.strain > rule.max_strain)
      why_[b] = static_cast<std::uint8_t>(BondEvent::Reason::strain);
    else if (-st.strain > rule.max_compression)
      why_[b] = static_cast<std::uint8_t>(BondEvent::Reason::compression);
    else if (st.tension > rule.max_tension)
      why_[b] = static_cast<std::uint8_t>(BondEvent::Reason::tension);
    else if (by_stress) {
      const Index i = bonds.i[b], j = bonds.j[b];
      const Vec3 n = (x_[j] - x_[i]).normalized();
      if (0.5 * n.dot((stress[i] + stress[j]) * n) > rule.max_stress)
        why_[b] = static_cast<std::uint8_t>(BondEvent::Reason::stress);
      else if (0.5 * (von_mises(stress[i]) + von_mises(stress[j])) > rule.max_von_mises)
        why_[b] = static_cast<std::uint8_t>(BondEvent::Reason::von_mises);
    }
  });
  return why_;
}

const std::vector<std::uint8_t>& PlasticFlow::flow(const PlasticRule& rule, const Model& m, State& s,
                                                   const Projection& p, int threads) {
  Bonds& bonds = s.bonds;  // rest lengths only: no topology change
  const std::size_t nb = bonds.size();
  edit_.resize(nb);
  // Each bond's flow is its own; the energy it releases is summed in a fixed order.
  s.energy.dissipated_heuristics +=
      deterministic_sum(nb, bond_pass_threads(m.num_quanta(), threads), [&](std::size_t b) {
        edit_[b] = kKept;
        if (!bonds.alive[b] || !applies(rule.quanta, bonds, b)) return 0.0;
        const double L0 = bonds.rest0[b], L = bonds.rest[b];
        const Stretch st = stretch(m, s, p, b);
        const double L1 = plastic_rest_length(rule, st.r, L, L0);
        if (L1 == L) return 0.0;
        bonds.rest[b] = L1;
        edit_[b] = std::abs(L1 - L0) > rule.max_plastic_strain * L0 ? kDuctile : kFlowed;
        return bonds.law_at(m.shapes, b, st.r, L).U - bonds.law_at(m.shapes, b, st.r, L1).U;
      });
  return edit_;
}

double plastic_rest_length(const PlasticRule& rule, double r, double L, double L0) {
  if (!(L0 > 0)) return L;
  const double a = rule.hardening;
  const double c = a / (1 - a);
  const double over = (r - L) / L0 - c * (L - L0) / L0;  // e - c p
  if (std::abs(over) <= rule.yield_strain) return L;
  const double sign = over > 0 ? 1.0 : -1.0;
  return (r + c * L0 - sign * rule.yield_strain * L0) / (1 + c);
}

std::unique_ptr<Heuristic> make_heuristic(BreakRule rule) {
  return std::make_unique<BreakHeuristic>(std::move(rule));
}

std::unique_ptr<Heuristic> make_heuristic(PlasticRule rule) {
  return std::make_unique<PlasticHeuristic>(std::move(rule));
}

}  // namespace qbond

// ---- Scene types: `break` and `plastic` ------------------------------------------------------

namespace qbond::scene_detail {

std::span<const HeuristicReader> scene_readers(std::type_identity<BreakRule>) {
  static const HeuristicReader rows[] = {
      {"break", "fracture: bonds break past a strain, compression, tension or stress limit",
       {{"max_strain", "number"},
        {"max_compression", "number"},
        {"max_tension", "number"},
        {"max_stress", "number"},
        {"max_von_mises", "number"},
        {"type", "string"},
        {"probability", "number"},
        {"select", "@selection"}},
       [](const HeuristicEntry& e) {
         const Obj& o = e.o;
         static const std::initializer_list<const char*> limits = {"max_strain", "max_compression", "max_tension",
                                                                   "max_stress", "max_von_mises"};
         BreakRule r;
         double* fields[] = {&r.max_strain, &r.max_compression, &r.max_tension, &r.max_stress, &r.max_von_mises};
         bool any = false;
         for (std::size_t f = 0; f < limits.size(); ++f) {
           const char* key = limits.begin()[f];
           if (!o.has(key)) continue;
           *fields[f] = positive(o[key], o.at(key));
           any = true;
         }
         if (!any) bad(o.path(), "give at least one of " + join(std::vector<std::string>(limits.begin(), limits.end())));
         if ((o.has("max_stress") || o.has("max_von_mises")) &&
             std::none_of(e.w.model.volume.begin(), e.w.model.volume.end(), [](double v) { return v > 0; }))
           bad(o.path(), "stress limits need quanta with volumes (lattice, sheet and chain bodies have them; "
                         "give 'quanta' bodies a 'volume')");
         if (o.has("probability")) {
           r.probability = positive(o["probability"], o.at("probability"));
           if (r.probability > 1) bad(o.at("probability"), "must be <= 1, got " + num_str(r.probability));
         }
         r.quanta = e.quanta_mask();
         e.out.emplace_back(std::move(r));
       }},
  };
  return rows;
}

std::span<const HeuristicReader> scene_readers(std::type_identity<PlasticRule>) {
  static const HeuristicReader rows[] = {
      {"plastic", "plasticity: bilinear elastoplastic bonds with kinematic hardening",
       {{"type", "string"},
        {"yield_strain", "number"},
        {"hardening", "number"},
        {"max_plastic_strain", "number"},
        {"select", "@selection"}},
       [](const HeuristicEntry& e) {
         const Obj& o = e.o;
         PlasticRule r;
         r.yield_strain = positive(o.required("yield_strain"), o.at("yield_strain"));
         if (o.has("hardening")) {
           r.hardening = non_negative(o["hardening"], o.at("hardening"));
           if (r.hardening >= 1) bad(o.at("hardening"), "must be < 1, got " + num_str(r.hardening));
         }
         if (o.has("max_plastic_strain"))
           r.max_plastic_strain = positive(o["max_plastic_strain"], o.at("max_plastic_strain"));
         r.quanta = e.quanta_mask();
         e.out.emplace_back(std::move(r));
       }},
  };
  return rows;
}

}  // namespace qbond::scene_detail
