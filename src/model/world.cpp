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
  }
}

void build_adjacency(const Model& model, const State& state, Adjacency& adj) {
  const std::size_t n = model.num_quanta(), nb = model.num_bonds();
  adj.offset.assign(n + 1, 0);
  for (std::size_t b = 0; b < nb; ++b) {
    if (!state.alive[b]) continue;
    ++adj.offset[model.bond_i[b] + 1];
    ++adj.offset[model.bond_j[b] + 1];
  }
  for (std::size_t i = 0; i < n; ++i) adj.offset[i + 1] += adj.offset[i];
  adj.bond.resize(adj.offset[n]);
  adj.other.resize(adj.offset[n]);
  std::vector<Index> fill(adj.offset.begin(), adj.offset.end() - 1);
  for (std::size_t b = 0; b < nb; ++b) {
    if (!state.alive[b]) continue;
    const Index i = model.bond_i[b], j = model.bond_j[b];
    adj.bond[fill[i]] = static_cast<Index>(b);
    adj.other[fill[i]++] = j;
    adj.bond[fill[j]] = static_cast<Index>(b);
    adj.other[fill[j]++] = i;
  }
  adj.version = state.topology_version;
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

Index World::add_bond(Index i, Index j, const BondSpec& s) {
  const std::size_t n = num_quanta();
  if (i >= n || j >= n) throw std::invalid_argument("bond endpoint out of range");
  if (i == j) throw std::invalid_argument("a bond must join two different quanta");
  if (!is_law_id(static_cast<std::uint8_t>(s.law))) throw std::invalid_argument("unknown bond law");
  if (const std::string why = invalid_law_shape(s.law, s.shape); !why.empty()) throw std::invalid_argument(why);
  const double L = s.rest_length >= 0 ? s.rest_length : (state.x[j] - state.x[i]).norm();
  model.bond_i.push_back(i);
  model.bond_j.push_back(j);
  model.bond_id.push_back(static_cast<Index>(model.bond_id.size()));
  model.law.push_back(s.law);
  model.damping_model.push_back(s.damping_model);
  model.stiffness.push_back(s.stiffness);
  model.damping.push_back(s.damping);
  model.rest0.push_back(L);
  model.law_shape.push_back(model.intern_shape(s.shape));
  state.rest.push_back(L);
  state.alive.push_back(1);
  state.bond_time.push_back(0.0);
  ++state.topology_version;
  return static_cast<Index>(model.bond_i.size() - 1);
}

namespace {

// Writes a formed bond's entries into the model at slot b (appending when b is the end).
void put_formed(Model& m, std::size_t b, const FormedBond& f) {
  if (b == m.num_bonds()) {
    for (auto* v : {&m.bond_i, &m.bond_j}) v->emplace_back();
    m.bond_id.push_back(static_cast<Index>(b));
    m.law.emplace_back();
    m.damping_model.emplace_back();
    for (auto* v : {&m.stiffness, &m.damping, &m.rest0}) v->emplace_back();
    m.law_shape.emplace_back();
  }
  m.bond_i[b] = f.i;
  m.bond_j[b] = f.j;
  m.law[b] = f.law;
  m.damping_model[b] = f.damping_model;
  m.stiffness[b] = f.stiffness;
  m.damping[b] = f.damping;
  m.rest0[b] = f.rest0;
  m.law_shape[b] = m.intern_shape(f.shape);
}

}  // namespace

Index World::form_bond(Index i, Index j, const BondSpec& s, double L, Index slot) {
  const std::size_t nb = num_bonds(), first = nb - state.formed.size();
  assert(i < num_quanta() && j < num_quanta() && i != j);
  assert(slot == nb || (slot >= first && slot < nb && !state.alive[slot]));
  const FormedBond f{i, j, s.law, s.damping_model, s.stiffness, s.damping, L, s.shape};
  put_formed(model, slot, f);
  if (slot == nb) {
    state.formed.push_back(f);
    state.rest.push_back(L);
    state.alive.push_back(1);
    state.bond_time.push_back(state.time);
  } else {
    state.formed[slot - first] = f;
    state.rest[slot] = L;
    state.alive[slot] = 1;
    state.bond_time[slot] = state.time;
  }
  ++state.topology_version;
  return slot;
}

void World::sync_formed_bonds() {
  const std::size_t first = state.rest.size() - state.formed.size();
  for (auto* v : {&model.bond_i, &model.bond_j, &model.bond_id}) v->resize(first);
  model.law.resize(first);
  model.damping_model.resize(first);
  for (auto* v : {&model.stiffness, &model.damping, &model.rest0}) v->resize(first);
  model.law_shape.resize(first);
  for (std::size_t k = 0; k < state.formed.size(); ++k) put_formed(model, first + k, state.formed[k]);
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
  if (motion.type == MotionType::rotate) {
    if (!(motion.axis.norm() > 0)) throw std::invalid_argument("rotation axis must be non-zero");
    motion.axis.normalize();
  }
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

void World::break_bond(Index b) {
  assert(b < num_bonds());
  if (state.alive[b]) {
    state.alive[b] = 0;
    state.bond_time[b] = state.time;
    ++state.topology_version;
  }
}

std::size_t World::num_alive_bonds() const {
  std::size_t c = 0;
  for (auto a : state.alive) c += a;
  return c;
}

}  // namespace qbond
