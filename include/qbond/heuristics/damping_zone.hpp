#pragma once
/// A damping zone (docs/heuristics.md): quanta inside a box lose velocity at a set rate — an
/// absorbing layer that keeps waves from reflecting off a lattice's cut edge, or a drag region.
/// The whole rule lives in this header: its parameters, its step, its factory and its scene type.
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "qbond/heuristics/heuristics.hpp"

namespace qbond {

/// Free quanta whose projected end-of-step position lies in the axis-aligned box center ± size/2
/// end the step with their velocity scaled by e^{−rate h}, the exact solution over the step of
/// dv/dt = −rate v applied after the integrator's step; positions stay as projected. The kinetic
/// energy removed, ½ m |v₁|² (1 − e^{−2 rate h}), is charged as dissipated.
struct DampingZone {
  Vec3 center = Vec3::Zero();          ///< [m]
  Vec3 size = Vec3::Zero();            ///< [m] the box's edges, each > 0
  double rate = 0;                     ///< [1/s] > 0
  std::vector<std::uint8_t> quanta{};  ///< per quanta: 1 when it may be damped (empty: all)

  /// Its scene type: the name, one line on it, and the keys it accepts with what each holds.
  static constexpr std::string_view scene_type = "damping_zone";
  static constexpr std::string_view scene_doc = "a box in which free quanta lose velocity at a set rate";
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 5> scene_keys{
      {{"type", "string"},
       {"center", "vec3"},
       {"size", "vec3"},
       {"rate", "number"},
       {"select", "@selection"}}};
  /// The rule an entry of that type describes. `Entry` is the scene reader's entry, which reads
  /// and checks keys by name and throws naming the entry's path.
  template <class Entry>
  static DampingZone from_scene(const Entry& e) {
    DampingZone z;
    z.center = e.vec3("center");
    z.size = e.vec3("size");
    if (!(z.size.minCoeff() > 0)) e.bad("size", "every edge must be > 0");
    z.rate = e.positive("rate");
    z.quanta = e.quanta_mask();
    return z;
  }
};

namespace heuristics_detail {

class DampingZoneHeuristic final : public Heuristic {
 public:
  explicit DampingZoneHeuristic(DampingZone zone) : zone_(std::move(zone)), half_(0.5 * zone_.size) {}
  std::string_view name() const override { return DampingZone::scene_type; }

  void apply(const Model& m, State& s, Projection& p, const HeuristicContext& ctx) override {
    const double keep = std::exp(-zone_.rate * ctx.step.h);
    double removed = 0;  // summed in quanta order: the same bits on any thread count
    for (std::size_t q = 0; q < m.num_quanta(); ++q) {
      const Index i = static_cast<Index>(q);
      if (m.is_kinematic(i) || (!zone_.quanta.empty() && !zone_.quanta[q])) continue;
      if (((projected(s, p, i) - zone_.center).cwiseAbs() - half_).maxCoeff() > 0) continue;
      const Vec3 v1 = s.v[q] + p.dv[q];
      p.dv[q] = keep * v1 - s.v[q];
      if (ctx.counted.empty() || ctx.counted[q]) removed += 0.5 * m.mass[q] * v1.squaredNorm();
    }
    // 1 − keep², without cancellation at small rate h
    s.energy.dissipated_heuristics += removed * -std::expm1(-2 * zone_.rate * ctx.step.h);
  }

 private:
  DampingZone zone_;
  Vec3 half_;
};

}  // namespace heuristics_detail

/// The damping zone's rule; throws std::invalid_argument unless every edge and the rate are > 0.
inline std::unique_ptr<Heuristic> make_heuristic(DampingZone zone) {
  if (!(zone.size.minCoeff() > 0))
    throw std::invalid_argument("damping_zone: every edge of size must be > 0");
  if (!(zone.rate > 0)) throw std::invalid_argument("damping_zone: rate must be > 0");
  return std::make_unique<heuristics_detail::DampingZoneHeuristic>(std::move(zone));
}

}  // namespace qbond
