#pragma once
// Where a step leaves the prescribed quanta, for the passes that write their rows (not public API).
#include <span>
#include <vector>

#include "qbond/integrators/integrators.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

// The prescribed quanta where a step leaves them (Motion::at at its end), by index, each once (as
// the last motion listing it places it): for passes that write the prescribed quanta's rows with
// the other quanta of their range, on the thread whose passes own that range. With one thread
// writing all of them (project_kinematic, place_kinematic), the other's next passes waited on
// those cache lines.
class PrescribedAt {
 public:
  struct Quanta {
    Index q;
    Index order;  // its place in the motions' lists
    Vec3 x, v;
  };
  // The list for time t (allocates only when it grows).
  void update(const Model& model, double t);
  // The prescribed quanta in [lo, hi).
  std::span<const Quanta> in(std::size_t lo, std::size_t hi) const;
  // project_kinematic's rows for the prescribed quanta in [lo, hi) (the same values).
  void project(const State& state, std::size_t lo, std::size_t hi, Projection& out) const;
  // place_kinematic for the prescribed quanta in [lo, hi).
  void place(std::size_t lo, std::size_t hi, Vec3* x, Vec3* v) const;

 private:
  std::vector<Quanta> list_;
  std::vector<Index> index_;  // list_'s quanta alone, to search (it stays in cache)
};

}  // namespace qbond
