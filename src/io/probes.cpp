#include "qbond/io/probes.hpp"

#include <algorithm>

#include "qbond/laws/laws.hpp"
#include "qbond/analysis/stress.hpp"

namespace qbond {

bool has_reaction(const Model& model, const Probe& probe) {
  return !probe.quanta.empty() &&
         std::all_of(probe.quanta.begin(), probe.quanta.end(), [&](Index i) { return model.is_kinematic(i); });
}

bool has_stress(const Model& model, const Probe& probe) {
  return std::any_of(probe.quanta.begin(), probe.quanta.end(), [&](Index i) { return model.volume[i] > 0; });
}

ProbeValue measure_probe(const Model& model, const State& state, const Probe& probe, std::span<const Mat3> sigma) {
  ProbeValue v;
  if (probe.quanta.empty()) return v;
  for (Index i : probe.quanta) v.mean += state.x[i];
  v.mean /= static_cast<double>(probe.quanta.size());
  v.has_stress = has_stress(model, probe);
  if (v.has_stress) {
    std::vector<Mat3> own;
    if (sigma.empty()) {
      virial_stress(model, state, own);
      sigma = own;
    }
    v.stress = mean_stress(model, sigma, probe.quanta);
    for (Index i : probe.quanta) v.von_mises_max = std::max(v.von_mises_max, von_mises(sigma[i]));
  }
  v.has_reaction = has_reaction(model, probe);
  if (!v.has_reaction) return v;
  std::vector<std::uint8_t> in(model.num_quanta(), 0);
  for (Index i : probe.quanta) in[i] = 1;
  const Vec3 c = probe.about.value_or(v.mean);
  // Bonds inside the selection pull both ends equally and oppositely: they cancel in the sums.
  for (std::size_t b = 0; b < state.bonds.size(); ++b) {
    if (!state.bonds.alive[b]) continue;
    const Index i = state.bonds.i[b], j = state.bonds.j[b];
    if (in[i] == in[j]) continue;
    const Vec3 fi = state.bonds.force_on_i(model.shapes, b, state.x[j] - state.x[i], state.v[j] - state.v[i],
                                           state.bonds.rest[b]);
    const Index q = in[i] ? i : j;  // the probe's end of the bond
    const Vec3 f = in[i] ? fi : Vec3(-fi);
    v.force -= f;
    v.torque -= (state.x[q] - c).cross(f);
  }
  return v;
}

}  // namespace qbond
