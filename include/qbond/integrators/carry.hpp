#pragma once
/// What an integrator carries from one step to the next (State::carry): one typed value per kind
/// of carry-over, each saying when it still holds and saving itself into a checkpoint, so that a
/// checkpoint or a rollback carries it and a resumed run continues bit for bit.
#include <cstddef>
#include <cstdint>
#include <variant>
#include <vector>

#include "qbond/core/line_vector.hpp"
#include "qbond/core/math.hpp"

namespace qbond {

class Writer;
class Reader;

/// The last step's solver solution, the velocity change Δv of every quanta: the next solve's
/// initial guess (WarmStart::previous).
struct SolverGuess {
  static constexpr std::uint8_t kKind = 1;  ///< its tag in a checkpoint
  LineVector<Vec3> dv;                      ///< [m/s] (n)
  /// Whether it is a guess for n quanta.
  bool fits(std::size_t n) const { return dv.size() == n; }
  /// Whether it survives a change of bond parameters (a guess only starts a solve).
  bool holds_after_bond_edit() const { return true; }
  /// Writes its fields (save_carry writes the kind tag before them).
  void save(Writer& w) const;
  /// Reads what save wrote, for n quanta; throws CheckpointError on other sizes.
  void load(Reader& r, std::size_t n);
  bool operator==(const SolverGuess&) const = default;  ///< field by field (tests, rollbacks)
};

/// The last two steps' solver solutions and lengths, for WarmStart::extrapolated's guess
/// 2 Δv₋₁ − Δv₋₂ (linear extrapolation in time), taken only between steps of one length.
struct SolverGuessPair {
  static constexpr std::uint8_t kKind = 2;  ///< its tag in a checkpoint
  LineVector<Vec3> dv;         ///< [m/s] the last step's Δv (n)
  LineVector<Vec3> dv_before;  ///< [m/s] the step before's (n; zeros when there was none)
  double h = 0;                ///< [s] the last step's length
  double h_before = 0;         ///< [s] the step before's length (0 when there was none)
  /// Whether it is a guess for n quanta.
  bool fits(std::size_t n) const { return dv.size() == n; }
  /// Whether it extrapolates to a step of length `step_h`: both steps it holds were that long
  /// (Δv over a step grows with its length).
  bool extrapolates(std::size_t n, double step_h) const { return fits(n) && h == step_h && h_before == step_h; }
  bool holds_after_bond_edit() const { return true; }  ///< as SolverGuess's
  void save(Writer& w) const;                         ///< as SolverGuess's
  void load(Reader& r, std::size_t n);                ///< as SolverGuess's
  bool operator==(const SolverGuessPair&) const = default;  ///< field by field (tests, rollbacks)
};

/// BDF2's history: the state the last step started from, and when (its step reads the state one
/// whole step back: docs/integrators.md).
struct Bdf2History {
  static constexpr std::uint8_t kKind = 3;  ///< its tag in a checkpoint
  std::vector<Vec3> x;    ///< [m] positions (n)
  std::vector<Vec3> v;    ///< [m/s] velocities (n)
  double t = 0;           ///< [s] the time of that state
  double h = 0;           ///< [s] the length of the step taken from it
  std::uint64_t step = 0; ///< the index of that step
  /// Whether it is the state of the step just before step `at` (starting at time `at_t`, of
  /// length `at_h`) for n quanta, taken with the same length: after a timestep change, another
  /// integrator's run or a fresh start it is not, and BDF2 restarts with backward Euler.
  bool precedes(std::size_t n, double at_t, double at_h, std::uint64_t at) const {
    return x.size() == n && at > 0 && h == at_h && step == at - 1 && t + h == at_t;
  }
  bool holds_after_bond_edit() const { return true; }  ///< as SolverGuess's
  void save(Writer& w) const;                         ///< as SolverGuess's
  void load(Reader& r, std::size_t n);                ///< as SolverGuess's
  bool operator==(const Bdf2History&) const = default;  ///< field by field (tests, rollbacks)
};

/// Velocity Verlet's last bond forces (first same as last: one force pass a step) with the state
/// they were taken for. The force pass writes `f` and `x` as its own rows: three component rows
/// each (structure of arrays, `stride` doubles apart, padding zeroed), on cache lines.
struct VerletForces {
  static constexpr std::uint8_t kKind = 4;  ///< its tag in a checkpoint
  LineVector<double> f;  ///< [N] the bond forces f₁ at x₁ (3 rows of stride)
  LineVector<double> x;  ///< [m] the positions x₁ the step left (3 rows of stride)
  LineVector<Vec3> v;    ///< [m/s] the velocities v₁ the step left (n)
  std::uint64_t topology_version = 0;  ///< State::topology_version of the bonds they summed
  /// Doubles from one component's row to the next.
  std::size_t stride() const { return f.size() / 3; }
  /// Sized for n quanta (rows of soa_stride(n)), padding zeroed; values otherwise unset.
  void resize(std::size_t n);
  /// Whether they are the forces of the bonds of this topology for n quanta; the step also checks
  /// that the state is x, v bit for bit in the pass that reads them, and evaluates them afresh
  /// when it is not (a heuristic, a contact, a rollback or the user changed it).
  bool holds_for(std::size_t n, std::uint64_t version) const { return v.size() == n && topology_version == version; }
  /// They hold only for the bonds' present parameters.
  bool holds_after_bond_edit() const { return false; }
  void save(Writer& w) const;           ///< as SolverGuess's
  void load(Reader& r, std::size_t n);  ///< as SolverGuess's
  bool operator==(const VerletForces&) const = default;  ///< field by field (tests, rollbacks)
};

/// What the integrator carries from one step to the next (nothing: std::monostate).
using Carry = std::variant<std::monostate, SolverGuess, SolverGuessPair, Bdf2History, VerletForces>;

/// Drops a carry-over that does not hold once bond parameters changed without a topology change
/// (plasticity's rest lengths, a user's stiffness edit).
void drop_after_bond_edit(Carry& c);

/// Writes a carry-over: its kind tag, then its own fields.
void save_carry(Writer& w, const Carry& c);
/// Reads what save_carry wrote for a state of n quanta; throws CheckpointError on an unknown kind
/// or sizes that are not for n quanta.
Carry load_carry(Reader& r, std::size_t n);
/// Converts the carry-over of a version-4 checkpoint (one array of triples whose length and last
/// entry told the kinds apart) for n quanta; an unknown layout carries nothing.
Carry carry_from_version4(const LineVector<Vec3>& old, std::size_t n);

}  // namespace qbond
