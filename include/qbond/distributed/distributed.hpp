#pragma once
/// Runs split over MPI ranks (docs/distributed.md): `mpirun -np N qbond run scene.json` cuts the
/// world in space into N boxes (recursive coordinate bisection), each rank steps the quanta of its
/// box with ghost copies of their bonded neighbours, exchanged every step, and quanta that leave
/// their box move to the rank whose box they entered. Rank 0 gathers the state for the outputs.
/// Without MPI (the build option QBOND_MPI off, or a program not started by a launcher) there is
/// one rank and a run is the ordinary one.
#include <functional>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "qbond/io/scene.hpp"
#include "qbond/simulation/runner.hpp"

namespace qbond {

/// MPI for the program's lifetime (MPI_Init to MPI_Finalize) when a launcher (mpirun, mpiexec,
/// Slurm's srun) started it as one of a job's ranks; nothing otherwise, so that a program started
/// alone needs no MPI.
class MpiSession {
 public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
};

/// Whether the library was built with MPI (QBOND_MPI).
bool built_with_mpi();
/// This process's rank in the job (0 when started alone).
int mpi_rank();
/// The job's number of ranks (1 when started alone). A build without MPI reads it from the
/// launcher's environment, so that RanksRun can refuse to run over several ranks.
int mpi_ranks();

/// What a run over ranks did, per rank (rank order), gathered on rank 0 when the run ends.
struct RanksStats {
  int ranks = 1;
  std::uint64_t migrations = 0;       ///< steps after which quanta moved to another rank
  std::uint64_t recuts = 0;           ///< migrations after which the boxes were cut anew (load drift)
  std::uint64_t halo_rebuilds = 0;    ///< pieces built anew for their quanta contact halos
  std::uint64_t retakes = 0;          ///< steps taken again after a quanta moved past its contact halo
  std::uint64_t halved = 0;           ///< steps the energy guard took again in halves (coupled_implicit)
  std::vector<std::size_t> owned;     ///< quanta each rank owns at the end
  std::vector<std::size_t> ghosts;    ///< ghost quanta each rank holds at the end
  std::vector<double> bytes_sent;     ///< bytes each rank sent in ghost exchanges over the run
  std::uint64_t steps = 0;            ///< steps taken
  /// Per rank, over the steps taken [s]: the CPU time of stepping its piece, of its ledger and
  /// energy sums, and the wall time of its whole steps (exchanges and waits for other ranks included).
  std::vector<double> stepping, bookkeeping, wall;
};

/// A run of a scene over the job's ranks: every rank constructs it with the same scene and
/// settings, and rank 0 writes the run's outputs (Runner: the same files and columns as a run on
/// one rank, from the state gathered at each output step). What is not distributed yet is refused
/// with std::invalid_argument: heuristics other than fracture by strain, compression and tension
/// (`break`), loads, adaptive steps, integrators other than velocity_verlet, explicit_euler and
/// symplectic_euler.
class RanksRun {
 public:
  RanksRun(Scene scene, RunSettings settings);
  /// Resumes a checkpoint over the job's ranks (Runner::resume's arguments and guarantees): every
  /// rank reads it, whatever the number of ranks that wrote it, and rank 0 continues its outputs.
  RanksRun(const std::filesystem::path& checkpoint, const std::function<void(Scene&, RunSettings&)>& adjust,
           std::uint64_t max_memory);
  ~RanksRun();
  RanksRun(const RanksRun&) = delete;
  RanksRun& operator=(const RanksRun&) = delete;

  /// Steps to settings.steps on every rank (all ranks stop at the same step: after a blow-up on
  /// any, or when `stop` returns true on any). `progress` is called on rank 0.
  RunResult run(const std::function<bool()>& stop = {}, const std::function<void(const RunProgress&)>& progress = {});

  /// What the run did over the ranks (rank 0, once run() returned; one rank: ranks = 1).
  const RanksStats& stats() const;
  /// Rank 0: the whole world as last gathered (the outputs' state); other ranks: the scene's.
  const World& world() const;
  const Scene& scene() const;
  const RunSettings& settings() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace qbond
