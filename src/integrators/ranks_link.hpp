#pragma once
// What the step of one rank's piece of the world needs from the other ranks between its passes
// when a run is spread over MPI ranks (src/distributed/distributed_step.cpp): with it, the
// hybrid's sweeps take the passes a run alone takes, in the whole world's colour order, RK4 its
// stages, the ghosts' values brought from their owners between them, and the Newton integrators
// their iterations, each linear solve over the whole world (StepIntegrator::link_to_ranks).
// Alone there is none.
#include <cstdint>
#include <span>
#include <vector>

#include "qbond/model/world.hpp"
#include "solvers/coloring.hpp"

namespace qbond {

struct ImplicitSystem;
struct SolveStats;

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
  // The owned rows of y solving the whole world's system whose rows of the piece's free quanta
  // sys holds (built on the piece: state's bonds, adj), by CG from zero to ‖b − A y‖ ≤ tolerance
  // ‖b‖ (collective).
  virtual void solve(const Model& model, const State& state, const Adjacency& adj, const ImplicitSystem& sys,
                     double tolerance, std::vector<Vec3>& y, SolveStats& stats) = 0;

 protected:
  ~RanksLink() = default;
};

}  // namespace qbond
