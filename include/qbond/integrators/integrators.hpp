#pragma once
/// Integrators (docs/integrators.md). Every integrator, explicit or implicit, only *projects* a step: it
/// returns the change of position and velocity of every quanta without moving anything, so that
/// heuristics can edit the projection before the step applies it (simulation.hpp).
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "qbond/core/math.hpp"
#include "qbond/integrators/carry.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

/// What one step is asked to do.
struct StepContext {
  double h = 1e-3;        ///< timestep [s]
  double t = 0;           ///< time at the start of the step [s]
  std::uint64_t step = 0; ///< index of the step being taken
};

/// The change a step will make (Eqs. 8–9): dx = Δp, dv = Δv for every quanta.
struct Projection {
  std::vector<Vec3> dx;  ///< [m] (n)
  std::vector<Vec3> dv;  ///< [m/s] (n)
  /// What the step leaves in State::carry when it applies (carry.hpp; nothing unless the
  /// integrator set it with keep). A solver's solution is kept apart from dv, which round-off
  /// makes differ from it.
  Carry carry;
  /// Sets `carry` to a T for the integrator to fill, with the storage of the carry-over the
  /// projection held before when it was a T too (no allocation once warmed up).
  template <class T>
  T& keep() {
    if (!std::holds_alternative<T>(spare_)) spare_.emplace<T>();
    carry = std::move(spare_);
    return std::get<T>(carry);
  }
  /// Set by a heuristic that changed bond parameters without a topology change (plasticity's rest
  /// lengths): the step then drops a carry-over that does not hold after it (drop_after_bond_edit).
  bool bonds_edited = false;
  /// The energy of the contacts the step's solve held (Model::obstacles), for the ledger:
  /// what they removed over the step, max(0, −Σ J·(v + v₁)/2 − ΔU) (J each quanta's contact
  /// impulse), and their springs' energy U at x + dx [J].
  struct ContactEnergy {
    double dissipated = 0;
    double stored = 0;
    double stored_start = 0;  ///< the springs' energy U at the step's start [J]
    double work = 0;  ///< the contact impulses' work Σ J·(v + v₁)/2 [J] (the energy guard's balance)
    /// Σ J·Δv over the bonded free quanta in contact [J]: the contacts' share of ½ Δvᵀ M Δv in
    /// backward Euler's numerical damping (the ledger's `numerical_damping`).
    double impulse_dv = 0;
    bool charged = false;  ///< set by an integrator that solved contacts this step
  } contact;
  /// Backward Euler's ½ Σ Δv·(m Δv − J) over the free quanta with bonds (J their contact
  /// impulses), from the integrator's own Δv before any heuristic edits it: the kinetic share of
  /// the ledger's `numerical_damping` (set by coupled_implicit) [J].
  double kinetic_loss = 0;
  /// Sizes for n quanta and clears the rest; dx and dv zeroed unless `zero` is false (for an
  /// integrator that writes every row).
  void resize(std::size_t n, bool zero = true) {
    if (zero) {
      dx.assign(n, Vec3::Zero());
      dv.assign(n, Vec3::Zero());
    } else {
      dx.resize(n);
      dv.resize(n);
    }
    if (carry.index() != 0) spare_ = std::move(carry);  // keep's storage for this step
    carry = std::monostate{};
    bonds_edited = false;
    contact = {};
    kinetic_loss = 0;
  }

 private:
  Carry spare_;
};

/// Where an integrator evaluates what the energy ledger charges, so that the ledger charges the
/// step the integrator took (docs/integrators.md).
struct LedgerHints {
  /// Fraction θ of the step's velocity change at which damping forces are evaluated (0: start of
  /// step, 1: end, ½: between): the ledger charges damping work at v + θ dv.
  double damping_theta = 0;
  /// Fraction φ of the step's displacement at which axial dampers take their direction d + φ Δd
  /// (0: the start-of-step bond; ½ for the midpoint-evaluated integrators).
  double damping_direction_theta = 0;
  /// Whether bond tensions are discrete gradients over the step, T̄ = ΔU/Δr along the midpoint
  /// bond (energy_momentum): the ledger then charges prescribed quanta that force, so that it
  /// closes exactly, instead of the trapezoid rule.
  bool discrete_gradient = false;
  /// Whether the step is linearised backward Euler (coupled_implicit): the ledger then charges
  /// its numerical damping in closed form (`numerical_damping`, docs/integrators.md).
  bool backward_euler = false;
};

/// The integrators, one line each: X(name). An integrator is this line, its file of
/// src/integrators/ (which defines its row, `const IntegratorInfo <name>_integrator`: key, one
/// line on it, the solvers and warm starts it takes, its constructor) and its tests; the options
/// it reads say so in their `read_by` below (kSolvingIntegrators, kNewtonIntegrators name groups).
/// Append new integrators last: IntegratorType's values follow this order.
#define QBOND_INTEGRATORS(X)                                                                     \
  X(explicit_euler)    /* the particle method: x += h v, v += h a(x, v) */                       \
  X(symplectic_euler)  /* v += h a(x, v), then x += h v_new */                                   \
  X(velocity_verlet)   /* second order, symplectic when undamped; one force pass a step */      \
  X(rk4)               /* classical fourth-order Runge–Kutta */                                  \
  X(hybrid_implicit)   /* Eqs. 11–12: one 3×3 solve per quanta (see NeighbourModel) */          \
  X(coupled_implicit)  /* Eq. 13 linearised (Baraff–Witkin): one global linear solve */         \
  X(energy_momentum)   /* discrete gradient: keeps energy and both momenta at any step */       \
  X(implicit_midpoint) /* forces at the step's midpoint; Newton-solved, second order */          \
  X(bdf2)              /* second-order backward differentiation; Newton-solved */

/// Which integrator (QBOND_INTEGRATORS; each one's row says what it is).
enum class IntegratorType : std::uint8_t {
#define QBOND_INTEGRATOR_ENUM(name) name,
  QBOND_INTEGRATORS(QBOND_INTEGRATOR_ENUM)
#undef QBOND_INTEGRATOR_ENUM
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

/// Preconditioner of the coupled implicit integrator's CG (docs/integrators.md, "Multigrid").
enum class Preconditioner : std::uint8_t {
  block_jacobi,  ///< A's 3×3 diagonal blocks inverted; matrix-free
  multigrid,     ///< a V-cycle of smoothed aggregation with the rigid-body modes, kept across steps
  /// block_jacobi until one of its solves needs more than kMultigridAfter iterations on a world
  /// of at least kMultigridQuanta quanta, multigrid from the next step on; back to block Jacobi
  /// while it costs less than multigrid's last solve (docs/integrators.md, "Multigrid")
  automatic,
};

/// The block-Jacobi iterations above which `automatic` turns to multigrid: where a multigrid
/// solve's dozen iterations cost less (docs/integrators.md, "Multigrid").
inline constexpr int kMultigridAfter = 100;
/// The fewest quanta for which `automatic` turns to multigrid: on smaller bodies a block-Jacobi
/// solve costs about as much as a multigrid one, and a kept hierarchy's upkeep does not pay
/// (docs/integrators.md, "Multigrid").
inline constexpr std::size_t kMultigridQuanta = 2000;

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
  Preconditioner preconditioner = Preconditioner::automatic;  ///< coupled_implicit with cg
  int iterations = 1;        ///< sweep/jacobi: sweeps per step (≥ 1)
  int max_iterations = 0;    ///< cg: iteration cap (0: three times the free unknowns)
  double tolerance = 1e-6;   ///< relative residual at which sweeps (‖b - A dv‖/‖b‖) and cg (‖b - A dv‖/max(‖b‖, h‖f_ext‖)) stop;
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
                    ///< results are the same bits for any count; at most max_threads()
  bool restore_momentum = true;  ///< iterative solvers: give each free component its exact
                                 ///< momentum change h Σ f_ext (see docs/integrators.md)
  /// After each step, give back the energy the integrator itself removed (or take back what it
  /// made): the free quanta's velocities relative to their component's rigid motion are scaled so
  /// that the energy budget closes, keeping every free component's linear and angular momentum
  /// (docs/integrators.md, "Energy restoration"). Costs two energy passes per step.
  bool restore_energy = false;
};

/// The most threads a run may ask for: 4 × the machine's hardware threads, and at least 64 so
/// that a scene written on a workstation runs anywhere. More threads than cores only wait on
/// each other, and OpenMP fails (or crashes) when asked for tens of thousands.
int max_threads();
/// The threads `threads` stands for (0: OpenMP's default, from OMP_NUM_THREADS or the cores).
/// Throws std::invalid_argument, saying where the count came from, above max_threads().
int checked_thread_count(int threads);
/// max_threads() and where it comes from, for messages.
std::string max_threads_text();

/// The defaults qbond ships (chosen from the measurements in docs/integrators.md).
IntegratorConfig default_integrator();

/// Statistics of the last projection (iterative solvers fill them).
struct SolveStats {
  int iterations = 0;        ///< sweeps or CG iterations taken
  double residual = 0;       ///< final relative residual (the tolerance's; 0 for direct solvers);
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
  /// `f_ext` holds the external force on every quanta for this step [N].
  virtual void project(const Model& model, const State& state, const Adjacency& adj,
                       const std::vector<Vec3>& f_ext, const StepContext& ctx, Projection& out) = 0;
  /// Drops what it keeps from step to step beyond State::carry (a multigrid hierarchy, the
  /// automatic preconditioner's choice), so that its next step depends on the State alone, as a
  /// new integrator's would: where a checkpoint is written or restored, a resumed run and the
  /// uninterrupted one then go on with the same bits.
  virtual void forget_history() {}
  /// Where this integrator evaluates damping and bond tensions, for the energy ledger.
  const LedgerHints& ledger_hints() const { return hints_; }
  const IntegratorConfig& config() const { return config_; }
  const SolveStats& stats() const { return stats_; }

 protected:
  Integrator(const IntegratorConfig& c, const LedgerHints& hints) : config_(c), hints_(hints) {}
  IntegratorConfig config_;
  LedgerHints hints_;
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
  preconditioner = 1 << 12,
};

/// An option: its scene-file key, what it sets (one line), and the field of IntegratorConfig
/// that holds it with the values it takes. The scene reader, the resolved scene, the JSON Schema
/// and the Python module read and write every option through its row alone.
struct IntegratorOptionInfo {
  /// What the field holds: a count, a number, a flag, or one of a list of names.
  enum class Holds : std::uint8_t { integer, number, boolean, name };
  IntegratorOption option;
  std::string_view key;
  std::string_view description;
  /// The docs' text on it, after the values it takes (`qbond key-tables`).
  std::string_view doc;
  std::uint16_t read_by = 0;  ///< the integrators that read it: bits 1 << IntegratorType (integrator_bits)
  Holds holds;
  int IntegratorConfig::*integer = nullptr;    ///< integer: the field, at least `least`
  double IntegratorConfig::*number = nullptr;  ///< number: the field, > 0 when `positive`, else ≥ 0
  bool IntegratorConfig::*boolean = nullptr;   ///< boolean: the field
  /// name: the field's scene-file name, setting it from one (throws std::invalid_argument listing
  /// the names), and the names it takes.
  std::string_view (*name_of)(const IntegratorConfig&) = nullptr;
  void (*set_name)(IntegratorConfig&, std::string_view) = nullptr;
  std::vector<std::string_view> (*names)() = nullptr;
  std::int64_t least = 0;
  /// integer: the largest count, and how to say it (empty: no bound).
  int (*most)() = nullptr;
  std::string (*most_text)() = nullptr;
  bool positive = false;
  double below = std::numeric_limits<double>::infinity();  ///< number: values must be below it
};

class StepIntegrator;  // the integrators with their private paths (src/integrators/advance.hpp)

/// A value of one of the integrators' enumerations with its scene-file name and one line on it.
template <class E>
struct NamedValue {
  E value;
  std::string_view key;
  std::string_view description;
};

/// One integrator's row, defined in its own file: its scene-file key, one line on it, and the
/// values of `solver` and `warm_start` it takes (the options it reads: their rows' read_by).
/// Scene files, the command line, the viewer's menu and the docs take their integrators from the
/// rows (integrator_table()).
struct IntegratorInfo {
  IntegratorType type;
  std::string_view key;
  std::string_view description;
  std::span<const CoupledSolver> solvers;  ///< the `solver` values it takes (empty: it reads none)
  std::span<const WarmStart> warm_starts;  ///< the `warm_start` values it takes (empty: it reads none)
  /// Its constructor, options checked (the library's: make_integrator is the public way).
  std::unique_ptr<StepIntegrator> (*make)(const IntegratorConfig&);
  /// Whether it reads an option (the option's row of kIntegratorOptions says).
  bool reads(IntegratorOption o) const;
};

/// Every integrator's row, in the order of IntegratorType (QBOND_INTEGRATORS).
std::span<const IntegratorInfo> integrator_table();
/// The row of integrator_table() for `t`.
const IntegratorInfo& integrator_info(IntegratorType t);
/// Every option an integrator may read, in the order scene files list them (kIntegratorOptions).
std::span<const IntegratorOptionInfo> integrator_options();
/// Every neighbour model, coupled solver and warm start, in enumeration order.
std::span<const NamedValue<NeighbourModel>> neighbour_models();
std::span<const NamedValue<CoupledSolver>> coupled_solvers();
std::span<const NamedValue<WarmStart>> warm_starts();
std::span<const NamedValue<Preconditioner>> preconditioners();

/// Scene-file names.
std::string_view to_string(IntegratorType t);
std::string_view to_string(NeighbourModel m);
std::string_view to_string(CoupledSolver s);
std::string_view to_string(WarmStart w);
std::string_view to_string(Preconditioner p);
std::string_view to_string(IntegratorOption o);
/// Parses scene-file names; throw std::invalid_argument listing the accepted names.
IntegratorType parse_integrator_type(std::string_view s);
NeighbourModel parse_neighbour_model(std::string_view s);
CoupledSolver parse_coupled_solver(std::string_view s);
WarmStart parse_warm_start(std::string_view s);
Preconditioner parse_preconditioner(std::string_view s);

/// The integrators an option's row says read it, as bits 1 << IntegratorType.
constexpr std::uint16_t integrator_bits(std::initializer_list<IntegratorType> types) {
  std::uint16_t b = 0;
  for (IntegratorType t : types) b = static_cast<std::uint16_t>(b | (1u << static_cast<int>(t)));
  return b;
}
/// Every integrator, present and to come.
inline constexpr std::uint16_t kEveryIntegrator = 0xFFFF;
/// The Newton-solved integrators.
inline constexpr std::uint16_t kNewtonIntegrators =
    integrator_bits({IntegratorType::energy_momentum, IntegratorType::implicit_midpoint, IntegratorType::bdf2});
/// The integrators that solve for the step (a tolerance, a warm start, momentum restoration).
inline constexpr std::uint16_t kSolvingIntegrators =
    kNewtonIntegrators | integrator_bits({IntegratorType::hybrid_implicit, IntegratorType::coupled_implicit});

/// The scene-file names of an enumeration's values.
template <class E>
std::vector<std::string_view> names_of(std::span<const NamedValue<E>> values) {
  std::vector<std::string_view> names;
  for (const NamedValue<E>& v : values) names.push_back(v.key);
  return names;
}

/// Every option an integrator may read, one row each: its key, one line, the integrators that
/// read it, and its field of IntegratorConfig with the values it takes. The scene reader, the
/// resolved scene, the JSON Schema, the Python module, the command line and the viewer read and
/// write every option through its row alone; a new option is its field above, its row here and
/// the code that reads it in its integrators' files.
namespace integrator_options_detail {
using O = IntegratorOption;
using H = IntegratorOptionInfo::Holds;
using C = IntegratorConfig;
using T = IntegratorType;
inline constexpr IntegratorOptionInfo rows[] = {
    {.option = O::neighbours,
     .key = "neighbours",
     .description = "how the hybrid solve treats a quanta's neighbours",
     .doc = "how a step treats a quanta's neighbours (`frozen`: the paper's, held at their start positions "
            "and at rest), spelled as the command line's `--neighbours`. Not the bodies' `neighbors` (which "
            "bonds a lattice makes): each key has one spelling, and the other is refused as an unknown key",
     .read_by = integrator_bits({T::hybrid_implicit}),
     .holds = H::name,
     .name_of = [](const C& c) { return to_string(c.neighbours); },
     .set_name = [](C& c, std::string_view s) { c.neighbours = parse_neighbour_model(s); },
     .names = [] { return names_of(neighbour_models()); }},
    {.option = O::solver,
     .key = "solver",
     .description = "the linear solver",
     .doc = "`sweep`, for the Newton integrators only, is `iterations` colour-ordered Gauss–Seidel sweeps per "
            "Newton iteration (the coupled integrator's sweeps are `hybrid_implicit` with `neighbours` "
            "`sweep`)",
     .read_by = kNewtonIntegrators | integrator_bits({T::coupled_implicit}),
     .holds = H::name,
     .name_of = [](const C& c) { return to_string(c.solver); },
     .set_name = [](C& c, std::string_view s) { c.solver = parse_coupled_solver(s); },
     .names = [] { return names_of(coupled_solvers()); }},
    {.option = O::iterations,
     .key = "iterations",
     .description = "sweeps per step (hybrid) or per Newton iteration (solver sweep), >= 1",
     .doc = "sweeps per step (per Newton iteration with `solver` `sweep`)",
     .read_by = kNewtonIntegrators | integrator_bits({T::hybrid_implicit}),
     .holds = H::integer,
     .integer = &C::iterations,
     .least = 1},
    {.option = O::max_iterations,
     .key = "max_iterations",
     .description = "CG's iteration cap (0: three times the free unknowns)",
     .doc = "CG's cap (0: three times the unknowns)",
     .read_by = kNewtonIntegrators | integrator_bits({T::coupled_implicit}),
     .holds = H::integer,
     .integer = &C::max_iterations},
    {.option = O::tolerance,
     .key = "tolerance",
     .description = "relative residual at which sweeps, CG and Newton stop",
     .doc = "relative residual at which sweeps and CG stop (CG's against the larger of ‖b‖ and the step's external "
            "impulse h‖f_ext‖); for the Newton integrators, of the nonlinear step",
     .read_by = kSolvingIntegrators,
     .holds = H::number,
     .number = &C::tolerance,
     .positive = true},
    {.option = O::chebyshev_rho,
     .key = "chebyshev_rho",
     .description = "sweeps: spectral radius for Chebyshev acceleration, [0, 1) (0: off)",
     .doc = "Chebyshev acceleration of sweeps: the sweeps' spectral radius (0: off)",
     .read_by = kNewtonIntegrators | integrator_bits({T::hybrid_implicit}),
     .holds = H::number,
     .number = &C::chebyshev_rho,
     .below = 1},
    {.option = O::warm_start,
     .key = "warm_start",
     .description = "the iterative solvers' initial guess",
     .doc = "the iterative solvers' first guess; `external` is `h f_ext / m`, `previous` the last step's `Δv` "
            "(not with `bdf2`, whose carry-over is the previous state), `extrapolated` the line through the "
            "last two steps' `Δv` when they had this step's length (`hybrid_implicit` and `coupled_implicit` "
            "only), `auto` `extrapolated` for `coupled_implicit` with `cg`, else `zero`",
     .read_by = kSolvingIntegrators,
     .holds = H::name,
     .name_of = [](const C& c) { return to_string(c.warm_start); },
     .set_name = [](C& c, std::string_view s) { c.warm_start = parse_warm_start(s); },
     .names = [] { return names_of(warm_starts()); }},
    {.option = O::restore_momentum,
     .key = "restore_momentum",
     .description = "give each free component its exact momentum change",
     .doc = "give each free component its exact momentum change `h Σ f_ext`, which an iterative solve stopped "
            "at its tolerance misses slightly ([integrators.md](integrators.md))",
     .read_by = kSolvingIntegrators,
     .holds = H::boolean,
     .boolean = &C::restore_momentum},
    {.option = O::newton_iterations,
     .key = "newton_iterations",
     .description = "Newton iterations per step at most, >= 1",
     .doc = "Newton iterations per step at most",
     .read_by = kNewtonIntegrators,
     .holds = H::integer,
     .integer = &C::newton_iterations,
     .least = 1},
    {.option = O::newton_polish,
     .key = "newton_polish",
     .description = "exact-Newton corrections to round-off once the tolerance is met",
     .doc = "after Newton meets `tolerance`, exact-Newton corrections until the residual stops decreasing, so "
            "that both momenta (and `energy_momentum`'s energy) are kept to round-off; one or two sparse LU "
            "solves per step ([integrators.md](integrators.md), \"Polishing\")",
     .read_by = integrator_bits({T::energy_momentum, T::implicit_midpoint}),
     .holds = H::boolean,
     .boolean = &C::newton_polish},
    {.option = O::threads,
     .key = "threads",
     .description = "OpenMP threads (0: all cores); the same bits for any count",
     .doc = "OpenMP threads (0: `OMP_NUM_THREADS` or every core); results are the same bits for any count. A "
            "world of fewer than 4 096 quanta steps on one thread whatever the count: threads would gain it "
            "nothing and keep the other cores busy waiting",
     .read_by = kEveryIntegrator,
     .holds = H::integer,
     .integer = &C::threads,
     .most = max_threads,
     .most_text = max_threads_text},
    {.option = O::restore_energy,
     .key = "restore_energy",
     .description = "give back the energy the integrator removed (or take back what it made)",
     .doc = "after each step, give back the energy the integrator removed by scaling internal velocities "
            "(momenta kept; [integrators.md](integrators.md), \"Energy restoration\")",
     .read_by = kEveryIntegrator,
     .holds = H::boolean,
     .boolean = &C::restore_energy},
    {.option = O::preconditioner,
     .key = "preconditioner",
     .description = "CG's preconditioner",
     .doc = "CG's preconditioner; `block_jacobi` inverts A's 3×3 diagonal blocks (matrix-free), `multigrid` "
            "is smoothed aggregation with the rigid-body modes, its hierarchy kept across steps, `automatic` "
            "block Jacobi until one of its steps needs many iterations, then whichever of the two cost less "
            "on its last step "
            "([integrators.md](integrators.md), \"Multigrid\")",
     .read_by = integrator_bits({T::coupled_implicit}),
     .holds = H::name,
     .name_of = [](const C& c) { return to_string(c.preconditioner); },
     .set_name = [](C& c, std::string_view s) { c.preconditioner = parse_preconditioner(s); },
     .names = [] { return names_of(preconditioners()); }},
};
}  // namespace integrator_options_detail
inline constexpr std::span<const IntegratorOptionInfo> kIntegratorOptions = integrator_options_detail::rows;

/// Fills the kinematic quanta's rows of a projection with their prescribed motion over
/// [ctx.t, ctx.t + h] (free rows untouched). Every integrator calls it first.
void project_kinematic(const Model& model, const State& state, const StepContext& ctx,
                       Projection& out);

/// Puts the kinematic quanta that follow a motion exactly on their prescribed path at time t:
/// x[i], v[i] = their position and velocity there (arrays of the model's quanta count). What a
/// step applies to them, so that they do not drift by round-off.
void place_kinematic(const Model& model, double t, Vec3* x, Vec3* v);

}  // namespace qbond
