#include "qbond/io/diagnostics.hpp"

#include <algorithm>
#include <cstdio>
#include <limits>

#include "qbond/analysis/analysis.hpp"
#include "qbond/analysis/stress.hpp"

namespace qbond {
namespace {

void put(std::string& out, double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, ",%.17g", v);
  out += buf;
}

void put_count(std::string& out, std::size_t v) {
  out += ',';
  out += std::to_string(v);
}

void put(std::string& out, const Vec3& v) {
  for (int k = 0; k < 3; ++k) put(out, v[k]);
}

}  // namespace

Diagnostics::Diagnostics(const Model& model, std::vector<Probe> probes, std::vector<Obstacle> obstacles)
    : probes_(std::move(probes)), contact_columns_(model.solves_contact()) {
  for (Obstacle& o : obstacles)
    if (o.record >= 0) obstacles_.push_back(std::move(o));
  for (const Probe& p : probes_) {
    reaction_.push_back(has_reaction(model, p));
    stress_.push_back(has_stress(model, p));
  }
}

std::string Diagnostics::header() const {
  std::string h = "step,time,kinetic,potential,dissipated,total,px,py,pz,lx,ly,lz,max_speed,bonds_alive,bonds_broken";
  for (std::size_t k = 0; k < probes_.size(); ++k) {
    for (const char* c : {"_x", "_y", "_z"}) h += "," + probes_[k].name + c;
    if (reaction_[k])
      for (const char* c : {"_fx", "_fy", "_fz", "_tx", "_ty", "_tz"}) h += "," + probes_[k].name + c;
    if (stress_[k])
      for (const char* c : {"_sxx", "_syy", "_szz", "_syz", "_sxz", "_sxy", "_von_mises_max"}) h += "," + probes_[k].name + c;
  }
  for (const Obstacle& o : obstacles_) {
    const std::string k = "obstacle" + std::to_string(o.record);
    for (const char* c : {"_jx", "_jy", "_jz", "_jn"}) h += "," + k + c;
    if (o.inside) h += "," + k + "_pressure";
  }
  if (contact_columns_) h += ",contact_energy,dissipated_contact";
  return h + ",work,numerical_damping,numerical,iterations,residual,timestep";
}

std::string Diagnostics::row(const Model& model, const State& state, const SolveStats& stats, double timestep) const {
  const EnergyBudget b = energy_budget(model, state);
  const double potential = b.now.bonds + b.now.gravity;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto books = [&](double v) { return ledger_ ? v : nan; };
  std::size_t alive = 0;
  for (std::uint8_t a : state.bonds.alive) alive += a;
  std::string r = std::to_string(state.step);
  put(r, state.time);
  put(r, b.now.kinetic);
  put(r, potential);
  put(r, books(b.dissipated_damping + b.dissipated_heuristics + b.dissipated_contact));
  put(r, contact_columns_ ? books(b.now.kinetic + potential + b.contact_stored) : b.now.kinetic + potential);
  put(r, linear_momentum(model, state));
  put(r, angular_momentum(model, state));
  put(r, max_speed(model, state).first);
  put_count(r, alive);
  put_count(r, state.bonds.size() - alive);
  std::vector<Mat3> sigma;
  if (std::find(stress_.begin(), stress_.end(), true) != stress_.end()) virial_stress(model, state, sigma);
  for (std::size_t k = 0; k < probes_.size(); ++k) {
    const ProbeValue v = measure_probe(model, state, probes_[k], sigma);
    put(r, v.mean);
    if (reaction_[k]) {
      put(r, v.force);
      put(r, v.torque);
    }
    if (stress_[k]) {
      const Mat3& s = v.stress;
      for (double c : {s(0, 0), s(1, 1), s(2, 2), s(1, 2), s(0, 2), s(0, 1), v.von_mises_max}) put(r, c);
    }
  }
  for (const Obstacle& o : obstacles_) {
    const auto k = static_cast<std::size_t>(o.record);
    const ObstacleImpulse J = k < state.obstacle_impulse.size() ? state.obstacle_impulse[k] : ObstacleImpulse{};
    put(r, J.total);
    put(r, J.normal);
    if (o.inside) {
      const double elapsed = state.time - state.energy.initial_time;
      put(r, elapsed > 0 ? J.normal / (o.contact_area() * elapsed) : 0.0);
    }
  }
  if (contact_columns_) {
    put(r, books(b.contact_stored));
    put(r, books(b.dissipated_contact));
  }
  put(r, books(b.work_loads + b.work_anchors));
  put(r, books(b.numerical_damping));
  put(r, books(b.dissipated_numerical));
  put_count(r, static_cast<std::size_t>(stats.iterations));
  put(r, stats.residual);
  put(r, timestep);
  return r;
}

}  // namespace qbond
