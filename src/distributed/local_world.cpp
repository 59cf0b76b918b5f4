#include "distributed/local_world.hpp"

#include <algorithm>
#include <map>

namespace qbond::distributed {

void append_bond(const Bonds& from, std::size_t b, Index i, Index j, Bonds& to) {
  to.i.push_back(i);
  to.j.push_back(j);
  to.id.push_back(from.id[b]);
  to.law.push_back(from.law[b]);
  to.damping_model.push_back(from.damping_model[b]);
  to.strength.push_back(from.strength[b]);
  to.damping.push_back(from.damping[b]);
  to.rest0.push_back(from.rest0[b]);
  to.shape.push_back(from.shape[b]);
  to.rest.push_back(from.rest[b]);
  to.alive.push_back(from.alive[b]);
  to.time.push_back(from.time[b]);
}

std::vector<std::uint8_t> local_quanta(const World& whole, std::span<const int> owner, int rank,
                                       const ContactHalo& contact) {
  const Bonds& wb = whole.state.bonds;
  const std::size_t n = whole.model.num_quanta();
  if (contact.everything) return std::vector<std::uint8_t>(n, 1);
  std::vector<std::uint8_t> wanted(n, 0);
  for (std::size_t q = 0; q < n; ++q)
    if (owner[q] == rank) wanted[q] = 1;
  for (std::size_t b = 0; b < wb.size(); ++b) {
    if (!wb.alive[b]) continue;
    const Index i = wb.i[b], j = wb.j[b];
    if (owner[i] == rank && owner[j] != rank) wanted[j] = 1;
    if (owner[j] == rank && owner[i] != rank) wanted[i] = 1;
  }
  for (const auto& [i, j] : contact.near) {
    if (owner[i] == rank) wanted[j] = 1;
    if (owner[j] == rank) wanted[i] = 1;
  }
  if (contact.layers < 2) return wanted;
  const std::vector<std::uint8_t> first = wanted;
  for (const auto& [i, j] : contact.near) {
    if (first[i]) wanted[j] = 1;
    if (first[j]) wanted[i] = 1;
  }
  return wanted;
}

Piece make_piece(const World& whole, std::span<const int> owner, int rank, const ContactHalo& contact) {
  const Model& wm = whole.model;
  const State& ws = whole.state;
  const Bonds& wb = ws.bonds;
  const std::size_t n = wm.num_quanta();
  const std::vector<std::uint8_t> wanted = local_quanta(whole, owner, rank, contact);
  Piece p;
  std::vector<Index> local(n, kNone);
  for (std::size_t q = 0; q < n; ++q)
    if (wanted[q]) {
      local[q] = static_cast<Index>(p.global.size());
      p.global.push_back(static_cast<Index>(q));
    }
  const std::size_t m = p.global.size();
  Model& lm = p.world.model;
  State& ls = p.world.state;
  lm.body_names = wm.body_names;
  lm.shapes = wm.shapes;
  lm.gravity = wm.gravity;
  lm.obstacles = wm.obstacles;
  lm.quanta_contact = wm.quanta_contact;
  lm.mass.resize(m);
  lm.inv_mass.resize(m);
  lm.body.resize(m);
  lm.volume.resize(m);
  lm.quanta_id.resize(m);
  ls.x.resize(m);
  ls.v.resize(m);
  p.owned.resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    const Index q = p.global[k];
    lm.mass[k] = wm.mass[q];
    lm.inv_mass[k] = wm.inv_mass[q];
    lm.body[k] = wm.body[q];
    lm.volume[k] = wm.volume[q];
    lm.quanta_id[k] = wm.quanta_id[q];
    ls.x[k] = ws.x[q];
    ls.v[k] = ws.v[q];
    p.owned[k] = owner[q] == rank;
    if (p.owned[k]) p.owned_quanta.push_back(static_cast<Index>(k));
  }
  // Prescribed motions: the entries of the local quanta, in the motion's order.
  for (const Motion& motion : wm.motions) {
    Motion mine = motion;
    mine.quanta.clear();
    mine.x0.clear();
    for (std::size_t k = 0; k < motion.quanta.size(); ++k) {
      if (local[motion.quanta[k]] == kNone) continue;
      mine.quanta.push_back(local[motion.quanta[k]]);
      mine.x0.push_back(motion.x0[k]);
    }
    if (!mine.quanta.empty()) lm.motions.push_back(std::move(mine));
  }
  // Loads: the entries of the local quanta, each with the whole load's share; ghosts too, whose
  // step here must be their owner's. Every load is kept, empty ones too, so that the piece forms
  // its forces as the whole world does.
  for (const Load& load : wm.loads) {
    Load mine{.quanta = {}, .force = load.force, .entries = load.quanta.size()};
    for (Index q : load.quanta)
      if (local[q] != kNone) mine.quanta.push_back(local[q]);
    lm.loads.push_back(std::move(mine));
  }
  // The bonds with an owned end (with quanta contact, with both ends local), in the whole world's order.
  Bonds& lb = ls.edit_bonds();
  for (std::size_t b = 0; b < wb.size(); ++b) {
    if (!wb.alive[b]) continue;
    ++p.whole_alive_bonds;
    const Index i = wb.i[b], j = wb.j[b];
    const bool held = owner[i] == rank || owner[j] == rank || (contact.layers > 0 && wanted[i] && wanted[j]);
    if (!held) continue;
    if (owner[i] == rank) p.owned_bonds.push_back(static_cast<Index>(lb.size()));
    p.whole_bond.push_back(static_cast<Index>(b));
    append_bond(wb, b, local[i], local[j], lb);
  }
  lb.first_formed = lb.size();
  ls.time = ws.time;
  ls.step = ws.step;
  ls.rng = ws.rng;
  return p;
}

HaloPlan halo_plan(const World& whole, std::span<const int> owner, int rank, const Piece& piece,
                   const ContactHalo& contact) {
  // Each peer's ghosts owned here (send) and this piece's ghosts that peer owns (recv), in the
  // whole world's order: a peer's recv list from this rank is this rank's send list to it.
  std::map<int, std::pair<std::vector<Index>, std::vector<Index>>> lists;  // peer: send, recv (local indices)
  for (std::size_t l = 0; l < piece.global.size(); ++l)
    if (!piece.owned[l]) lists[owner[piece.global[l]]].second.push_back(static_cast<Index>(l));
  const std::size_t n = whole.model.num_quanta();
  int ranks = 0;
  for (std::size_t q = 0; q < n; ++q) ranks = std::max(ranks, owner[q] + 1);
  for (int peer = 0; peer < ranks; ++peer) {
    if (peer == rank) continue;
    const std::vector<std::uint8_t> theirs = local_quanta(whole, owner, peer, contact);
    for (std::size_t l = 0; l < piece.global.size(); ++l)
      if (piece.owned[l] && theirs[piece.global[l]]) lists[peer].first.push_back(static_cast<Index>(l));
  }
  HaloPlan plan;
  for (auto& [peer, sr] : lists) {
    if (sr.first.empty() && sr.second.empty()) continue;
    plan.peers.push_back(peer);
    plan.send.push_back(std::move(sr.first));
    plan.recv.push_back(std::move(sr.second));
  }
  return plan;
}

}  // namespace qbond::distributed
