#pragma once
/// Renumbering quanta and bonds for memory locality (docs/performance.md).
///
/// A step streams the bonds and reads both ends' positions and velocities; when bonds joining
/// nearby quanta sit near each other in memory and so do their ends, those reads hit the cache.
/// Scenes built from meshes, packings or shuffled lists do not come in such an order, so scene
/// loading renumbers the world as LAMMPS sorts its atoms (atom_modify sort): quanta by spatial
/// bin, x fastest, then y, then z, so that a lattice's neighbours sit at a few fixed offsets that
/// the hardware prefetcher streams (a Morton order keeps neighbours closer but scatters them
/// over more offsets, and steps run slower); bonds so that a lattice's
/// form affine runs (locality_order). As LAMMPS does with its atom tags, the user's ids stay
/// with the quanta and bonds (Model::quanta_id, Bonds::id): outputs and selections speak
/// them.
#include <cassert>
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond {

/// New index of each quanta and bond: quanta[old] and bonds[old] (permutations).
struct Renumbering {
  std::vector<Index> quanta;
  std::vector<Index> bonds;
};

/// The quanta sorted by the bin of their current position (bins one spacing wide, the median
/// nearest-bonded-neighbour distance, centred on the lowest corner's lattice; x fastest; ties by
/// index), and the bonds made with the scene sorted, in the new numbering, by block of 128 first
/// ends, then the index offset between their ends, then first end, when that puts at least half
/// of them in affine runs (consecutive bonds whose ends both advance by one, which the paper's
/// hybrid step loads and updates as contiguous vectors: a lattice), else by their (first end,
/// second end) (a mesh or packing); ties by index. Bonds formed during the run (from
/// Bonds::first_formed on) keep their slots at the end. The quanta keep their given order
/// instead when it puts more bonds in affine runs (a lattice built row by row and then rotated,
/// whose rows the world's bins cut across). A builder's lattice, made x fastest, keeps its
/// quanta order, rotated or not; a sorted world maps to the identity.
Renumbering locality_order(const World& world);

/// Renumbers every per-quanta and per-bond array of the world, the quanta of its motions and
/// loads and the integrator's carried state, and changes the topology version. `r` must leave
/// formed bonds in their slots (locality_order does). Results of a step change only by
/// summation order (round-off).
void renumber(World& world, const Renumbering& r);

/// Moves values[offset + k] to values[offset + p[k]] for k < p.size(): a per-quanta array
/// (p = Renumbering::quanta) or per-bond array (p = Renumbering::bonds) to the new numbering.
template <class T, class A>
void permute(std::vector<T, A>& values, const std::vector<Index>& p, std::size_t offset = 0) {
  assert(values.size() >= offset + p.size());
  std::vector<T> old(values.begin() + static_cast<std::ptrdiff_t>(offset),
                     values.begin() + static_cast<std::ptrdiff_t>(offset + p.size()));
  for (std::size_t k = 0; k < p.size(); ++k) values[offset + p[k]] = std::move(old[k]);
}

/// The index of the quanta of each user id: at[Model::quanta_id[i]] = i.
std::vector<Index> quanta_by_id(const Model& model);
/// The index of the bond of each user id: at[Bonds::id[b]] = b.
std::vector<Index> bonds_by_id(const Bonds& bonds);

/// Maps a list of old quanta indices to new ones, in place.
void renumber_quanta(std::vector<Index>& quanta, const Renumbering& r);

}  // namespace qbond
