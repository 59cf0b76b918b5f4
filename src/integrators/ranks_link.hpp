#pragma once
// What the hybrid's iterative solve of one rank's piece of the world needs from the other ranks
// when a run is spread over MPI ranks (src/distributed/distributed_step.cpp): with it, each piece
// takes the passes a run alone takes, in the whole world's colour order, the ghosts' unknowns
// brought from their owners between them. Alone there is none.
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "integrators/advance.hpp"
#include "qbond/model/world.hpp"
#include "solvers/coloring.hpp"

namespace qbond {

class RanksLink {
 public:
  // 1 for each local quanta this rank owns: its rows of the solve (a ghost's are its owner's).
  virtual const std::vector<std::uint8_t>& owned() const = 0;
  // The whole world's colouring of its free quanta, restricted to the piece's (local indices).
  virtual const Coloring& coloring() const = 0;
  // Every ghost's row of y made its owner's (collective).
  virtual void exchange(std::vector<Vec3>& y) = 0;
  // Each entry of `sums` added over the ranks, in rank order (collective).
  virtual void sum(std::span<double> sums) = 0;
  // restore_component_momentum over the whole world's free components, on the owned rows of dv
  // (collective).
  virtual void restore_momentum(const Model& model, const std::vector<Vec3>& f_ext, double h,
                                std::vector<Vec3>& dv) = 0;

 protected:
  ~RanksLink() = default;
};

// hybrid_implicit with sweeps or Jacobi iterations on one rank's piece, its passes linked to the
// other ranks' by `link` (which must outlive it).
std::unique_ptr<StepIntegrator> make_hybrid_over_ranks(const IntegratorConfig& config, RanksLink& link);

}  // namespace qbond
