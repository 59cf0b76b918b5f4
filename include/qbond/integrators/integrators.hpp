#pragma once
/// Integrators (DESIGN §5). Every integrator, explicit or implicit, only *projects* a step: it
/// returns the change of position and velocity of every quanta without moving anything, so that
/// heuristics can edit the projection before the step applies it (DESIGN §4).
#include <cmath>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "qbond/core/math.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

/// What one step is asked to do.
struct StepContext {
  double h = 1e-3;        ///< timestep [s]
  double t = 0;           ///< time at the start of the step [s]
  std::uint64_t step = 0; ///< index of the step being taken
  /// Set by Simulation::step when nothing reads dx and dv after the integrator (no heuristic, no
  /// energy ledger): an integrator may then write the state the step applies into
  /// Projection::applied instead, and check it against max_speed, in the passes that form it.
  bool direct = false;
  double max_speed = HUGE_VAL;  ///< [m/s] the blow-up limit a direct projection is checked against
};

/// The change a step will make (Eqs. 8–9): dx = Δp, dv = Δv for every quanta.
struct Projection {
  std::vector<Vec3> dx;  ///< [m] (n; empty when the integrator wrote `applied` instead)
  std::vector<Vec3> dv;  ///< [m/s] (n; empty when the integrator wrote `applied` instead)
  /// The state the step applies, x + dx and v + dv (the same bits) with the prescribed quanta
  /// placed (place_kinematic), when the integrator wrote it instead of dx and dv
  /// (StepContext::direct): one pass over the quanta fewer, and no dx, dv streamed out and back.
  struct Applied {
    std::vector<Vec3> x, v;  ///< [m], [m/s] (n)
    bool written = false;
    bool ok = false;  ///< every value finite and no free quanta faster than StepContext::max_speed
  } applied;
  /// The solver's solution to keep as State::warm when the step applies (WarmStart::previous and
  /// extrapolated only, keep_guess; empty otherwise). Kept apart from dv, which round-off makes
  /// differ from it.
  LineVector<Vec3> warm;
  /// Whether `warm` holds values that hold only for the bonds' present parameters (velocity_verlet's
  /// bond forces); the step then drops it if a heuristic sets `bonds_edited`.
  bool warm_needs_bonds = false;
  /// Set by a heuristic that changed bond parameters without a topology change (plasticity's rest
  /// lengths).
  bool bonds_edited = false;
  /// Set when the integrator took the step in substeps (the Newton integrators' fallback): the
  /// work of the prescribed quanta and the dampers' loss summed over the substeps, which the
  /// energy ledger charges instead of its whole-step estimate from dx, dv (docs/integrators.md).
  bool has_work = false;
  double work_anchors = 0;        ///< [J]
  double dissipated_damping = 0;  ///< [J]
  /// Sizes for n quanta and clears the rest; dx and dv zeroed unless `zero` is false (for an
  /// integrator that writes every row).
  void resize(std::size_t n, bool zero = true) {
    applied.written = false;
    if (zero) {
      dx.assign(n, Vec3::Zero());
      dv.assign(n, Vec3::Zero());
    } else {
      dx.resize(n);
      dv.resize(n);
    }
    clear_rest();
  }
  /// Sizes `applied` for n quanta (its values are the integrator's to write) and empties dx and dv
  /// (their capacity kept), for StepContext::direct; clears the rest.
  void resize_applied(std::size_t n) {
    applied.x.resize(n);
    applied.v.resize(n);
    applied.written = true;
    applied.ok = false;
    dx.clear();
    dv.clear();
    clear_rest();
  }

 private:
  void clear_rest() {
    warm.clear();
    warm_needs_bonds = bonds_edited = false;
    has_work = false;
    work_anchors = dissipated_damping = 0;
  }
};

/// Which integrator.
enum class IntegratorType : std::uint8_t {
  explicit_euler,    ///< the particle method: x += h v, v += h a(x, v)
  symplectic_euler,  ///< v += h a(x, v), then x += h v_new
  velocity_verlet,   ///< second order, symplectic when undamped; one force pass a step
                     ///< (Groot–Warren's form with damping, docs/integrators.md)
  rk4,               ///< classical fourth-order Runge–Kutta
  hybrid_implicit,   ///< Eqs. 11–12: one 3×3 solve per quanta (see NeighbourModel)
  coupled_implicit,  ///< Eq. 13 linearised (Baraff–Witkin): one global linear solve
  energy_momentum,   ///< discrete gradient (Simo–Tarnow, Gonzalez): conserves energy and both
                     ///< momenta at any step; Newton-solved (see docs/integrators.md)
  implicit_midpoint, ///< forces at the step's midpoint; Newton-solved, second order
  bdf2,              ///< second-order backward differentiation; Newton-solved, first step
                     ///< (and every restart) by backward Euler
};

/// How the hybrid integrator treats a quanta's neighbours while solving for it.
enum class NeighbourModel : std::uint8_t {
  frozen,  ///< the paper literally: neighbours held at their start positions and at rest
  sweep,   ///< block Gauss–Seidel on the coupled system, in graph-colour order
  jacobi,  ///< block Jacobi on the coupled system (for comparison)
};

/// Linear solver of the coupled implicit integrator.
enum class CoupledSolver : std::uint8_t {
  dense,  ///< dense Gaussian elimination (partial pivoting): the paper's cubic-cost method
  ldlt,   ///< sparse LDLᵀ (Eigen SimplicialLDLT)
  cg,     ///< matrix-free conjugate gradient, block-Jacobi preconditioned
  sweep,  ///< block Gauss–Seidel sweeps in colour order (Newton integrators only: `iterations`
          ///< sweeps per Newton iteration; the coupled integrator's is hybrid_implicit/sweep)
};

/// Initial guess of the iterative solvers (sweep, jacobi, cg). CG scales a guess by the factor
/// that minimises its error in A's norm, so that no guess starts it worse than zero.
enum class WarmStart : std::uint8_t {
  zero,       ///< dv = 0
  external,   ///< dv = h f_ext / m: exact for a free body under uniform gravity
  previous,   ///< the previous step's dv
  automatic,  ///< `extrapolated` for coupled_implicit with cg, `zero` otherwise (make_integrator)
  /// 2 dv₋₁ − dv₋₂ from the last two steps' dv when both had this step's length, else `previous`
  /// (hybrid_implicit and coupled_implicit only)
  extrapolated,
};

/// Every option of every integrator; each integrator reads the ones that concern it.
struct IntegratorConfig {
  IntegratorType type = IntegratorType::coupled_implicit;
  NeighbourModel neighbours = NeighbourModel::sweep;  ///< hybrid only
  CoupledSolver solver = CoupledSolver::cg;           ///< coupled and Newton integrators
  int iterations = 1;        ///< sweep/jacobi: sweeps per step (≥ 1)
  int max_iterations = 0;    ///< cg: iteration cap (0: three times the free unknowns)
  double tolerance = 1e-6;   ///< relative residual ‖b - A dv‖/‖b‖ at which sweeps and cg stop;
                             ///< Newton integrators: relative residual of the nonlinear step
  int newton_iterations = 20;  ///< Newton integrators: iteration cap per step (≥ 1)
  /// energy_momentum, implicit_midpoint: once Newton meets `tolerance`, take exact-Newton
  /// corrections (sparse LU) until the residual stops decreasing, i.e. to round-off, so that both
  /// momenta (and energy_momentum's energy) are kept to round-off rather than to the tolerance.
  /// Costs one or two LU solves per step (docs/integrators.md, "Polishing").
  bool newton_polish = false;
  double chebyshev_rho = 0;  ///< sweep: spectral radius estimate for Chebyshev acceleration (0 = off)
  WarmStart warm_start = WarmStart::automatic;  ///< sweeps from `previous` blow up, from
                                               ///< `external` they pump energy into anchored bodies
  int threads = 0;  ///< OpenMP threads (0: OpenMP's default, OMP_NUM_THREADS or every core);
                    ///< results are the same bits for any count
  bool restore_momentum = true;  ///< iterative solvers: give each free component its exact
                                 ///< momentum change h Σ f_ext (see docs/integrators.md)
  /// After each step, give back the energy the integrator itself removed (or take back what it
  /// made): the free quanta's velocities relative to their component's rigid motion are scaled so
  /// that the energy budget closes, keeping every free component's linear and angular momentum
  /// (docs/integrators.md, "Energy restoration"). Costs two energy passes per step.
  bool restore_energy = false;
};

/// The defaults qbond ships (chosen from the measurements in docs/integrators.md).
IntegratorConfig default_integrator();

/// Statistics of the last projection (iterative solvers fill them).
struct SolveStats {
  int iterations = 0;        ///< sweeps or CG iterations taken
  double residual = 0;       ///< final relative residual ‖b - A dv‖ / ‖b‖ (0 for direct solvers);
                             ///< Newton integrators: of the nonlinear step (see newton.hpp)
  int linear_iterations = 0; ///< Newton integrators: CG iterations or sweeps summed over the step
  int exact_iterations = 0;  ///< Newton integrators: iterations solved with the exact Jacobian (LU)
  int switches = 0;          ///< Newton integrators: changes between the exact and the modified
                             ///< matrix after a failed line search
  int substeps = 0;          ///< Newton integrators: substeps the step was split into because its
                             ///< Newton iteration did not converge (0: solved whole)
  int unconverged = 0;       ///< Newton integrators: solves left above the tolerance (a whole
                             ///< step, or substeps at the depth limit); 0 when the step converged
  int polish_iterations = 0;  ///< Newton integrators: corrections after the tolerance was met,
                              ///< taking the residual to round-off (energy_momentum, implicit_midpoint)
};

/// An integrator: owns its options and its scratch buffers (no allocation once warmed up).
class Integrator {
 public:
  virtual ~Integrator() = default;
  /// Projects one step of length ctx.h from `state` into `out` (resized to the quanta count).
  /// `f_ext` holds the external force on every quanta for this step [N], or is empty for gravity
  /// alone, m_i g on every quanta, when the integrator forms_gravity().
  virtual void project(const Model& model, const State& state, const Adjacency& adj,
                       const std::vector<Vec3>& f_ext, const StepContext& ctx, Projection& out) = 0;
  /// Whether project() takes an empty `f_ext` for gravity alone in a direct step
  /// (StepContext::direct), forming m_i g in its own passes: Simulation then skips the pass that
  /// fills the array when no load or queued force adds to gravity.
  virtual bool forms_gravity() const { return false; }
  /// Fraction θ of the step's velocity change at which this integrator evaluates damping forces
  /// (0: start of step, 1: end, ½: between). The energy ledger charges damping work at v + θ dv.
  virtual double damping_theta() const = 0;
  /// Fraction φ of the step's displacement at which axial dampers take their direction
  /// d + φ Δd (0: the start-of-step bond; ½ for the midpoint-evaluated integrators).
  virtual double damping_direction_theta() const { return 0.0; }
  /// Whether bond tensions are discrete gradients over the step, T̄ = ΔU/Δr along the midpoint
  /// bond (energy_momentum); the ledger then charges prescribed quanta that force, so that it
  /// closes exactly, instead of the trapezoid rule.
  virtual bool discrete_gradient() const { return false; }
  const IntegratorConfig& config() const { return config_; }
  const SolveStats& stats() const { return stats_; }

 protected:
  explicit Integrator(const IntegratorConfig& c) : config_(c) {}
  IntegratorConfig config_;
  SolveStats stats_;
};

/// Creates the integrator a configuration names. Throws std::invalid_argument on bad options.
std::unique_ptr<Integrator> make_integrator(const IntegratorConfig& config);

/// The options of IntegratorConfig by scene-file key, as bits: which ones an integrator reads.
enum class IntegratorOption : std::uint16_t {
  neighbours = 1 << 0,
  solver = 1 << 1,
  iterations = 1 << 2,
  max_iterations = 1 << 3,
  tolerance = 1 << 4,
  chebyshev_rho = 1 << 5,
  warm_start = 1 << 6,
  restore_momentum = 1 << 7,
  newton_iterations = 1 << 8,
  newton_polish = 1 << 9,
  threads = 1 << 10,         ///< every integrator
  restore_energy = 1 << 11,  ///< every integrator (Simulation applies it)
};

/// An option's scene-file key and what it sets, one line.
struct IntegratorOptionInfo {
  IntegratorOption option;
  std::string_view key;
  std::string_view description;
};

/// A value of one of the integrators' enumerations with its scene-file name and one line on it.
template <class E>
struct NamedValue {
  E value;
  std::string_view key;
  std::string_view description;
};

/// One integrator: its scene-file key, one line on it, the options it reads and the values of
/// `solver` and `warm_start` it takes. The one list of integrators: scene files, the command
/// line, the viewer's menu and the docs all take their integrators and options from it.
struct IntegratorInfo {
  IntegratorType type;
  std::string_view key;
  std::string_view description;
  std::uint16_t options;                   ///< IntegratorOption bits
  std::span<const CoupledSolver> solvers;  ///< the `solver` values it takes (empty: it reads none)
  std::span<const WarmStart> warm_starts;  ///< the `warm_start` values it takes (empty: it reads none)
  std::unique_ptr<Integrator> (*make)(const IntegratorConfig&);  ///< its constructor (options checked)
  bool reads(IntegratorOption o) const { return (options & static_cast<std::uint16_t>(o)) != 0; }
};

/// Every integrator, in the order of IntegratorType.
std::span<const IntegratorInfo> integrator_table();
/// The row of integrator_table() for `t`.
const IntegratorInfo& integrator_info(IntegratorType t);
/// Every option an integrator may read, in the order scene files list them.
std::span<const IntegratorOptionInfo> integrator_options();
/// Every neighbour model, coupled solver and warm start, in enumeration order.
std::span<const NamedValue<NeighbourModel>> neighbour_models();
std::span<const NamedValue<CoupledSolver>> coupled_solvers();
std::span<const NamedValue<WarmStart>> warm_starts();

/// Scene-file names.
std::string_view to_string(IntegratorType t);
std::string_view to_string(NeighbourModel m);
std::string_view to_string(CoupledSolver s);
std::string_view to_string(WarmStart w);
std::string_view to_string(IntegratorOption o);
/// Parses scene-file names; throw std::invalid_argument listing the accepted names.
IntegratorType parse_integrator_type(std::string_view s);
NeighbourModel parse_neighbour_model(std::string_view s);
CoupledSolver parse_coupled_solver(std::string_view s);
WarmStart parse_warm_start(std::string_view s);

/// Fills the kinematic quanta's rows of a projection with their prescribed motion over
/// [ctx.t, ctx.t + h] (free rows untouched). Every integrator calls it first.
void project_kinematic(const Model& model, const State& state, const StepContext& ctx,
                       Projection& out);

/// Puts the kinematic quanta that follow a motion exactly on their prescribed path at time t:
/// x[i], v[i] = their position and velocity there (arrays of the model's quanta count). What a
/// step applies to them, so that they do not drift by round-off.
void place_kinematic(const Model& model, double t, Vec3* x, Vec3* v);

/// The prescribed quanta where a step leaves them (Motion::at at its end), by index, each once (as
/// the last motion listing it places it): for passes that write the prescribed quanta's rows with
/// the other quanta of their range, on the thread whose passes own that range. With one thread
/// writing all of them (project_kinematic, place_kinematic), the other's next passes waited on
/// those cache lines (docs/performance-history.md, session 27).
class PrescribedAt {
 public:
  struct Quanta {
    Index q;
    Index order;  ///< its place in the motions' lists
    Vec3 x, v;
  };
  /// The list for time t (allocates only when it grows).
  void update(const Model& model, double t);
  /// The prescribed quanta in [lo, hi).
  std::span<const Quanta> in(std::size_t lo, std::size_t hi) const;
  /// project_kinematic's rows for the prescribed quanta in [lo, hi) (the same values).
  void project(const State& state, std::size_t lo, std::size_t hi, Projection& out) const;
  /// place_kinematic for the prescribed quanta in [lo, hi).
  void place(std::size_t lo, std::size_t hi, Vec3* x, Vec3* v) const;

 private:
  std::vector<Quanta> list_;
  std::vector<Index> index_;  // list_'s quanta alone, to search (it stays in cache)
};

}  // namespace qbond
