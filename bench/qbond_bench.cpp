// qbond's performance suite (Google Benchmark), run by `qbond bench` (docs/performance.md).
//
//   qbond_bench [benchmark flags] [--n=10,20,40] [--threads=1,2] [--integrators=a,b,...] [--dt=H]
//               [--order=built,shuffled,sorted] [--as-run]
//   qbond_bench [benchmark flags] --solve [--n=20,40]
//
// Registers, for each integrator, lattice size n and thread count, the time of one step of the
// canonical workload (samples.hpp: n³ simple-cubic lattice, face diagonals, x = 0 face anchored,
// gravity, h = 1e-4 s unless --dt says otherwise; with --as-run each step as `qbond run` takes it,
// energy ledger and rollback copy included), and a STREAM-style triad measuring this machine's memory bandwidth in the
// same run on each thread count, so that a step's time can be set against the bandwidth bound of
// the bytes it must move on as many threads. Counters: quanta, bonds, threads, bytes_per_step (the traffic model below).
//
// With --solve: the time to reach the backward-Euler solution of one step at h = 1/60 s to a
// relative residual of 1e-6, by qbond's CG preconditioned by 3×3 block Jacobi (matrix-free) and by
// multigrid (set-up included, and reported apart), by Eigen's CG (diagonal preconditioner) and
// sparse Cholesky (SimplicialLLT) on the same assembled system, and (built with PETSc) by PETSc's
// CG with GAMG and with hypre's BoomerAMG (set-up and solve apart); every row's residual is the
// true one, ‖b − A y‖ / ‖b‖.
#include <benchmark/benchmark.h>

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench_integrators.hpp"
#ifdef QBOND_PETSC
#include "petsc_solve.hpp"
#endif
#include "integrators/backward_euler.hpp"  // internal: the linear system the implicit integrators solve
#include "integrators/multigrid_step.hpp"   // internal: its multigrid-preconditioned solve
#include "qbond/model/ordering.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/simulation/simulation.hpp"

namespace {

using namespace qbond;

using bench::known_integrators;
using bench::NamedIntegrator;

// The bytes one step must move at the least, streaming every array once: per bond its two end
// indices (2 × 4 B) and stiffness, rest length and damping (3 × 8 B); per quanta position and
// velocity read (2 × 24 B), mass read (8 B), position and velocity change written (2 × 24 B).
// A step that passes over the data several times (sweeps, CG iterations) is bounded by this
// times its passes; the ratio reported is against this single pass.
double bytes_per_step(std::size_t quanta, std::size_t bonds) {
  return 32.0 * static_cast<double>(bonds) + 104.0 * static_cast<double>(quanta);
}

// The order the lattice's quanta and bonds are numbered in: as the builder made them (rows of x,
// then y, then z), shuffled (as a mesh or packing might come), or shuffled and then renumbered
// by locality_order (as scene loading does).
enum class Order { built, shuffled, sorted };

Order parse_order(const std::string& s) {
  if (s == "built") return Order::built;
  if (s == "shuffled") return Order::shuffled;
  if (s == "sorted") return Order::sorted;
  std::fprintf(stderr, "qbond_bench: --order: '%s' is not built, shuffled or sorted\n", s.c_str());
  std::exit(2);
}

void apply_order(World& w, Order order) {
  if (order == Order::built) return;
  Renumbering r;
  r.quanta.resize(w.num_quanta());
  r.bonds.resize(w.num_bonds());
  std::iota(r.quanta.begin(), r.quanta.end(), Index{0});
  std::iota(r.bonds.begin(), r.bonds.end(), Index{0});
  std::mt19937_64 rng(12345);
  std::shuffle(r.quanta.begin(), r.quanta.end(), rng);
  std::shuffle(r.bonds.begin(), r.bonds.end(), rng);
  renumber(w, r);
  if (order == Order::sorted) renumber(w, locality_order(w));
}

void step_benchmark(benchmark::State& st, const NamedIntegrator& integ, int n, int threads, double dt,
                    Order order, bool as_run) {
  Scene scene = canonical_lattice(n);
  apply_order(scene.world, order);
  if (dt > 0)
    scene.timestep = dt;
  else if (integ.timestep > 0)
    scene.timestep = integ.timestep;
  IntegratorConfig cfg = integ.config;
  cfg.threads = threads;
  const std::size_t quanta = scene.world.num_quanta(), bonds = scene.world.num_bonds();
  Simulation sim(std::move(scene.world), cfg, scene.timestep);
  sim.set_track_energy(as_run);
  sim.set_keep_last_good(as_run);
  for (int k = 0; k < 3; ++k) sim.step();  // buffers grown, caches warm
  for (auto _ : st) {
    const StepReport r = sim.step();
    if (r.status != StepReport::Status::ok) {
      st.SkipWithError("the step failed");
      break;
    }
  }
  st.counters["quanta"] = static_cast<double>(quanta);
  st.counters["bonds"] = static_cast<double>(bonds);
  st.counters["threads"] = threads;
  st.counters["timestep"] = scene.timestep;
  st.counters["bytes_per_step"] = bytes_per_step(quanta, bonds);
}

// STREAM's triad a = b + s c over arrays far larger than the caches, on `threads` threads, each
// taking one contiguous share (and touching its pages first); bytes counted as STREAM does (two
// reads and one write of 8 B per element).
void triad_benchmark(benchmark::State& st, int threads) {
  const auto n = std::ptrdiff_t{1} << 24;  // 3 × 128 MiB
  std::unique_ptr<double[]> a(new double[n]), b(new double[n]), c(new double[n]);
  double *ap = a.get(), *bp = b.get(), *cp = c.get();
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    ap[i] = 0.0;
    bp[i] = 1.0;
    cp[i] = 2.0;
  }
  const double s = 3.0;
  for (auto _ : st) {
#pragma omp parallel for schedule(static) num_threads(threads)
    for (std::ptrdiff_t i = 0; i < n; ++i) ap[i] = bp[i] + s * cp[i];
    benchmark::DoNotOptimize(ap);
    benchmark::ClobberMemory();
  }
  st.counters["bytes_per_iteration"] = 24.0 * static_cast<double>(n);
  st.counters["threads"] = threads;
}

constexpr double kSolveStep = 1.0 / 60, kSolveTolerance = 1e-6;

// The canonical lattice at rest with its adjacency and gravity as the external forces: the system
// the solver rows solve.
struct SolveCase {
  Scene scene;
  Adjacency adj;
  std::vector<Vec3> f_ext;
  explicit SolveCase(int n) : scene(canonical_lattice(n)) {
    const Model& m = scene.world.model;
    build_adjacency(m, scene.world.state, adj);
    f_ext.resize(m.num_quanta());
    for (std::size_t i = 0; i < f_ext.size(); ++i) f_ext[i] = m.mass[i] * m.gravity;
  }
};

// The true relative residual ‖b − A y‖ / ‖b‖ over the free quanta, by CG's own product.
double true_residual(const Model& m, const State& state, const ImplicitSystem& sys, const std::vector<Vec3>& y) {
  std::vector<Vec3> Ay;
  apply_system(m, state.bonds, sys, y, 1, Ay);
  double r2 = 0;
  for (std::size_t i = 0; i < y.size(); ++i)
    if (!m.is_kinematic(static_cast<Index>(i))) r2 += (sys.rhs[i] - Ay[i]).squaredNorm();
  return std::sqrt(r2) / sys.rhs_norm;
}

// The default step's system (begin_implicit_step: the linearisation included) solved by CG
// preconditioned by 3×3 block Jacobi from zero, on one thread, as coupled_implicit with
// preconditioner block_jacobi solves it.
void solve_qbond(benchmark::State& st, int n) {
  const SolveCase c(n);
  const World& w = c.scene.world;
  const Model& m = w.model;
  double residual = 0;
  int iterations = 0;
  for (auto _ : st) {
    st.PauseTiming();
    ImplicitSystem sys;
    Projection kin;
    std::vector<Vec3> y(w.num_quanta(), Vec3::Zero());
    SolveStats stats;
    st.ResumeTiming();
    begin_implicit_step(m, w.state, c.adj, c.f_ext, {.h = kSolveStep}, /*edges=*/false, 1, kin, sys);
    conjugate_gradient(m, w.state.bonds, sys, kSolveTolerance, 100000, 1, y, /*y_zero=*/true, stats);
    st.PauseTiming();
    iterations = stats.iterations;
    residual = true_residual(m, w.state, sys, y);
    st.ResumeTiming();
  }
  st.counters["solver_iterations"] = iterations;
  st.counters["residual"] = residual;
  st.counters["quanta"] = static_cast<double>(w.num_quanta());
}

// The default step's system (begin_implicit_step) solved by multigrid-preconditioned CG from zero,
// the hierarchy built for it (MultigridStep, as coupled_implicit with preconditioner multigrid
// takes its first step); counters: the set-up and CG times apart (wall, and the thread's CPU time),
// and the true residual.
void solve_multigrid(benchmark::State& st, int n) {
  const SolveCase c(n);
  const World& w = c.scene.world;
  const Model& m = w.model;
  const Adjacency& adj = c.adj;
  const std::vector<Vec3>& f_ext = c.f_ext;
  double setup = 0, solve = 0, setup_cpu = 0, solve_cpu = 0, residual = 0, levels = 0;
  int iterations = 0;
  for (auto _ : st) {
    st.PauseTiming();
    ImplicitSystem sys;
    Projection kin;
    MultigridStep mg;
    std::vector<Vec3> y;
    SolveStats stats;
    st.ResumeTiming();
    begin_implicit_step(m, w.state, adj, f_ext, {.h = kSolveStep}, /*edges=*/false, 1, kin, sys);
    mg.solve(m, w.state, adj, sys, /*contacts=*/false, kSolveStep, kSolveTolerance, 100000, 1, y, /*y_zero=*/true,
             stats);
    st.PauseTiming();
    // Summed, then averaged as the benchmark's time is: each iteration's parts are within it.
    setup += mg.setup_seconds;
    solve += mg.solve_seconds;
    setup_cpu += mg.setup_cpu_seconds;
    solve_cpu += mg.solve_cpu_seconds;
    iterations = stats.iterations;
    levels = static_cast<double>(mg.mg.levels());
    residual = true_residual(m, w.state, sys, y);
    st.ResumeTiming();
  }
  st.counters["solver_iterations"] = iterations;
  st.counters["residual"] = residual;
  const double runs = static_cast<double>(std::max<benchmark::IterationCount>(st.iterations(), 1));
  st.counters["setup_seconds"] = setup / runs;
  st.counters["solve_seconds"] = solve / runs;
  st.counters["setup_cpu_seconds"] = setup_cpu / runs;
  st.counters["solve_cpu_seconds"] = solve_cpu / runs;
  st.counters["levels"] = levels;
  st.counters["quanta"] = static_cast<double>(w.num_quanta());
}

// The same system (begin_implicit_step, as the integrators build it) assembled into a sparse
// matrix of the free unknowns and solved by Eigen: CG or SimplicialLLT.
void solve_eigen(benchmark::State& st, int n, bool cholesky) {
  const SolveCase c(n);
  const World& w = c.scene.world;
  const Model& m = w.model;
  const Adjacency& adj = c.adj;
  const std::vector<Vec3>& f_ext = c.f_ext;
  ImplicitSystem sys;
  Projection kin;
  std::vector<Eigen::Index> dof;
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::SparseMatrix<double> A;
  Eigen::VectorXd b;
  double iterations = 0, residual = 0;
  for (auto _ : st) {
    begin_implicit_step(m, w.state, adj, f_ext, {.h = kSolveStep}, /*edges=*/false, 1, kin, sys);
    assemble_system(m, w.state, sys, dof, triplets, A, b);
    Eigen::VectorXd y;
    if (cholesky) {
      Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt(A);
      y = llt.solve(b);
    } else {
      Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper> cg(A);
      cg.setTolerance(kSolveTolerance);
      y = cg.solve(b);
      iterations = static_cast<double>(cg.iterations());
    }
    residual = (b - A * y).norm() / b.norm();
    benchmark::DoNotOptimize(y.data());
  }
  if (!cholesky) st.counters["solver_iterations"] = iterations;  // a zero counter's aggregates divide by 0
  st.counters["residual"] = residual;
  st.counters["quanta"] = static_cast<double>(w.num_quanta());
}

#ifdef QBOND_PETSC
// The same system assembled (assemble_system) and copied into PETSc, solved by PETSc's CG with GAMG
// (the free quanta's rigid-body modes as near-null space) or hypre's BoomerAMG to the same
// relative residual (bench/petsc_solve.hpp); counters: the set-up (the copy into PETSc included)
// and the solve apart, and the true residual.
void solve_petsc(benchmark::State& st, int n, bench::PetscPreconditioner pc) {
  const SolveCase c(n);
  const World& w = c.scene.world;
  const Model& m = w.model;
  ImplicitSystem sys;
  Projection kin;
  std::vector<Eigen::Index> dof;
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::SparseMatrix<double> A;
  Eigen::VectorXd b;
  std::vector<double> coordinates;
  bench::PetscSolveResult r;
  double setup = 0, solve = 0;  // summed over the iterations, averaged as the benchmark's time is
  for (auto _ : st) {
    begin_implicit_step(m, w.state, c.adj, c.f_ext, {.h = kSolveStep}, /*edges=*/false, 1, kin, sys);
    assemble_system(m, w.state, sys, dof, triplets, A, b);
    coordinates.resize(static_cast<std::size_t>(A.rows()));
    for (std::size_t i = 0; i < dof.size(); ++i)
      if (dof[i] >= 0)
        for (int d = 0; d < 3; ++d) coordinates[static_cast<std::size_t>(dof[i] + d)] = w.state.x[i][d];
    r = bench::petsc_solve(A, b, coordinates, pc, kSolveTolerance, 100000);
    if (!r.converged) {
      st.SkipWithError("PETSc's CG did not converge");
      break;
    }
    setup += r.matrix_seconds + r.setup_seconds;
    solve += r.solve_seconds;
    benchmark::DoNotOptimize(r.x.data());
  }
  st.counters["solver_iterations"] = r.iterations;
  st.counters["residual"] = r.true_residual;
  const double runs = static_cast<double>(std::max<benchmark::IterationCount>(st.iterations(), 1));
  st.counters["setup_seconds"] = setup / runs;
  st.counters["solve_seconds"] = solve / runs;
  if (r.levels > 0) st.counters["levels"] = r.levels;
  st.counters["quanta"] = static_cast<double>(w.num_quanta());
}
#endif

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

std::vector<int> split_ints(const std::string& s, const char* flag) {
  std::vector<int> out;
  for (const std::string& t : split(s)) {
    char* end = nullptr;
    const long v = std::strtol(t.c_str(), &end, 10);
    if (*end != '\0' || v < 1 || v > 1000) {
      std::fprintf(stderr, "qbond_bench: %s: '%s' is not a positive integer\n", flag, t.c_str());
      std::exit(2);
    }
    out.push_back(static_cast<int>(v));
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  std::vector<int> sizes{10, 20, 40}, threads{1};
  const auto all = known_integrators();
  std::vector<std::string> names;
  for (std::size_t k = 0; k < bench::kDefaultRows; ++k) names.push_back(all[k].name);
  std::vector<std::string> orders{"built"};
  double dt = 0;
  bool solve = false, as_run = false;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    auto value = [&](const char* flag) -> const char* {
      const std::string f = std::string(flag) + "=";
      return a.rfind(f, 0) == 0 ? argv[k] + f.size() : nullptr;
    };
    if (const char* v = value("--n"))
      sizes = split_ints(v, "--n");
    else if (const char* v2 = value("--threads"))
      threads = split_ints(v2, "--threads");
    else if (const char* v3 = value("--integrators"))
      names = split(v3);
    else if (const char* v5 = value("--order"))
      orders = split(v5);
    else if (a == "--solve")
      solve = true;
    else if (a == "--as-run")
      as_run = true;
    else if (const char* v4 = value("--dt")) {
      char* end = nullptr;
      dt = std::strtod(v4, &end);
      if (*end != '\0' || !(dt > 0 && dt < 10)) {
        std::fprintf(stderr, "qbond_bench: --dt: '%s' is not a timestep in (0, 10) s\n", v4);
        return 2;
      }
    }
    else {
      std::fprintf(stderr,
                   "qbond_bench: unknown argument '%s' (--n=LIST --threads=LIST --integrators=LIST --dt=H "
                   "--order=LIST --as-run, and Google Benchmark's --benchmark_* flags)\n",
                   argv[k]);
      return 2;
    }
  }
  if (solve) {
    for (int n : sizes) {
      const std::string tail = "/n:" + std::to_string(n);
      benchmark::RegisterBenchmark(("solve/qbond_cg" + tail).c_str(), [n](benchmark::State& st) { solve_qbond(st, n); })
          ->UseRealTime()->Unit(benchmark::kMillisecond);
      benchmark::RegisterBenchmark(("solve/qbond_mg" + tail).c_str(),
                                   [n](benchmark::State& st) { solve_multigrid(st, n); })
          ->UseRealTime()->Unit(benchmark::kMillisecond);
      benchmark::RegisterBenchmark(("solve/eigen_cg" + tail).c_str(),
                                   [n](benchmark::State& st) { solve_eigen(st, n, false); })
          ->UseRealTime()->Unit(benchmark::kMillisecond);
#ifdef QBOND_PETSC
      benchmark::RegisterBenchmark(("solve/petsc_gamg" + tail).c_str(), [n](benchmark::State& st) {
        solve_petsc(st, n, bench::PetscPreconditioner::gamg);
      })->UseRealTime()->Unit(benchmark::kMillisecond);
      benchmark::RegisterBenchmark(("solve/petsc_boomeramg" + tail).c_str(), [n](benchmark::State& st) {
        solve_petsc(st, n, bench::PetscPreconditioner::boomeramg);
      })->UseRealTime()->Unit(benchmark::kMillisecond);
#endif
      // SimplicialLLT's fill-in on a 3D lattice: minutes and gigabytes past 20³ (docs/performance.md).
      if (n <= 20)
        benchmark::RegisterBenchmark(("solve/eigen_cholesky" + tail).c_str(),
                                     [n](benchmark::State& st) { solve_eigen(st, n, true); })
            ->UseRealTime()->Unit(benchmark::kMillisecond);
    }
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
  }
  for (int t : threads)
    benchmark::RegisterBenchmark(("triad/threads:" + std::to_string(t)).c_str(),
                                 [t](benchmark::State& st) { triad_benchmark(st, t); })
        ->UseRealTime()
        ->Unit(benchmark::kMillisecond);
  for (const std::string& name : names) {
    const NamedIntegrator* integ = nullptr;
    for (const auto& i : all)
      if (i.name == name) integ = &i;
    if (!integ) {
      std::string known;
      for (const auto& i : all) known += (known.empty() ? "" : ", ") + i.name;
      std::fprintf(stderr, "qbond_bench: unknown integrator '%s' (%s)\n", name.c_str(), known.c_str());
      return 2;
    }
    for (const std::string& o : orders)
      for (int n : sizes)
        for (int t : threads) {
          const Order order = parse_order(o);
          const std::string tail = (order == Order::built ? "" : "/order:" + o) + (as_run ? "/as_run" : "");
          benchmark::RegisterBenchmark(
              ("step/" + name + "/n:" + std::to_string(n) + "/threads:" + std::to_string(t) + tail).c_str(),
              [integ, n, t, dt, order, as_run](benchmark::State& st) {
                step_benchmark(st, *integ, n, t, dt, order, as_run);
              })
              ->UseRealTime()
              ->Unit(benchmark::kMillisecond);
        }
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
