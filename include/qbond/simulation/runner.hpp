#pragma once
/// A run of a scene with its outputs (docs/running.md): diagnostics.csv, ParaView frames and series,
/// run.json and checkpoints, continued bit for bit from any checkpoint. The `qbond run` program
/// is this plus a progress bar and signal handling; the library keeps no global state.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "qbond/io/scene.hpp"
#include "qbond/simulation/simulation.hpp"

namespace qbond {

/// How a scene is run. Saved in checkpoints, so that a resumed run goes on the same way.
struct RunSettings {
  std::filesystem::path out_dir = "out";  ///< made absolute when the run starts
  std::uint64_t steps = 0;                ///< the step count at which the run ends (total, not remaining)
  std::uint64_t every = 1;                ///< steps between diagnostics rows and frames
  std::uint64_t checkpoint_every = 0;     ///< steps between checkpoints; 0: at the end and on stops only
  bool vtk = true;                        ///< write .vtp frames and the .pvd series
  /// Charge the energy ledger every step (Simulation::set_track_energy). Off: a step costs one
  /// pass over the bonds less, the ledger's columns are written as nan, and no energy gain is
  /// checked or guarded against. Kept in checkpoints. Not over MPI ranks.
  bool ledger = true;
  /// Over MPI ranks: each frame a .pvtp with one .vtp piece per rank (RanksRun); alone, no effect.
  /// Not kept in checkpoints: a resumed run takes it from its command line.
  bool frame_pieces = false;
  /// When set, writes each frame, to the file it is given (frames/frame_<step>.pvtp), instead of
  /// a whole-world .vtp: RanksRun's, whose ranks write a piece each.
  std::function<void(const std::filesystem::path&)> write_frame;
  /// Over MPI ranks (RanksRun): the ranks' boxes as JSON, written into each checkpoint's metadata
  /// as `ranks`, so that a run resumed over as many ranks cuts the world where this one did.
  std::function<std::string()> ranks_layout;
  /// The `ranks` of the checkpoint a run resumes from (read_checkpoint), as JSON; empty if none.
  std::string resumed_ranks;
  /// The adaptive controller's state in the checkpoint a run resumes from (read_checkpoint): the
  /// step it proposes next and the one that led to its state [s]; 0 when it has none.
  double resumed_next_step = 0, resumed_last_step = 0;
};

/// The file of a step's frame, relative to the output directory: frames/frame_<step, 10
/// digits>.<extension>.
std::string frame_file(std::uint64_t step, std::string_view extension);

/// The settings a scene asks for (its `steps` and `output` section).
RunSettings settings_of(const Scene& scene);

/// Where a run stands, for progress displays.
struct RunProgress {
  std::uint64_t step = 0;        ///< steps taken so far (state.step)
  std::uint64_t first_step = 0;  ///< step at which this invocation started
  std::uint64_t last_step = 0;   ///< step at which the run ends
  double time = 0;               ///< simulated time [s]
  double wall_seconds = 0;       ///< wall time of this invocation so far [s]
  /// Whether the step adapts: the run then ends at a time, not at last_step (an estimate).
  bool adaptive = false;
  double fraction = 0;  ///< of this invocation's run done: by steps, or by simulated time if adaptive
};

/// How a run ended.
enum class RunStatus : std::uint8_t { completed, stopped, blowup };

struct RunResult {
  RunStatus status = RunStatus::completed;
  std::string message;  ///< blow-up: what, where and when; stopped: the step it was interrupted at
  std::uint64_t steps_taken = 0;
  double wall_seconds = 0;
  /// The run's largest energy gain beyond the external work (Simulation::energy_gain): when it
  /// exceeded limits.energy_gain, events.csv has an `energy_gain` row at the step it first did,
  /// and run.json an `energy_gain` object with `exceeded` true.
  EnergyGain energy_gain;
};

/// One run: the simulation and the files it writes into settings.out_dir:
///   diagnostics.csv   one row per output step (columns: diagnostics.hpp)
///   frames/*.vtp      one VTK PolyData frame per output step, when settings.vtk
///   series.pvd        the frames as a ParaView time series
///   checkpoint.qbc    the latest checkpoint (checkpoint.hpp)
///   run.json          the resolved scene, settings, version, status and timings
///   run.lock          held while the run writes (directory_lock.hpp): one run per directory
/// An exception that ends a run (an output that cannot be written) leaves run.json with status
/// "failed" and its message before it reaches the caller.
class Runner {
 public:
  /// Starts a fresh run: creates the output directory and locks it (DirectoryBusy when another
  /// run holds it), writes run.json, the CSV header and the step-0 row and frame. Frames of an
  /// earlier run in the same directory are removed, and temporaries left by killed runs.
  Runner(Scene scene, RunSettings settings);
  /// Continues from a checkpoint, in the checkpoint's directory. `adjust` may change the scene
  /// and settings before the run is rebuilt (later end, other output directory); outputs already
  /// written past the checkpoint's step are dropped so that the directory reads as if the run had
  /// never stopped. The checkpoint's metadata is checked like a scene (CheckpointError naming the
  /// file and the JSON path), and its scene must fit `max_memory` (0: default_memory_limit()).
  /// A checkpoint already at or past the run's end (nothing to run) is std::invalid_argument,
  /// thrown before anything is written.
  static Runner resume(const std::filesystem::path& checkpoint,
                       const std::function<void(Scene&, RunSettings&)>& adjust = {}, std::uint64_t max_memory = 0);
  /// What resume() would run, without touching the checkpoint's directory: the checkpoint's scene
  /// with its state in scene.world, and its run's settings, after `adjust` (the same checks and
  /// errors). Every rank of a run over ranks reads it (RanksRun).
  static std::pair<Scene, RunSettings> read_checkpoint(const std::filesystem::path& checkpoint,
                                                       const std::function<void(Scene&, RunSettings&)>& adjust = {},
                                                       std::uint64_t max_memory = 0);
  ~Runner();
  Runner(Runner&&) noexcept;
  Runner& operator=(Runner&&) = delete;

  /// Steps until settings.steps, a blow-up, or `stop()` returning true (checked after every
  /// step). Then writes the final row, frame, checkpoint and run.json. `progress` is called after
  /// every step.
  RunResult run(const std::function<bool()>& stop = {},
                const std::function<void(const RunProgress&)>& progress = {});

  const Scene& scene() const;
  const RunSettings& settings() const;
  Simulation& simulation();
  /// How each step is taken and what it reports, in place of simulation()'s own (a run over MPI
  /// ranks steps its pieces and gathers the state into simulation().world(), RanksRun).
  struct Stepper {
    std::function<StepReport()> step;  ///< advances simulation().world() by one step and reports it
    /// The step's bond events (events.csv), the bonds of simulation().world() already broken or formed.
    std::function<const std::vector<BondEvent>&()> events;
    std::function<SolveStats()> stats;  ///< the step's solve (the diagnostics' iterations, residual)
    /// E(t) − E(0) beyond the external work so far (events.csv's energy_gain row, run.json).
    std::function<const EnergyGain&()> energy_gain;
    /// The step just taken and the one proposed next [s] (the diagnostics' timestep column, and
    /// an adaptive run's checkpoints).
    std::function<std::pair<double, double>()> steps;
  };
  /// Replaces how each step is taken and what it reports; every member must be set.
  void set_stepper(Stepper stepper);

 private:
  struct Impl;
  explicit Runner(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace qbond
