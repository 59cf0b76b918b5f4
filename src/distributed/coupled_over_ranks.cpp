#include "distributed/coupled_over_ranks.hpp"

#include <petscksp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "distributed/collectives.hpp"
#include "integrators/backward_euler.hpp"
#include "integrators/contact_solve.hpp"
#include "integrators/integrator_common.hpp"

namespace qbond::distributed {

namespace {

void check(PetscErrorCode code, const char* call) {
  if (code != 0)
    throw std::runtime_error(std::string("PETSc: ") + call + " failed (error " + std::to_string(code) + ")");
}

bool g_petsc_started = false;  // this program started PETSc (end_petsc ends it)

// PETSc over MPI_COMM_WORLD, started once MPI runs; without PETSc's signal handlers, so that
// the run's own SIGTERM handling (a stop agreed by every rank) stays in place.
void start_petsc() {
  PetscBool up = PETSC_FALSE;
  check(PetscInitialized(&up), "PetscInitialized");
  if (up) return;
  check(PetscOptionsSetValue(nullptr, "-no_signal_handler", nullptr), "PetscOptionsSetValue");
  check(PetscInitializeNoArguments(), "PetscInitializeNoArguments");
  g_petsc_started = true;
}

// Whether the scene asks for hypre's multigrid over ranks (`automatic` stays block Jacobi there:
// its switch is qbond's own multigrid's, which a run over ranks does not have).
bool boomeramg(const IntegratorConfig& config) { return config.preconditioner == Preconditioner::multigrid; }

// Whether PETSC_OPTIONS names a preconditioner (-pc_type): it then gets the assembled matrix.
bool preconditioner_from_options() {
  PetscBool set = PETSC_FALSE;
  check(PetscOptionsHasName(nullptr, nullptr, "-pc_type", &set), "PetscOptionsHasName");
  return set == PETSC_TRUE;
}

// The whole system's rows a rank owns as a PETSc operator in 3×3 blocks, with its vectors and its
// CG solver, built for one piece and its bonds (the pattern holds while they do). `assembled`:
// A as PETSc's matrix, filled from the system's blocks every step (hypre's multigrid, or a
// preconditioner PETSC_OPTIONS names); else a shell whose product is qbond's own bond pass over
// the piece (SystemProduct), the ghosts' rows of its argument scattered from their owners, and
// CG preconditioned by the owned rows' inverted diagonal blocks.
class RanksSystem {
 public:
  RanksSystem(const SolveLayout& layout, const State& state, const Adjacency& adj, const IntegratorConfig& config,
              bool assembled)
      : assembled_(assembled), threads_(config.threads) {
    start_petsc();
    const auto own = static_cast<PetscInt>(layout.owned_free.size());
    const auto total = static_cast<PetscInt>(layout.rows);
    if (assembled_)
      create_matrix(layout, adj, config);
    else
      create_shell(layout, own, total);
    check(MatCreateVecs(A_, &x_, &b_), "MatCreateVecs");
    if (assembled_) set_rigid_modes(layout, state, own);

    check(KSPCreate(PETSC_COMM_WORLD, &ksp_), "KSPCreate");
    check(KSPSetOperators(ksp_, A_, A_), "KSPSetOperators");
    check(KSPSetType(ksp_, KSPCG), "KSPSetType(KSPCG)");
    // qbond's CG criterion: the true (unpreconditioned) residual against ‖b‖.
    check(KSPSetNormType(ksp_, KSP_NORM_UNPRECONDITIONED), "KSPSetNormType");
    cap_ = config.max_iterations > 0 ? config.max_iterations : static_cast<int>(3 * layout.rows);
    set_tolerance(config.tolerance);
    PC pc;
    check(KSPGetPC(ksp_, &pc), "KSPGetPC");
    if (!assembled_) {
      // A's 3 × 3 diagonal blocks inverted, as qbond's own CG.
      check(PCSetType(pc, PCSHELL), "PCSetType(PCSHELL)");
      check(PCShellSetContext(pc, this), "PCShellSetContext");
      check(PCShellSetApply(pc, &RanksSystem::shell_precondition), "PCShellSetApply");
      check(PCShellSetName(pc, "qbond: inverted 3x3 diagonal blocks"), "PCShellSetName");
    } else if (!boomeramg(config)) {
      check(PCSetType(pc, PCPBJACOBI), "PCSetType(PCPBJACOBI)");
    } else {
      // hypre's BoomerAMG: the same bits on every run over the same ranks (GAMG, measured, not
      // over three ranks).
      check(PCSetType(pc, PCHYPRE), "PCSetType(PCHYPRE)");
      check(PCHYPRESetType(pc, "boomeramg"), "PCHYPRESetType(boomeramg)");
    }
    check(KSPSetFromOptions(ksp_), "KSPSetFromOptions");  // PETSC_OPTIONS may choose another
  }
  RanksSystem(const RanksSystem&) = delete;
  RanksSystem& operator=(const RanksSystem&) = delete;
  ~RanksSystem() {
    (void)KSPDestroy(&ksp_);
    (void)VecScatterDestroy(&scatter_);
    (void)VecDestroy(&local_);
    (void)VecDestroy(&x_);
    (void)VecDestroy(&b_);
    (void)MatDestroy(&A_);
  }

  // Makes the operator the step's system (sys, built on the piece: model, bonds, adj): assembles
  // PETSc's matrix, or points the shell at sys (which must outlive the step's solve).
  void load(const SolveLayout& layout, const Model& model, const Bonds& bonds, const Adjacency& adj,
            const ImplicitSystem& sys) {
    if (!assembled_) {
      product_.prepare(model, bonds, sys, quanta_, threads_);
      sys_ = &sys;
      owned_free_ = &layout.owned_free;
      return;
    }
    check(MatZeroEntries(A_), "MatZeroEntries");
    const std::size_t own = layout.owned_free.size();
    // One block row at a time: its diagonal block, then −B_b towards each free neighbour in the
    // quanta's adjacency order (values row-major over the row's 3 × 3·columns).
    for (std::size_t k = 0; k < own; ++k) {
      const Index i = layout.owned_free[k];
      cols_.assign(1, static_cast<PetscInt>(layout.row[i]));
      blocks_.assign(1, sys.diag[i]);
      for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
        const std::int64_t r = layout.row[adj.other[e]];
        if (r < 0) continue;
        const Index bond = adj.bond[e];
        cols_.push_back(static_cast<PetscInt>(r));
        blocks_.push_back(-block_matrix(sys.bonds.u(bond), sys.bonds.Ba[bond], sys.bonds.Bb[bond]));
      }
      const std::size_t nc = cols_.size();
      values_.resize(9 * nc);
      for (std::size_t c = 0; c < nc; ++c)
        for (int r = 0; r < 3; ++r)
          for (int s = 0; s < 3; ++s) values_[static_cast<std::size_t>(r) * 3 * nc + 3 * c + static_cast<std::size_t>(s)] = blocks_[c](r, s);
      check(MatSetValuesBlocked(A_, 1, &cols_[0], static_cast<PetscInt>(nc), cols_.data(), values_.data(), ADD_VALUES),
            "MatSetValuesBlocked");
    }
    check(MatAssemblyBegin(A_, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
    check(MatAssemblyEnd(A_, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  }

  // CG stops at ‖b − A y‖ ≤ tolerance max(‖b‖, scale), scale the whole system's h‖f_ext‖ for
  // coupled steps (ImplicitSystem::load_norm), 0 for Newton's.
  void set_tolerance(double tolerance, double scale = 0) {
    check(KSPSetTolerances(ksp_, tolerance, tolerance * scale, PETSC_DEFAULT, cap_), "KSPSetTolerances");
    scale_ = scale;
  }

  // Solves the loaded system for the owned free quanta's rows of y (right-hand side sys.rhs),
  // from y's rows when `guessed`, else from zero (collective).
  void solve(const SolveLayout& layout, const ImplicitSystem& sys, bool guessed, std::vector<Vec3>& y,
             SolveStats& stats) {
    const std::size_t own = layout.owned_free.size();
    {
      PetscScalar *pb = nullptr, *px = nullptr;
      check(VecGetArray(b_, &pb), "VecGetArray");
      check(VecGetArray(x_, &px), "VecGetArray");
      for (std::size_t k = 0; k < own; ++k)
        for (int j = 0; j < 3; ++j) {
          const Index i = layout.owned_free[k];
          pb[3 * k + static_cast<std::size_t>(j)] = sys.rhs[i][j];
          px[3 * k + static_cast<std::size_t>(j)] = guessed ? y[i][j] : 0.0;
        }
      check(VecRestoreArray(b_, &pb), "VecRestoreArray");
      check(VecRestoreArray(x_, &px), "VecRestoreArray");
    }
    check(KSPSetInitialGuessNonzero(ksp_, guessed ? PETSC_TRUE : PETSC_FALSE), "KSPSetInitialGuessNonzero");
    check(KSPSolve(ksp_, b_, x_), "KSPSolve");
    PetscInt its = 0;
    PetscReal rnorm = 0, bnorm = 0;
    check(KSPGetIterationNumber(ksp_, &its), "KSPGetIterationNumber");
    check(KSPGetResidualNorm(ksp_, &rnorm), "KSPGetResidualNorm");
    check(VecNorm(b_, NORM_2, &bnorm), "VecNorm");
    stats.iterations += static_cast<int>(its);
    bnorm = std::max(bnorm, scale_);
    stats.residual = bnorm > 0 ? rnorm / bnorm : rnorm;
    const PetscScalar* px = nullptr;
    check(VecGetArrayRead(x_, &px), "VecGetArrayRead");
    for (std::size_t k = 0; k < own; ++k)
      y[layout.owned_free[k]] = Vec3(px[3 * k], px[3 * k + 1], px[3 * k + 2]);
    check(VecRestoreArrayRead(x_, &px), "VecRestoreArrayRead");
  }

  // The ghosts' rows of y from the last solve's solution, scattered from their owners (the
  // shell's; collective).
  void ghost_rows(const SolveLayout& layout, std::vector<Vec3>& y) {
    check(VecScatterBegin(scatter_, x_, local_, INSERT_VALUES, SCATTER_FORWARD), "VecScatterBegin");
    check(VecScatterEnd(scatter_, x_, local_, INSERT_VALUES, SCATTER_FORWARD), "VecScatterEnd");
    const PetscScalar* in = nullptr;
    check(VecGetArrayRead(local_, &in), "VecGetArrayRead");
    for (std::size_t k = layout.owned_free.size(); k < quanta_.size(); ++k)
      y[quanta_[k]] = Vec3(in[3 * k], in[3 * k + 1], in[3 * k + 2]);
    check(VecRestoreArrayRead(local_, &in), "VecRestoreArrayRead");
  }

  // out = A y for this rank's rows (3 per owned free quanta; collective).
  void apply(const std::vector<double>& y, std::vector<double>& out) {
    {
      PetscScalar* px = nullptr;
      check(VecGetArray(x_, &px), "VecGetArray");
      std::copy(y.begin(), y.end(), px);
      check(VecRestoreArray(x_, &px), "VecRestoreArray");
    }
    check(MatMult(A_, x_, b_), "MatMult");
    const PetscScalar* pb = nullptr;
    PetscInt n = 0;
    check(VecGetLocalSize(b_, &n), "VecGetLocalSize");
    check(VecGetArrayRead(b_, &pb), "VecGetArrayRead");
    out.assign(pb, pb + n);
    check(VecRestoreArrayRead(b_, &pb), "VecRestoreArrayRead");
  }

 private:
  // The assembled matrix, its pattern preallocated by block row from the piece's bonds.
  void create_matrix(const SolveLayout& layout, const Adjacency& adj, const IntegratorConfig& config) {
    const auto own = static_cast<PetscInt>(layout.owned_free.size());
    const auto total = static_cast<PetscInt>(layout.rows);
    const std::int64_t first = layout.first_row, last = first + own;
    // Preallocation by block row: the blocks in this rank's columns and in the others'.
    std::vector<PetscInt> d(static_cast<std::size_t>(own), 1), o(static_cast<std::size_t>(own), 0);
    for (PetscInt k = 0; k < own; ++k) {
      const Index i = layout.owned_free[static_cast<std::size_t>(k)];
      for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e) {
        const std::int64_t r = layout.row[adj.other[e]];
        if (r < 0) continue;
        ++((r >= first && r < last) ? d : o)[static_cast<std::size_t>(k)];
      }
      d[static_cast<std::size_t>(k)] = std::min(d[static_cast<std::size_t>(k)], own);
      o[static_cast<std::size_t>(k)] = std::min(o[static_cast<std::size_t>(k)], total - own);
    }
    check(MatCreate(PETSC_COMM_WORLD, &A_), "MatCreate");
    check(MatSetSizes(A_, 3 * own, 3 * own, 3 * total, 3 * total), "MatSetSizes");
    check(MatSetBlockSize(A_, 3), "MatSetBlockSize");
    // Block rows (BAIJ) for a point-block Jacobi solve, a product half the memory traffic of AIJ's;
    // AIJ for hypre, which takes that.
    const bool blocks = !boomeramg(config);
    check(MatSetType(A_, blocks ? MATBAIJ : MATAIJ), "MatSetType");
    check(MatXAIJSetPreallocation(A_, 3, d.data(), o.data(), nullptr, nullptr), "MatXAIJSetPreallocation");
    if (!blocks) {  // (BAIJ takes neither option)
      check(MatSetOption(A_, MAT_SPD, PETSC_TRUE), "MatSetOption(MAT_SPD)");
      check(MatSetOption(A_, MAT_SPD_ETERNAL, PETSC_TRUE), "MatSetOption(MAT_SPD_ETERNAL)");
    }
  }

  // The rigid-body modes of the owned free quanta's positions at the start: the near-null space
  // a smoothed-aggregation preconditioner takes (PETSC_OPTIONS="-pc_type gamg").
  void set_rigid_modes(const SolveLayout& layout, const State& state, PetscInt own) {
    Vec coords;
    check(VecDuplicate(x_, &coords), "VecDuplicate");
    {
      PetscScalar* c = nullptr;
      check(VecGetArray(coords, &c), "VecGetArray");
      for (PetscInt k = 0; k < own; ++k)
        for (int j = 0; j < 3; ++j) c[3 * k + j] = state.x[layout.owned_free[static_cast<std::size_t>(k)]][j];
      check(VecRestoreArray(coords, &c), "VecRestoreArray");
    }
    MatNullSpace rigid;
    check(MatNullSpaceCreateRigidBody(coords, &rigid), "MatNullSpaceCreateRigidBody");
    check(MatSetNearNullSpace(A_, rigid), "MatSetNearNullSpace");
    check(MatNullSpaceDestroy(&rigid), "MatNullSpaceDestroy");
    check(VecDestroy(&coords), "VecDestroy");
  }

  // The shell and what its product reads: the piece's free quanta, owned ones first (this rank's
  // rows, in order) then the ghosts (in local order), and the scatter that brings their rows of
  // a PETSc vector into one local vector in that order.
  void create_shell(const SolveLayout& layout, PetscInt own, PetscInt total) {
    const std::int64_t first = layout.first_row, last = first + own;
    quanta_ = layout.owned_free;
    for (std::size_t l = 0; l < layout.row.size(); ++l)
      if (layout.row[l] >= 0 && (layout.row[l] < first || layout.row[l] >= last)) quanta_.push_back(static_cast<Index>(l));
    std::vector<PetscInt> rows(quanta_.size());
    for (std::size_t k = 0; k < quanta_.size(); ++k) rows[k] = static_cast<PetscInt>(layout.row[quanta_[k]]);
    const auto n = static_cast<PetscInt>(quanta_.size());
    product_out_.resize(3 * quanta_.size());

    check(MatCreate(PETSC_COMM_WORLD, &A_), "MatCreate");
    check(MatSetSizes(A_, 3 * own, 3 * own, 3 * total, 3 * total), "MatSetSizes");
    check(MatSetBlockSize(A_, 3), "MatSetBlockSize");
    check(MatSetType(A_, MATSHELL), "MatSetType(MATSHELL)");
    check(MatShellSetContext(A_, this), "MatShellSetContext");
    check(MatShellSetOperation(A_, MATOP_MULT, reinterpret_cast<void (*)(void)>(&RanksSystem::shell_multiply)),
          "MatShellSetOperation(MATOP_MULT)");
    check(MatSetOption(A_, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption(MAT_SYMMETRIC)");
    check(MatSetUp(A_), "MatSetUp");

    Vec global;
    check(MatCreateVecs(A_, &global, nullptr), "MatCreateVecs");
    check(VecCreateSeq(PETSC_COMM_SELF, 3 * n, &local_), "VecCreateSeq");
    IS from, to;
    check(ISCreateBlock(PETSC_COMM_SELF, 3, n, rows.data(), PETSC_COPY_VALUES, &from), "ISCreateBlock");
    check(ISCreateStride(PETSC_COMM_SELF, 3 * n, 0, 1, &to), "ISCreateStride");
    check(VecScatterCreate(global, from, local_, to, &scatter_), "VecScatterCreate");
    check(ISDestroy(&from), "ISDestroy");
    check(ISDestroy(&to), "ISDestroy");
    check(VecDestroy(&global), "VecDestroy");
  }

  // y = A x by the shell: x's rows of the piece's free quanta gathered (the ghosts' from their
  // owners), qbond's bond pass over the piece, and its owned rows kept.
  static PetscErrorCode shell_multiply(Mat A, Vec x, Vec y) {
    PetscFunctionBeginUser;
    RanksSystem* self = nullptr;
    PetscCall(MatShellGetContext(A, &self));
    PetscCall(VecScatterBegin(self->scatter_, x, self->local_, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecScatterEnd(self->scatter_, x, self->local_, INSERT_VALUES, SCATTER_FORWARD));
    const PetscScalar* in = nullptr;
    PetscCall(VecGetArrayRead(self->local_, &in));
    self->product_.apply(in, self->product_out_.data(), self->threads_);
    PetscCall(VecRestoreArrayRead(self->local_, &in));
    PetscScalar* out = nullptr;
    PetscInt n = 0;
    PetscCall(VecGetLocalSize(y, &n));
    PetscCall(VecGetArray(y, &out));
    std::copy_n(self->product_out_.data(), n, out);
    PetscCall(VecRestoreArray(y, &out));
    PetscFunctionReturn(0);
  }

  // z = blockdiag(A_ii)⁻¹ r over this rank's rows (qbond's inverted diagonal blocks).
  static PetscErrorCode shell_precondition(PC pc, Vec r, Vec z) {
    PetscFunctionBeginUser;
    RanksSystem* self = nullptr;
    PetscCall(PCShellGetContext(pc, &self));
    const PetscScalar* in = nullptr;
    PetscScalar* out = nullptr;
    PetscCall(VecGetArrayRead(r, &in));
    PetscCall(VecGetArray(z, &out));
    const std::vector<Index>& owned = *self->owned_free_;
    for (std::size_t k = 0; k < owned.size(); ++k) {
      const Vec3 zk = self->sys_->diag_inv[owned[k]] * Vec3(in[3 * k], in[3 * k + 1], in[3 * k + 2]);
      for (int j = 0; j < 3; ++j) out[3 * k + static_cast<std::size_t>(j)] = zk[j];
    }
    PetscCall(VecRestoreArray(z, &out));
    PetscCall(VecRestoreArrayRead(r, &in));
    PetscFunctionReturn(0);
  }

  bool assembled_;
  int threads_;
  int cap_ = 0;  // CG's iterations at most
  double scale_ = 0;  // the residual's scale besides ‖b‖ (set_tolerance)
  Mat A_ = nullptr;
  Vec x_ = nullptr, b_ = nullptr;
  KSP ksp_ = nullptr;
  // The assembled matrix's row being set.
  std::vector<PetscInt> cols_;
  std::vector<Mat3> blocks_;
  std::vector<PetscScalar> values_;
  // The shell's.
  std::vector<Index> quanta_;
  Vec local_ = nullptr;
  VecScatter scatter_ = nullptr;
  SystemProduct product_;
  std::vector<double> product_out_;
  const ImplicitSystem* sys_ = nullptr;
  const std::vector<Index>* owned_free_ = nullptr;
};

// Whether the solve takes PETSc's assembled matrix: for hypre's multigrid, or a preconditioner
// PETSC_OPTIONS names; the block-Jacobi solve multiplies without it.
bool takes_matrix(const IntegratorConfig& config) {
  start_petsc();
  return boomeramg(config) || preconditioner_from_options();
}

class CoupledOverRanks final : public StepIntegrator {
 public:
  // Dampers at the end-of-step velocity (backward Euler), as the coupled integrator on one rank.
  // Obstacle contacts are each owned quanta's, solved by its rank (contact_solve.hpp); quanta–quanta
  // contacts every rank's, whose piece is then the whole world, each solve's ghost rows brought
  // from their owners before the active set reads them.
  CoupledOverRanks(const IntegratorConfig& c, SolveLayout layout, const double& whole_h)
      : StepIntegrator(c, {.damping_theta = 1.0, .backward_euler = true}), layout_(std::move(layout)), whole_h_(whole_h) {
    std::vector<std::uint8_t> owned(layout_.row.size(), 0);
    for (Index i : layout_.owned_free) owned[i] = 1;
    contact_.only_quanta(std::move(owned));
  }

  bool forms_gravity() const override { return true; }

  void project(const Model& model, const State& state, const Adjacency& adj, const std::vector<Vec3>& f_ext,
               const StepContext& ctx, Projection& out) override {
    stats_ = {};
    const int threads = config_.threads;
    begin_implicit_step(model, state, adj, f_ext, ctx, /*edges=*/false, threads, out, sys_);
    const bool contacts =
        contact_.begin(model, state, adj, f_ext, ctx.h, whole_h_ > 0 ? whole_h_ : ctx.h, threads, sys_);
    const bool guessed = initial_guess(config_.warm_start, model, f_ext, ctx.h, state.carry, threads, y_);
    if (!guessed) y_.assign(model.num_quanta(), Vec3::Zero());
    const bool pairs = contacts && model.quanta_contact.radius > 0;
    if (!system_) {
      const bool matrix = takes_matrix(config_);
      // The assembled matrix holds the bonds' blocks, not the contact pairs' (the shell's product does).
      if (matrix && pairs)
        throw std::invalid_argument(
            "over ranks, quanta contact inside the implicit solve takes the block-Jacobi solve: PETSC_OPTIONS "
            "names a preconditioner (-pc_type), which would take the assembled matrix without the contacts");
      system_ = std::make_unique<RanksSystem>(layout_, state, adj, config_, matrix);
    }
    // The residual's scale over the whole system (the piece's load_norm counts ghosts too).
    double load2 = 0;
    for (Index i : layout_.owned_free) load2 += external_force(model, f_ext, i).squaredNorm();
    double whole_load2 = 0;
    for (double part : all_gather({&load2, 1})) whole_load2 += part;
    system_->set_tolerance(config_.tolerance, ctx.h * std::sqrt(whole_load2));
    auto solve = [&](bool from_y) {
      system_->load(layout_, model, state.bonds, adj, sys_);
      system_->solve(layout_, sys_, from_y, y_, stats_);
      if (pairs) system_->ghost_rows(layout_, y_);
    };
    solve(guessed);
    // Contacts: solved again, from the last solution, while some rank's active set changes, as
    // the run alone's coupled step; those released twice return only once no rank's set changes
    // otherwise (ContactSolve::admit).
    for (int pass = 1; contacts && pass < ContactSolve::kPasses; ++pass) {
      const bool last = pass + 1 == ContactSolve::kPasses;
      int changed[1] = {contact_.update(model, state, ctx.h, threads, last, y_, sys_) ? 1 : 0};
      max_over_ranks(changed);
      if (!changed[0]) {
        int waiting[1] = {contact_.waiting() ? 1 : 0};
        max_over_ranks(waiting);
        if (!waiting[0]) break;
        changed[0] = contact_.admit(model, state, ctx.h, threads, last, y_, sys_) ? 1 : 0;
        max_over_ranks(changed);
        if (!changed[0]) break;
      }
      solve(true);
    }
    if (config_.restore_momentum) restore_momentum_over_ranks(layout_, model, f_ext, ctx.h, y_, contact_.touching());
    keep_guess(config_.warm_start, y_, ctx.h, state.carry, threads, out);
    // The ghosts' rows are their owners' to write: the exchange after the step brings them.
    write_free_rows(model, state, ctx.h, y_, threads, out);
    if (model.gravity != Vec3::Zero())
      for (Index i : layout_.lone) fall_freely(model, i, f_ext, ctx.h, contact_.touching(), out);
    if (contacts) contact_.finish(model, state, adj, ctx.h, y_, out);
    out.kinetic_loss = kinetic_loss(model, adj, out, layout_.owned_free);
  }

 private:
  SolveLayout layout_;
  const double& whole_h_;
  ImplicitSystem sys_;
  ContactSolve contact_;
  std::vector<Vec3> y_;
  std::unique_ptr<RanksSystem> system_;
};

class PetscRanksSolve final : public RanksSolve {
 public:
  PetscRanksSolve(const SolveLayout& layout, const State& state, const Adjacency& adj, const IntegratorConfig& config)
      : layout_(layout), system_(layout, state, adj, config, takes_matrix(config)) {}

  void solve(const Model& model, const Bonds& bonds, const Adjacency& adj, const ImplicitSystem& sys,
             double tolerance, std::vector<Vec3>& y, SolveStats& stats) override {
    system_.set_tolerance(tolerance);
    system_.load(layout_, model, bonds, adj, sys);
    system_.solve(layout_, sys, false, y, stats);
  }

 private:
  const SolveLayout& layout_;
  RanksSystem system_;
};

}  // namespace

std::unique_ptr<RanksSolve> make_ranks_solve(const SolveLayout& layout, const State& state, const Adjacency& adj,
                                             const IntegratorConfig& config) {
  return std::make_unique<PetscRanksSolve>(layout, state, adj, config);
}

std::unique_ptr<StepIntegrator> make_coupled_over_ranks(const IntegratorConfig& config, SolveLayout layout,
                                                        const double& whole_h) {
  IntegratorConfig c = config;
  c.warm_start = resolved_warm_start(c);  // as make_step_integrator does
  return std::make_unique<CoupledOverRanks>(c, std::move(layout), whole_h);
}

void apply_both_operators(const SolveLayout& layout, const Model& model, const State& state, const Adjacency& adj,
                          const ImplicitSystem& sys, const IntegratorConfig& config, const std::vector<double>& y,
                          std::vector<double>& matrix_free, std::vector<double>& assembled) {
  RanksSystem shell(layout, state, adj, config, false), matrix(layout, state, adj, config, true);
  shell.load(layout, model, state.bonds, adj, sys);
  matrix.load(layout, model, state.bonds, adj, sys);
  shell.apply(y, matrix_free);
  matrix.apply(y, assembled);
}

void end_petsc() {
  if (!g_petsc_started) return;
  PetscBool done = PETSC_FALSE;
  if (PetscFinalized(&done) == 0 && !done) (void)PetscFinalize();
  g_petsc_started = false;
}

}  // namespace qbond::distributed
