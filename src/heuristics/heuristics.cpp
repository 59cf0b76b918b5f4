#include "qbond/heuristics/heuristics.hpp"

#include "qbond/io/scene.hpp"

namespace qbond {

std::string_view to_string(BondEvent::Kind k) {
  switch (k) {
    case BondEvent::Kind::broken: return "broken";
    case BondEvent::Kind::formed: return "formed";
  }
  return "?";
}

std::string_view to_string(BondEvent::Reason r) {
  switch (r) {
    case BondEvent::Reason::strain: return "strain";
    case BondEvent::Reason::compression: return "compression";
    case BondEvent::Reason::tension: return "tension";
    case BondEvent::Reason::ductility: return "ductility";
    case BondEvent::Reason::stress: return "stress";
    case BondEvent::Reason::von_mises: return "von_mises";
    case BondEvent::Reason::capture: return "capture";
    case BondEvent::Reason::failure: return "failure";
  }
  return "?";
}

std::unique_ptr<Heuristic> make_heuristic(const HeuristicSpec& spec) {
  struct Make {
    std::unique_ptr<Heuristic> operator()(const BreakRule& r) const { return make_break_heuristic(r); }
    std::unique_ptr<Heuristic> operator()(const PlasticRule& r) const { return make_plastic_heuristic(r); }
    std::unique_ptr<Heuristic> operator()(const Obstacle& o) const { return make_obstacle_heuristic({o}); }
    std::unique_ptr<Heuristic> operator()(const QuantaContactRule& r) const { return make_quanta_contact_heuristic(r); }
    std::unique_ptr<Heuristic> operator()(const FormRule& r) const { return make_form_heuristic(r); }
  };
  return std::visit(Make{}, spec);
}

}  // namespace qbond
