#include "qbond/heuristics/heuristics.hpp"

#include "qbond/heuristics/registry.hpp"

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
  return std::visit([](const auto& rule) { return make_heuristic(rule); }, spec);
}

}  // namespace qbond
