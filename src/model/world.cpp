#include "qbond/model/world.hpp"

#include <Eigen/Geometry>
#include <cassert>
#include <stdexcept>

namespace qbond {

std::string_view to_string(DampingModel m) {
  return m == DampingModel::axial ? "axial" : "isotropic";
}

void Motion::at(std::size_t k, double t, Vec3& x, Vec3& v) const {
  const double tau = t - t0;
  switch (type) {
    case MotionType::fixed:
      x = x0[k];
      v.setZero();
      return;
    case MotionType::translate:
      x = x0[k] + velocity * tau;
      v = velocity;
      return;
    case MotionType::rotate: {
      const Eigen::AngleAxisd R(rate * tau, axis);
      x = center + R * (x0[k] - center);
      v = (rate * axis).cross(x - center);
      return;
    }
    case MotionType::keyframes: {
      // The interval holding tau: from the previous pose (the start, or a keyframe) to the next.
      Keyframe from, to;
      double w = 1, dw = 0;  // the fraction of the way, and its rate [1/s]; held past the last
      std::size_t next = 0;
      while (next < keyframes.size() && keyframes[next].time <= tau) from = keyframes[next++];
      if (next < keyframes.size() && tau > 0) {
        to = keyframes[next];
        const double span = to.time - from.time, s = (tau - from.time) / span;
        w = interpolation == Interpolation::linear ? s : s * s * (3 - 2 * s);
        dw = (interpolation == Interpolation::linear ? 1 : 6 * s * (1 - s)) / span;
      } else {
        to = from;
      }
      const double angle = from.angle + w * (to.angle - from.angle);
      const Vec3 r = Eigen::AngleAxisd(angle, axis) * (x0[k] - center);
      x = center + r + from.offset + w * (to.offset - from.offset);
      v = (dw * (to.angle - from.angle) * axis).cross(r) + dw * (to.offset - from.offset);
      return;
    }
  }
}

void build_adjacency(const Model& model, const State& state, Adjacency& adj) {
  const std::size_t n = model.num_quanta(), nb = state.bonds.size();
  adj.offset.assign(n + 1, 0);
  const Bonds& bonds = state.bonds;
  for (std::size_t b = 0; b < nb; ++b) {
    if (!bonds.alive[b]) continue;
    ++adj.offset[bonds.i[b] + 1];
    ++adj.offset[bonds.j[b] + 1];
  }
  for (std::size_t i = 0; i < n; ++i) adj.offset[i + 1] += adj.offset[i];
  adj.bond.resize(adj.offset[n]);
  adj.other.resize(adj.offset[n]);
  std::vector<Index> fill(adj.offset.begin(), adj.offset.end() - 1);
  for (std::size_t b = 0; b < nb; ++b) {
    if (!bonds.alive[b]) continue;
    const Index i = bonds.i[b], j = bonds.j[b];
    adj.bond[fill[i]] = static_cast<Index>(b);
    adj.other[fill[i]++] = j;
    adj.bond[fill[j]] = static_cast<Index>(b);
    adj.other[fill[j]++] = i;
  }
  adj.version = state.topology_version();
}

Index World::add_body(std::string name) {
  model.body_names.push_back(std::move(name));
  return static_cast<Index>(model.body_names.size() - 1);
}

Index World::add_quanta(const Vec3& x, const Vec3& v, double mass, Index body, double volume) {
  if (!(mass >= 0)) throw std::invalid_argument("quanta mass must be >= 0");
  if (!(volume >= 0)) throw std::invalid_argument("quanta volume must be >= 0");
  model.mass.push_back(mass);
  model.inv_mass.push_back(mass > 0 ? 1.0 / mass : 0.0);
  model.body.push_back(body);
  model.volume.push_back(volume);
  model.quanta_id.push_back(static_cast<Index>(model.quanta_id.size()));
  state.x.push_back(x);
  state.v.push_back(v);
  return static_cast<Index>(model.mass.size() - 1);
}

BondLaw bond_law(Model& model, const BondSpec& s) {
  if (!is_law_id(static_cast<std::uint8_t>(s.law))) throw std::invalid_argument("unknown bond law");
  if (const std::string why = invalid_law_shape(s.law, s.shape); !why.empty()) throw std::invalid_argument(why);
  return {s.law, s.damping_model, s.stiffness, s.damping, model.intern_shape(s.shape)};
}

Index World::add_bond(Index i, Index j, const BondSpec& s) {
  const std::size_t n = num_quanta();
  if (i >= n || j >= n) throw std::invalid_argument("bond endpoint out of range");
  if (i == j) throw std::invalid_argument("a bond must join two different quanta");
  const BondLaw law = bond_law(model, s);
  return state.add_bond(i, j, law, s.rest_length >= 0 ? s.rest_length : (state.x[j] - state.x[i]).norm());
}

namespace {

// Appends an entry to every per-bond array (its values set by the caller).
void append_slot(Bonds& b) {
  for (auto* v : {&b.i, &b.j, &b.id}) v->emplace_back();
  b.law.emplace_back();
  b.damping_model.emplace_back();
  for (auto* v : {&b.strength, &b.damping, &b.rest0, &b.rest, &b.time}) v->emplace_back();
  b.shape.emplace_back();
  b.alive.emplace_back();
}

// Writes bond k's ends, law, rest lengths and time; it is alive.
void put_bond(Bonds& b, std::size_t k, Index i, Index j, const BondLaw& law, double L, double time) {
  b.i[k] = i;
  b.j[k] = j;
  b.law[k] = law.law;
  b.damping_model[k] = law.damping_model;
  b.strength[k] = law.strength;
  b.damping[k] = law.damping;
  b.shape[k] = law.shape;
  b.rest0[k] = L;
  b.rest[k] = L;
  b.alive[k] = 1;
  b.time[k] = time;
}

}  // namespace

Index State::add_bond(Index i, Index j, const BondLaw& law, double L) {
  // Scene bonds come before those formed during the run (whose slots formation reuses).
  if (bonds.first_formed != bonds.size())
    throw std::invalid_argument("add_bond: the scene's bonds cannot follow bonds formed during the run");
  const std::size_t k = bonds.size();
  append_slot(bonds);
  bonds.id[k] = static_cast<Index>(k);
  put_bond(bonds, k, i, j, law, L, 0.0);
  bonds.first_formed = bonds.size();
  ++topology_version_;
  return static_cast<Index>(k);
}

Index State::form_bond(Index i, Index j, const BondLaw& law, double L, Index slot) {
  const std::size_t nb = bonds.size();
  assert(i < x.size() && j < x.size() && i != j);
  assert(slot == nb || (slot >= bonds.first_formed && slot < nb && !bonds.alive[slot]));
  if (slot == nb) {
    append_slot(bonds);
    bonds.id[slot] = slot;
  }
  put_bond(bonds, slot, i, j, law, L, time);
  ++topology_version_;
  return slot;
}

void State::break_bond(Index b) {
  assert(b < bonds.size());
  if (bonds.alive[b]) {
    bonds.alive[b] = 0;
    bonds.time[b] = time;
    ++topology_version_;
  }
}

std::uint32_t Model::intern_shape(const LawShape& shape) {
  // A scene has a handful of materials: a linear search is enough.
  for (std::size_t k = 0; k < shapes.size(); ++k)
    if (shapes[k] == shape) return static_cast<std::uint32_t>(k);
  shapes.push_back(shape);
  return static_cast<std::uint32_t>(shapes.size() - 1);
}

void World::prescribe(std::vector<Index> quanta, Motion motion) {
  motion.t0 = state.time;
  motion.x0.clear();
  if (motion.type == MotionType::rotate || motion.type == MotionType::keyframes) {
    if (!(motion.axis.norm() > 0)) throw std::invalid_argument("rotation axis must be non-zero");
    motion.axis.normalize();
  }
  for (std::size_t k = 0; k < motion.keyframes.size(); ++k)
    if (!(motion.keyframes[k].time > (k ? motion.keyframes[k - 1].time : 0.0)))
      throw std::invalid_argument("keyframe times must increase from 0");
  for (Index i : quanta) {
    if (i >= num_quanta()) throw std::invalid_argument("prescribed quanta out of range");
    model.inv_mass[i] = 0.0;
    motion.x0.push_back(state.x[i]);
  }
  motion.quanta = std::move(quanta);
  for (std::size_t k = 0; k < motion.quanta.size(); ++k) {
    Vec3 x, v;
    motion.at(k, state.time, x, v);
    state.v[motion.quanta[k]] = v;
  }
  model.motions.push_back(std::move(motion));
}

void World::add_load(std::vector<Index> quanta, const Vec3& total_force) {
  for (Index i : quanta)
    if (i >= num_quanta()) throw std::invalid_argument("loaded quanta out of range");
  model.loads.push_back({std::move(quanta), total_force});
}

std::size_t World::num_alive_bonds() const {
  std::size_t c = 0;
  for (auto a : state.bonds.alive) c += a;
  return c;
}

}  // namespace qbond
