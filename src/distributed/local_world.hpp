#pragma once
// One rank's piece of a world: the quanta it owns, the ghosts it needs (the other ends of its
// quanta's bonds and the quanta near enough to touch them, owned by other ranks) and the bonds
// with an owned end, as a World of its own
// that the ordinary step advances. Local quanta and bonds keep the whole world's order, so that a
// quanta's force sums its bonds' terms in the same order as on one rank. Every rank holds the
// whole world's model and topology and builds its piece, and its halo lists, from them.
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond::distributed {

struct Piece {
  World world;                        // the owned and ghost quanta, the bonds with a local end owned
                                      // (with quanta contact, with both ends local)
  std::vector<Index> global;          // each local quanta's index in the whole world (ascending)
  std::vector<std::uint8_t> owned;    // 1 for the quanta this rank owns, 0 for ghosts (local)
  std::vector<Index> owned_quanta;    // the local indices of the owned quanta (ascending)
  std::vector<Index> owned_bonds;     // local bonds this rank accounts for: those whose first end it owns
  std::vector<Index> whole_bond;      // each local bond's index in the whole world
  std::size_t whole_alive_bonds = 0;  // alive bonds of the whole world (each rank owns a share)
};

// The ghosts that quanta–quanta contact needs besides the bonds' (penalty contact, a force of the
// explicit step): a rank also holds the quanta `near` its owned ones, and with two layers those
// near its ghosts too (velocity Verlet moves a ghost by its own contacts' forces at the step's
// start before the owned quanta's contacts read where it went).
// A piece with quanta contact also holds the bonds between its ghosts: a pair of local quanta
// touches only when no bond joins them. Quanta contact inside the implicit solve takes the whole
// world instead (`everything`): its pairs are found along the step's predicted paths, which a
// frame-sized step makes long, and each rank then solves every pair's active set as the run
// alone does.
struct ContactHalo {
  std::vector<std::pair<Index, Index>> near;  // pairs (i < j) of the whole world closer than the reach
  int layers = 0;                             // 0: no quanta contact; 1 or 2
  bool everything = false;                    // every quanta of the whole world is local
};

// The quanta rank `rank` holds (1 each): those it owns, the other ends of their alive bonds, and
// the contact halo's.
std::vector<std::uint8_t> local_quanta(const World& whole, std::span<const int> owner, int rank,
                                       const ContactHalo& contact);

// Rank `rank`'s piece of `whole` given every quanta's owner; its state is whole.state's for those
// quanta and bonds, at the same time and step, with no carry-over (the caller gives it one).
// Only alive bonds are taken. A load acts on the local quanta of its selection, each with the
// whole load's share.
Piece make_piece(const World& whole, std::span<const int> owner, int rank, const ContactHalo& contact = {});

// Appends bond b of `from` to `to`, its ends renumbered i and j (every field of the bond).
void append_bond(const Bonds& from, std::size_t b, Index i, Index j, Bonds& to);

// What a rank exchanges with each other rank: the local indices of the owned quanta another rank
// needs as ghosts (send) and of the ghosts it receives from their owner (recv), both in the
// whole world's order, so that one rank's send list is the other's recv list, entry by entry.
struct HaloPlan {
  std::vector<int> peers;                 // ranks it exchanges with (ascending)
  std::vector<std::vector<Index>> send;   // per peer
  std::vector<std::vector<Index>> recv;   // per peer
};
HaloPlan halo_plan(const World& whole, std::span<const int> owner, int rank, const Piece& piece,
                   const ContactHalo& contact = {});

}  // namespace qbond::distributed
