#include "qbond/heuristics/formation.hpp"

#include <algorithm>
#include <unordered_set>

#include "heuristics/formation_pass.hpp"
#include "io/scene/heuristic_entry.hpp"

namespace qbond {
namespace {

std::uint64_t pair_key(Index a, Index b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

class FormHeuristic final : public Heuristic {
 public:
  explicit FormHeuristic(FormRule r) : rule_(std::move(r)) {}
  std::string_view name() const override { return "form"; }

  void bind(Model& model) override { law_ = bond_law(model, rule_.bond); }

  void apply(const Model& m, State& s, Projection& p, const HeuristicContext& ctx) override {
    // Earlier rules of this step may have changed the bonds: count from the current ones.
    const Adjacency* adj = &ctx.adj;
    if (ctx.adj.version != s.topology_version()) {
      build_adjacency(m, s, own_adj_);
      adj = &own_adj_;
    }
    pos_.resize(m.num_quanta());
    for (std::size_t i = 0; i < pos_.size(); ++i) pos_[i] = projected(s, p, static_cast<Index>(i));
    pass_.run(rule_, law_, m, s, *adj, pos_, {}, ctx.step, ctx.events);
  }

 private:
  FormRule rule_;
  BondLaw law_;  // rule_.bond with its shape's row in the model (bind)
  Adjacency own_adj_;
  std::vector<Vec3> pos_;
  FormationPass pass_;
};

}  // namespace

std::size_t FormationPass::run(const FormRule& rule, const BondLaw& law, const Model& m, State& s,
                               const Adjacency& adj, const std::vector<Vec3>& pos, std::span<const Index> ids,
                               const StepContext& step, std::vector<BondEvent>& events) {
  const std::size_t n = m.num_quanta();
  const Bonds& bonds = s.bonds;
  auto id = [&](Index a) { return ids.empty() ? a : ids[a]; };
  // Per quanta, its alive formed bonds; pairs whose bond broke within min_age; the broken formed
  // slots to reuse, in order.
  degree_.assign(n, 0);
  recent_.clear();
  free_.clear();
  for (std::size_t b = 0; b < bonds.size(); ++b) {
    if (bonds.alive[b]) {
      if (b >= bonds.first_formed) {
        ++degree_[bonds.i[b]];
        ++degree_[bonds.j[b]];
      }
      continue;
    }
    if (rule.min_age > 0 && bonds.time[b] > s.time - rule.min_age) recent_.insert(pair_key(bonds.i[b], bonds.j[b]));
    if (b >= bonds.first_formed) free_.push_back(static_cast<Index>(b));
  }
  pairs_.clear();
  grid_.build(pos, rule.capture_radius);
  grid_.pairs(pos, [&](Index a, Index c) {
    const Index i = id(a), j = id(c);
    if (!rule.quanta.empty() && !(rule.quanta[i] && rule.quanta[j])) return;
    if (m.is_kinematic(i) && m.is_kinematic(j)) return;
    if (rule.pairs == FormPairs::same_body && m.body[i] != m.body[j]) return;
    if (rule.pairs == FormPairs::other_body && m.body[i] == m.body[j]) return;
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e)
      if (adj.other[e] == j) return;
    if (!recent_.empty() && recent_.count(pair_key(i, j))) return;
    pairs_.emplace_back(a, c);
  });
  std::size_t next_free = 0, made = 0;
  for (const auto& [a, c] : pairs_) {
    const Index i = id(a), j = id(c);
    if (rule.max_bonds > 0 &&
        (degree_[i] >= static_cast<Index>(rule.max_bonds) || degree_[j] >= static_cast<Index>(rule.max_bonds)))
      continue;
    const double r = (pos[c] - pos[a]).norm();
    const double L = rule.rest_length >= 0 ? rule.rest_length : r;
    const Index slot = next_free < free_.size() ? free_[next_free++] : static_cast<Index>(bonds.size());
    const Index b = s.form_bond(i, j, law, L, slot);
    ++made;
    ++degree_[i];
    ++degree_[j];
    const LawValue lv = bonds.law_at(m.shapes, b, r, L);
    s.energy.dissipated_heuristics -= lv.U;  // energy the new bond holds was added by the rule
    BondEvent e;
    e.kind = BondEvent::Kind::formed;
    e.reason = BondEvent::Reason::capture;
    e.step = step.step;
    e.time = step.t + step.h;
    e.bond = b;
    e.i = i;
    e.j = j;
    e.strain = L > 0 ? (r - L) / L : 0.0;
    e.tension = lv.T;
    events.push_back(e);
  }
  return made;
}

std::unique_ptr<Heuristic> make_heuristic(FormRule rule) {
  if (!(rule.capture_radius > 0)) throw std::invalid_argument("form: capture_radius must be > 0");
  return std::make_unique<FormHeuristic>(std::move(rule));
}

}  // namespace qbond

// ---- Scene types: `form` and `liquid` --------------------------------------------------------

namespace qbond::scene_detail {

std::span<const HeuristicReader> scene_readers(std::type_identity<FormRule>) {
  // The shape of a law the rule's bonds follow joins the model's table while the world is built,
  // so a step never writes it (the heuristic's bind() finds it there).
  static const HeuristicReader rows[] = {
      {"form", "bond formation: quanta that come close bond",
       {{"type", "string"},
        {"capture_radius", "number"},
        {"pairs", "enum:any|same_body|other_body"},
        {"max_bonds", "integer"},
        {"min_age", "number"},
        {"rest_length", "number"},
        {"material", "string"},
        {"select", "@selection"}},
       [](const HeuristicEntry& e) {
         const Obj& o = e.o;
         FormRule r;
         r.capture_radius = positive(o.required("capture_radius"), o.at("capture_radius"));
         if (o.has("pairs"))
           r.pairs = choice<FormPairs>(o["pairs"], o.at("pairs"),
                                       {{"any", FormPairs::any},
                                        {"same_body", FormPairs::same_body},
                                        {"other_body", FormPairs::other_body}});
         if (o.has("max_bonds")) r.max_bonds = static_cast<int>(integer(o["max_bonds"], o.at("max_bonds"), 1));
         if (o.has("min_age")) r.min_age = non_negative(o["min_age"], o.at("min_age"));
         if (o.has("rest_length")) r.rest_length = positive(o["rest_length"], o.at("rest_length"));
         r.bond = e.bond_material("material");
         bond_law(e.w.model, r.bond);
         r.quanta = e.quanta_mask();
         e.out.emplace_back(std::move(r));
       }},
      {"liquid", "a cohesive liquid: a break rule and a form rule at the liquid's spacing",
       {{"type", "string"},
        {"spacing", "number"},
        {"max_strain", "number"},
        {"capture_radius", "number"},
        {"max_bonds", "integer"},
        {"material", "string"},
        {"select", "@selection"}},
       [](const HeuristicEntry& e) {
         const Obj& o = e.o;
         // A preset: bonds break past max_strain and form again within the capture radius, at the
         // rest length `spacing` the liquid keeps between its quanta (its density).
         const double a = positive(o.required("spacing"), o.at("spacing"));
         BreakRule br;
         br.max_strain = o.has("max_strain") ? positive(o["max_strain"], o.at("max_strain")) : 0.3;
         FormRule fr;
         fr.capture_radius = o.has("capture_radius") ? positive(o["capture_radius"], o.at("capture_radius")) : 1.2 * a;
         if (fr.capture_radius >= a * (1 + br.max_strain))
           bad(o.at("capture_radius"), "must be below spacing x (1 + max_strain) = " +
                                           num_str(a * (1 + br.max_strain)) + " m, or new bonds would break at once");
         fr.max_bonds = o.has("max_bonds") ? static_cast<int>(integer(o["max_bonds"], o.at("max_bonds"), 1)) : 12;
         fr.rest_length = a;
         fr.bond = e.bond_material("material");
         bond_law(e.w.model, fr.bond);
         br.quanta = fr.quanta = e.quanta_mask();
         e.out.emplace_back(std::move(br));
         e.out.emplace_back(std::move(fr));
       }},
  };
  return rows;
}

}  // namespace qbond::scene_detail
