#pragma once
// Quanta contact by the projection rule on a piece of a run over MPI ranks (docs/distributed.md).
// The rule projects its pairs one after another, each reading what the last left, so a pair
// across the cut between two ranks depends on pairs on either side. Every rank therefore
// projects every pair of the whole world: each sends the rows of its owned quanta that touch
// something (its piece holds every quanta they can touch), and every rank runs the run alone's
// passes over the gathered quanta, in the whole world's order, then takes its quanta's results.
#include <memory>
#include <span>
#include <vector>

#include "qbond/heuristics/heuristics.hpp"
#include "qbond/model/obstacle.hpp"

namespace qbond {

// What the contact rule of a piece needs from the run over ranks. Every call is collective.
class ContactRanks {
 public:
  // The whole world's model (masses, bodies) and the adjacency of its bonds.
  virtual const Model& whole_model() const = 0;
  virtual const Adjacency& whole_adjacency() const = 0;
  // The whole index of each of the piece's quanta, and the piece's index of a whole one (kNone: none).
  virtual std::span<const Index> whole_index() const = 0;
  virtual Index local_index(Index whole) const = 0;
  // Every rank's `mine`, in rank order, on every rank.
  virtual std::vector<double> gather(std::span<const double> mine) = 0;

 protected:
  ~ContactRanks() = default;
};

// The contact rule of a piece linked to the other ranks' (the piece's owned quanta are
// HeuristicContext::counted). `ranks` outlives it.
std::unique_ptr<Heuristic> make_heuristic(QuantaContactRule rule, ContactRanks& ranks);

}  // namespace qbond
