// The `qbond` program: `run` a scene with its outputs, `statics` (its equilibrium), `validate` scene
// files, `export` (the built world for LAMMPS), `schema` (theirs), `key-tables` (the docs' tables of their keys), `experiment` (the paper's experiments), `bench` (the performance
// suite), `view` (the viewer).
// The work is done by the library (scene.hpp, runner.hpp); this file holds what only a program
// has: options, the progress display, signals and exit codes.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <thread>

#include "bench.hpp"
#include "contact_cost.hpp"
#include "huge_pages.hpp"
#include "realtime.hpp"
#include "experiment.hpp"
#include "qbond/analysis/analysis.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/io/checkpoint.hpp"
#include "qbond/io/lammps_data.hpp"
#include "qbond/io/memory.hpp"
#include "qbond/io/files.hpp"
#include "qbond/io/scene_docs.hpp"
#include "qbond/io/scene_schema.hpp"
#include "qbond/simulation/runner.hpp"
#include "qbond/distributed/distributed.hpp"
#include "qbond/simulation/statics_run.hpp"
#include "qbond/version.hpp"
#include "replay.hpp"
#include "viewer.hpp"

namespace {

// --help in the program's words: a plain placeholder for each option's value (N, NUMBER, TEXT,
// or the option's own, such as SIZE or DEGREES) where CLI11 prints its validators' names
// (INT:POSITIVE, INT:INT in [64 - 8192]), and what an option needs or excludes said in words.
class HelpFormatter : public CLI::Formatter {
 public:
  std::string make_option_opts(const CLI::Option* opt) const override {
    if (!opt->get_option_text().empty()) return " " + opt->get_option_text();
    std::string out;
    if (opt->get_type_size() != 0 && !opt->get_type_name().empty()) {
      out += " " + placeholder(opt->get_type_name());
      if (opt->get_expected_max() == CLI::detail::expected_max_vector_size) out += " ...";
      if (opt->get_required()) out += " (required)";
    }
    // Said once: where the description already names the other option, it says how.
    auto unsaid = [&](const CLI::Option* other) { return opt->get_description().find(other->get_name()) == std::string::npos; };
    for (const CLI::Option* other : opt->get_needs())
      if (unsaid(other)) out += " (with " + other->get_name() + ")";
    for (const CLI::Option* other : opt->get_excludes())
      if (unsaid(other)) out += " (not with " + other->get_name() + ")";
    return out;
  }

 private:
  static std::string placeholder(const std::string& type) {
    const std::string head = type.substr(0, type.find(':'));
    const std::string tail = type.find(':') == std::string::npos ? "" : type.substr(type.find(':') + 1);
    // A range check reads "INT:INT in [64 - 8192]": N (64 to 8192).
    if (const std::size_t a = type.find(" in ["), b = type.find(" - ", a), c = type.find(']', b);
        a != std::string::npos && b != std::string::npos && c != std::string::npos)
      return placeholder(type.substr(0, a)) + " (" + type.substr(a + 5, b - a - 5) + " to " + type.substr(b + 3, c - b - 3) + ")";
    if (head == "INT" || head == "UINT") return "N";
    if (head == "FLOAT") return "NUMBER";
    if (head == "TEXT") return tail.empty() || !std::all_of(tail.begin(), tail.end(), ::isupper) ? "TEXT" : tail;
    return type;  // the option's own name for its value (DEGREES, X,Y,Z)
  }
};
namespace fs = std::filesystem;

// Exit codes (README, "Running a scene").
constexpr int kExitFailure = 1;   // an output could not be written, or another runtime failure
constexpr int kExitBadInput = 2;  // bad scene, checkpoint or option; nothing was written
constexpr int kExitBlowup = 3;    // the simulation blew up; the last good state was written

// Lower bounds on a number with a short message ("--dt: must be > 0, got -1"): CLI11's
// PositiveNumber and NonNegativeNumber print their range up to the largest double, digit by digit.
CLI::Validator at_least_zero(bool strict) {
  return CLI::Validator(
      [strict](std::string& text) -> std::string {
        double value = 0;
        if (!CLI::detail::lexical_cast(text, value)) return "must be a number, got '" + text + "'";
        if (strict ? value > 0 : value >= 0) return {};
        return std::string(strict ? "must be > 0" : "must be >= 0") + ", got " + text;
      },
      strict ? "POSITIVE" : "NONNEGATIVE");
}
const CLI::Validator kPositive = at_least_zero(true), kNonNegative = at_least_zero(false);

// An output file whose directory does not exist is bad input, said before the work that would
// write it (a benchmark, a viewer run), not after.
void require_directory_of(const char* option, const std::string& path) {
  if (path.empty()) return;
  const fs::path dir = fs::absolute(path).parent_path();
  if (!fs::is_directory(dir))
    throw std::invalid_argument(std::string(option) + " " + path + ": no directory " + dir.string());
}

// The one piece of process-wide state a signal handler needs; the first SIGINT/SIGTERM asks the
// run to stop after the current step, a second one kills the process as usual.
volatile std::sig_atomic_t g_signal = 0;

extern "C" void on_signal(int sig) {
  g_signal = sig;
  std::signal(sig, SIG_DFL);
}

struct Options {
  std::string scene;
  std::string resume;
  long long steps = -1;
  double duration = -1;
  double timestep = -1;
  std::string out;
  long long every = -1;
  long long checkpoint_every = -1;
  bool no_vtk = false;
  bool no_ledger = false;
  bool frame_pieces = false;
  std::string integrator, neighbours, solver, preconditioner;
  int iterations = -1;
  int threads = -1;
  double tolerance = -1;
  bool list = false;
  bool quiet = false;
  std::uint64_t max_memory = 0;  ///< 0: default_memory_limit()
};

/// `--max-memory`'s value: a size such as 8G or 512MiB (memory.hpp's parse_bytes).
CLI::Validator memory_size() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        try {
          qbond::parse_bytes(text);
          return {};
        } catch (const std::invalid_argument& e) {
          return e.what();
        }
      },
      "SIZE");
}

/// `--integrator`'s help: every integrator of the table (integrators.hpp) with its line.
std::string integrator_help() {
  std::string help = "integrator override, one of:";
  for (const qbond::IntegratorInfo& i : qbond::integrator_table())
    help += "\n  " + std::string(i.key) + ": " + std::string(i.description);
  return help;
}

/// An integrator option's help: its line, the integrators that read it and, for `neighbours`,
/// `solver` and `preconditioner`, the values each takes.
std::string option_help(qbond::IntegratorOption option) {
  using namespace qbond;
  std::string help;
  for (const IntegratorOptionInfo& opt : integrator_options())
    if (opt.option == option) help = std::string(opt.description);
  auto join = [](auto list) {
    std::string out;
    for (auto v : list) out += (out.empty() ? "" : ", ") + std::string(to_string(v));
    return out;
  };
  // Integrators grouped by the values they take.
  std::vector<std::pair<std::string, std::string>> groups;  // (values, integrators)
  for (const IntegratorInfo& i : integrator_table()) {
    if (!i.reads(option)) continue;
    std::string values;
    if (option == IntegratorOption::solver) values = join(i.solvers);
    if (option == IntegratorOption::neighbours)
      for (const NamedValue<NeighbourModel>& m : neighbour_models())
        values += (values.empty() ? "" : ", ") + std::string(m.key);
    if (option == IntegratorOption::preconditioner)
      for (const NamedValue<Preconditioner>& p : preconditioners())
        values += (values.empty() ? "" : ", ") + std::string(p.key);
    auto g = std::find_if(groups.begin(), groups.end(), [&](const auto& p) { return p.first == values; });
    if (g == groups.end()) groups.emplace_back(values, std::string(i.key));
    else g->second += ", " + std::string(i.key);
  }
  for (const auto& [values, integrators] : groups)
    help += values.empty() ? " (" + integrators + ")" : "\n  " + values + " (" + integrators + ")";
  return help;
}

/// A scene from a file path, or a built-in scene by name (the default one when none is given).
/// The rule (docs/running.md): an argument with a '/' or ending in .json is a file; any other is
/// a built-in scene's name when there is one of that name (a file or folder of the same name is
/// then reached as ./NAME, which a note says), else a file.
qbond::Scene load_any(const std::string& arg, std::uint64_t max_memory = 0) {
  if (arg.empty()) return qbond::builtin_scene(qbond::kDefaultScene, max_memory);
  const bool path_like = arg.find('/') != std::string::npos || fs::path(arg).extension() == ".json";
  std::error_code ec;
  const bool exists = fs::exists(arg, ec);
  if (!path_like) {
    const auto builtins = qbond::builtin_scenes();
    if (std::any_of(builtins.begin(), builtins.end(),
                    [&](const qbond::BuiltinScene& s) { return s.name == arg; })) {
      if (exists)
        std::fprintf(stderr, "qbond: note: '%s' is the built-in scene; for the %s of that name, write ./%s\n",
                     arg.c_str(), fs::is_directory(arg, ec) ? "folder" : "file", arg.c_str());
      return qbond::builtin_scene(arg, max_memory);
    }
    if (!exists) return qbond::builtin_scene(arg, max_memory);  // its error lists the built-in scenes
  }
  return qbond::load_scene(arg, max_memory);
}

/// Whether `qbond view ARG` replays a finished run: ARG is a .pvd file or a run directory
/// holding series.pvd, named as a path (a '/' or the .pvd extension) or by a name no built-in
/// scene has (load_any's rule: a built-in name wins over a folder of that name).
bool names_replay(const std::string& arg) {
  if (arg.empty() || !qbond::view::is_replay(arg)) return false;
  if (arg.find('/') != std::string::npos || fs::path(arg).extension() == ".pvd") return true;
  const auto builtins = qbond::builtin_scenes();
  return std::none_of(builtins.begin(), builtins.end(), [&](const qbond::BuiltinScene& s) { return s.name == arg; });
}

/// "X,Y,Z" as a point, or std::invalid_argument naming `option`.
qbond::Vec3 parse_point(const char* option, const std::string& text) {
  qbond::Vec3 p;
  std::size_t at = 0;
  for (int k = 0; k < 3; ++k) {
    const std::size_t end = k < 2 ? text.find(',', at) : text.size();
    const std::string part = end == std::string::npos ? "" : text.substr(at, end - at);
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (part.empty() || used != part.size() || !std::isfinite(v))
      throw std::invalid_argument(std::string(option) + ": expected three numbers X,Y,Z [m], got \"" + text + "\"");
    p[k] = v;
    at = end + 1;
  }
  return p;
}

/// The steps of `length` at `timestep`, or std::invalid_argument naming `option`.
std::uint64_t steps_of(const char* option, double length, double timestep) {
  try {
    return qbond::steps_for_duration(length, timestep);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string(option) + ": " + e.what());
  }
}

/// An integrator option given on the command line that the run's integrator (or its solver)
/// does not read would change nothing: refused, naming the integrators that read it.
void refuse_unread_options(const Options& o, const qbond::IntegratorConfig& c) {
  using namespace qbond;
  const IntegratorInfo& info = integrator_info(c.type);
  const std::pair<bool, IntegratorOption> given[] = {
      {!o.neighbours.empty(), IntegratorOption::neighbours},
      {!o.solver.empty(), IntegratorOption::solver},
      {!o.preconditioner.empty(), IntegratorOption::preconditioner},
      {o.iterations > 0, IntegratorOption::iterations},
      {o.tolerance > 0, IntegratorOption::tolerance}};
  for (const auto& [set, option] : given) {
    if (!set) continue;
    const std::string name = "--" + std::string(to_string(option));
    if (!info.reads(option)) {
      std::string readers;
      for (const IntegratorInfo& i : integrator_table())
        if (i.reads(option)) readers += (readers.empty() ? "" : ", ") + std::string(i.key);
      throw std::invalid_argument(name + " does not apply to the integrator " + std::string(info.key) +
                                  " (it is read by " + readers + ")");
    }
    // The preconditioner is CG's, a coupled solve's tolerance too (the direct solvers are
    // exact), and the sweeps per Newton iteration are those of the solver sweep.
    const bool coupled = c.type == IntegratorType::coupled_implicit;
    const char* needs =
        option == IntegratorOption::preconditioner || (option == IntegratorOption::tolerance && coupled)
            ? "cg"
        : option == IntegratorOption::iterations && info.reads(IntegratorOption::solver) ? "sweep"
                                                                                         : nullptr;
    if (needs && to_string(c.solver) != needs)
      throw std::invalid_argument(name + " applies to " + std::string(info.key) + " with the solver " +
                                  needs + " only, not " + std::string(to_string(c.solver)));
  }
}

/// Applies the command line's overrides to a scene and its run settings, keeping the scene's
/// resolved JSON in step (it is what run.json and checkpoints record).
void apply(const Options& o, qbond::Scene& scene, qbond::RunSettings& rs) {
  using namespace qbond;
  nlohmann::json& j = scene.resolved;
  if (o.timestep > 0) {
    // A new step keeps the run's simulated length unless a length is given too.
    const double length = static_cast<double>(rs.steps) * scene.timestep;
    scene.timestep = o.timestep;
    if (o.steps < 0 && o.duration <= 0) rs.steps = length > 0 ? steps_of("--dt", length, o.timestep) : 0;
    j["timestep"] = o.timestep;
  }
  if (o.steps >= 0) {
    if (static_cast<std::uint64_t>(o.steps) > kMaxSteps)
      throw std::invalid_argument("--steps: must be <= 2^53, got " + std::to_string(o.steps));
    rs.steps = static_cast<std::uint64_t>(o.steps);
  }
  if (o.duration > 0) rs.steps = steps_of("--duration", o.duration, scene.timestep);
  scene.steps = rs.steps;
  j["steps"] = rs.steps;
  j.erase("duration");
  IntegratorConfig& c = scene.integrator;
  if (!o.integrator.empty()) c.type = parse_integrator_type(o.integrator);
  if (!o.neighbours.empty()) c.neighbours = parse_neighbour_model(o.neighbours);
  if (!o.solver.empty()) c.solver = parse_coupled_solver(o.solver);
  if (!o.preconditioner.empty()) c.preconditioner = parse_preconditioner(o.preconditioner);
  if (o.iterations > 0) c.iterations = o.iterations;
  if (o.tolerance > 0) c.tolerance = o.tolerance;
  refuse_unread_options(o, c);
  if (o.threads > max_threads())
    throw std::invalid_argument("--threads: must be <= " + std::to_string(max_threads()) + " (4 x this machine's " +
                                std::to_string(std::thread::hardware_concurrency()) +
                                " hardware threads, at least 64), got " + std::to_string(o.threads));
  if (o.threads >= 0) c.threads = o.threads;
  j["integrator"]["type"] = to_string(c.type);
  j["integrator"]["neighbours"] = to_string(c.neighbours);
  j["integrator"]["solver"] = to_string(c.solver);
  j["integrator"]["preconditioner"] = to_string(c.preconditioner);
  j["integrator"]["iterations"] = c.iterations;
  j["integrator"]["tolerance"] = c.tolerance;
  j["integrator"]["threads"] = c.threads;
  if (!o.out.empty()) rs.out_dir = o.out;
  if (o.every > 0) rs.every = static_cast<std::uint64_t>(o.every);
  if (o.checkpoint_every >= 0) rs.checkpoint_every = static_cast<std::uint64_t>(o.checkpoint_every);
  if (o.no_vtk) rs.vtk = false;
  if (o.no_ledger) rs.ledger = false;
  if (o.frame_pieces) rs.frame_pieces = true;
  j["output"]["dir"] = rs.out_dir.string();
  j["output"]["every"] = rs.every;
  j["output"]["checkpoint_every"] = rs.checkpoint_every;
  j["output"]["vtk"] = rs.vtk;
}

std::string clock(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const auto s = static_cast<long long>(seconds + 0.5);
  char buf[32];
  if (s >= 3600)
    std::snprintf(buf, sizeof buf, "%lld:%02lld:%02lld", s / 3600, s / 60 % 60, s % 60);
  else
    std::snprintf(buf, sizeof buf, "%lld:%02lld", s / 60, s % 60);
  return buf;
}

/// Progress on stderr: a bar redrawn in place on a terminal, plain lines every 10 % (or every
/// 30 s) otherwise, so that logs stay readable.
class Progress {
 public:
  explicit Progress(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO) == 1) {}
  void operator()(const qbond::RunProgress& p) {
    if (quiet_) return;
    const double done = static_cast<double>(p.step - p.first_step);
    const double frac = p.fraction;
    const bool last = frac >= 1.0;
    if (tty_) {
      if (!last && p.wall_seconds - shown_ < 0.1) return;
    } else if (!last && frac - shown_frac_ < 0.1 && p.wall_seconds - shown_ < 30) {
      return;
    }
    shown_ = p.wall_seconds;
    shown_frac_ = frac;
    const double rate = p.wall_seconds > 0 ? done / p.wall_seconds : 0;
    const double eta = frac > 0 ? p.wall_seconds * (1 - frac) / frac : -1;
    // An adaptive run's step count is not known in advance: no "of last_step" for it.
    const std::string of = p.adaptive ? "" : "/" + std::to_string(p.last_step);
    char line[160];
    std::snprintf(line, sizeof line, "%5.1f%%  step %llu%s  t = %.6g s  %.4g steps/s  ETA %s", 100 * frac,
                  static_cast<unsigned long long>(p.step), of.c_str(), p.time, rate, clock(eta).c_str());
    if (tty_) {
      constexpr int kWidth = 24;
      const int filled = static_cast<int>(frac * kWidth);
      std::fprintf(stderr, "\r[%s%s] %s\033[K", std::string(filled, '#').c_str(),
                   std::string(kWidth - filled, '-').c_str(), line);
      if (last) std::fputc('\n', stderr);
      open_line_ = !last;
    } else {
      std::fprintf(stderr, "%s\n", line);
    }
    std::fflush(stderr);
  }
  /// Ends a bar left mid-line (stop, blow-up) so that messages start on their own line.
  void finish() {
    if (open_line_) std::fputc('\n', stderr);
    open_line_ = false;
  }

 private:
  bool quiet_, tty_;
  bool open_line_ = false;
  double shown_ = -1e9, shown_frac_ = -1;
};

// A run over ranks: each rank's share of the quanta and of the ghost exchange, and where its time
// went per step.
void print_ranks(const qbond::RanksStats& s) {
  std::printf("over %d ranks: quanta moved between ranks after %llu steps; boxes cut anew %llu times", s.ranks,
              static_cast<unsigned long long>(s.migrations), static_cast<unsigned long long>(s.recuts));
  if (s.halved) std::printf("; steps taken again in halves %llu times", static_cast<unsigned long long>(s.halved));
  if (s.halo_rebuilds || s.retakes)
    std::printf("; contact halos built anew %llu times, steps taken again %llu times",
                static_cast<unsigned long long>(s.halo_rebuilds), static_cast<unsigned long long>(s.retakes));
  std::printf("\n");
  const double steps = s.steps ? static_cast<double>(s.steps) : 1.0;
  for (std::size_t k = 0; k < s.owned.size(); ++k)
    std::printf("  rank %zu: %zu quanta, %zu ghosts, %.0f bytes sent per step; per step %.3g ms stepping and %.3g ms "
                "ledger (CPU), %.3g ms in all (wall)\n",
                k, s.owned[k], s.ghosts[k], s.bytes_sent[k] / steps, 1e3 * s.stepping[k] / steps,
                1e3 * s.bookkeeping[k] / steps, 1e3 * s.wall[k] / steps);
}

int run(const Options& o) {
  using namespace qbond;
  if (o.list) {
    for (const BuiltinScene& s : builtin_scenes())
      std::printf("%-18s %s%s\n", std::string(s.name).c_str(), std::string(s.description).c_str(),
                  s.name == kDefaultScene ? " (default)" : "");
    return 0;
  }
  // Everything that can be wrong with the input is found before anything is written.
  std::optional<Runner> runner;
  std::optional<RanksRun> ranks;  // under mpirun with more than one rank (docs/distributed.md)
  const bool speak = mpi_rank() == 0, quiet = o.quiet || !speak;
  if (!o.resume.empty()) {
    if (!o.scene.empty()) throw std::invalid_argument("--resume continues a checkpoint's own scene; give no SCENE");
    const auto adjust = [&](Scene& s, RunSettings& rs) { apply(o, s, rs); };
    if (mpi_ranks() > 1)
      ranks.emplace(o.resume, adjust, o.max_memory);
    else
      runner.emplace(Runner::resume(o.resume, adjust, o.max_memory));
  } else {
    Scene scene = load_any(o.scene, o.max_memory);
    RunSettings rs = settings_of(scene);
    apply(o, scene, rs);
    if (mpi_ranks() > 1)
      ranks.emplace(std::move(scene), std::move(rs));
    else
      runner.emplace(std::move(scene), std::move(rs));
  }
  const Scene& scene = ranks ? ranks->scene() : runner->scene();
  const RunSettings& rs = ranks ? ranks->settings() : runner->settings();
  const World& w = ranks ? ranks->world() : runner->simulation().world();
  if (!quiet) {
    std::printf("%s %s: %zu quanta, %zu bonds, h = %g s, steps %llu -> %llu, integrator %s\n",
                o.resume.empty() ? "running" : "resuming", scene.name.c_str(), w.num_quanta(), w.num_bonds(),
                scene.timestep, static_cast<unsigned long long>(w.state.step),
                static_cast<unsigned long long>(rs.steps), std::string(to_string(scene.integrator.type)).c_str());
    std::printf("output: %s\n", rs.out_dir.c_str());
    std::fflush(stdout);
  }
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  Progress progress(quiet);
  const auto stop = [] { return g_signal != 0; };
  const RunResult r = ranks ? ranks->run(stop, std::ref(progress)) : runner->run(stop, std::ref(progress));
  progress.finish();
  if (!quiet && !rs.ledger) {
    std::printf("%llu steps in %.3g s (%.4g steps/s); t = %.6g s; energy %.6g J (no ledger)\n",
                static_cast<unsigned long long>(r.steps_taken), r.wall_seconds,
                r.wall_seconds > 0 ? r.steps_taken / r.wall_seconds : 0.0, w.state.time,
                energy_budget(w.model, w.state).now.total());
  } else if (!quiet) {
    const EnergyBudget b = energy_budget(w.model, w.state);
    std::printf("%llu steps in %.3g s (%.4g steps/s); t = %.6g s; energy %.6g J (damping %.3g J, numerical damping %.3g J, numerical %.3g J)\n",
                static_cast<unsigned long long>(r.steps_taken), r.wall_seconds,
                r.wall_seconds > 0 ? r.steps_taken / r.wall_seconds : 0.0, w.state.time, b.now.total(),
                b.dissipated_damping, b.numerical_damping, b.dissipated_numerical);
    if (ranks) print_ranks(ranks->stats());
    if (r.energy_gain.exceeded)
      std::fprintf(stderr,
                   "qbond: warning: the energy exceeded its initial value plus the external work by %.3g J "
                   "(%.3g of what the system could hold; limit %.3g) from step %llu (t = %.6g s): the integrator "
                   "made energy (events.csv, run.json; limits.stop_on_energy_gain ends such a run)\n",
                   r.energy_gain.largest, r.energy_gain.relative, scene.limits.energy_gain,
                   static_cast<unsigned long long>(r.energy_gain.first_step), r.energy_gain.first_time);
  }
  switch (r.status) {
    case RunStatus::completed: return 0;
    case RunStatus::stopped:
      if (speak)
        std::fprintf(stderr, "qbond: stopped by signal %d at step %llu; resume with: qbond run --resume %s\n",
                     static_cast<int>(g_signal), static_cast<unsigned long long>(w.state.step),
                     (rs.out_dir / "checkpoint.qbc").c_str());
      return 128 + static_cast<int>(g_signal);
    case RunStatus::blowup:
      if (speak)
        std::fprintf(stderr, "qbond: %s\nqbond: the last good state is in %s\n", r.message.c_str(),
                     (rs.out_dir / "checkpoint.qbc").c_str());
      return kExitBlowup;
  }
  return kExitFailure;
}

int validate(const std::vector<std::string>& scenes, std::uint64_t max_memory) {
  int bad = 0;
  for (const std::string& arg : scenes) {
    try {
      const qbond::Scene s = load_any(arg, max_memory);
      std::printf("%s: ok\n%s\n", arg.c_str(), qbond::scene_summary(s).c_str());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "qbond: %s\n", e.what());
      ++bad;
    }
  }
  return bad ? kExitBadInput : 0;
}

// `qbond statics`: the scene's static equilibrium and its outputs (statics_run.hpp).
struct StaticsArgs {
  std::string scene, out;
  double tolerance = 1e-8;
  int max_iterations = 50;
  bool no_vtk = false, quiet = false;
};

int statics(const StaticsArgs& a, std::uint64_t max_memory) {
  qbond::Scene scene = load_any(a.scene, max_memory);
  qbond::StaticsSettings ss;
  ss.out_dir = a.out.empty() ? fs::path(scene.output.dir) : fs::path(a.out);
  ss.tolerance = a.tolerance;
  ss.max_iterations = a.max_iterations;
  ss.vtk = !a.no_vtk;
  if (!a.quiet)
    std::printf("statics %s: %zu quanta, %zu bonds\noutput: %s\n", scene.name.c_str(),
                scene.world.num_quanta(), scene.world.num_bonds(), fs::absolute(ss.out_dir).c_str());
  const qbond::StaticsReport r = qbond::run_statics(scene, ss);
  if (!a.quiet)
    std::printf(
        "%s after %d Newton iterations, residual %.3g; largest displacement %.6g m; load [%.6g, %.6g, %.6g] "
        "N, "
        "reaction [%.6g, %.6g, %.6g] N\n",
        r.result.converged ? "equilibrium" : "no equilibrium", r.result.iterations, r.result.residual,
        r.max_displacement, r.load.x(), r.load.y(), r.load.z(), r.reaction.x(), r.reaction.y(),
        r.reaction.z());
  if (r.result.converged) return 0;
  std::fprintf(
      stderr,
      "qbond: no equilibrium within %d iterations (residual %.3g above %.3g): the loads may push a free "
      "body or a mechanism; the outputs hold the state of the smallest residual\n",
      ss.max_iterations, r.result.residual, ss.tolerance);
  return kExitBlowup;
}

// `qbond export`: the world a scene builds, before its first step, as another program's input.
struct ExportArgs {
  std::string scene, lammps;
  bool quiet = false;
};

int export_scene(const ExportArgs& a, std::uint64_t max_memory) {
  const qbond::Scene scene = load_any(a.scene, max_memory);
  std::ofstream out(a.lammps);
  if (!out) throw std::runtime_error("--lammps: cannot write " + a.lammps);
  qbond::write_lammps_data(out, scene.world, scene.name);
  out.close();
  if (!out) throw std::runtime_error("--lammps: writing " + a.lammps + " failed");
  if (!a.quiet)
    std::printf("wrote %s: %zu atoms, %d bond(s) of %d bond type(s) (LAMMPS data, units si, atom_style bond)\n",
                a.lammps.c_str(), scene.world.num_quanta(),
                static_cast<int>(qbond::lammps_bond_types(scene.world).first.size()),
                qbond::lammps_bond_types(scene.world).second);
  return 0;
}

// `qbond key-tables`: rewrites the tables between `<!-- keys:NAME -->` markers from the
// declarations (scene_docs.hpp); with `check`, writes nothing and exits 1 when one differs.
int key_tables(const std::vector<std::string>& files, bool check) {
  int stale = 0;
  std::string all;
  for (const std::string& f : files) all += " " + f;
  for (const std::string& f : files) {
    const std::string text = qbond::read_file(f);
    const std::string written = qbond::with_scene_doc_tables(text, f);
    if (text.find("<!-- keys:") == std::string::npos)
      throw std::invalid_argument(f + ": no <!-- keys:NAME --> table (tables: " + [] {
        std::string n;
        for (std::string_view s : qbond::scene_doc_table_names()) n += (n.empty() ? "" : ", ") + std::string(s);
        return n;
      }() + ")");
    if (written == text) continue;
    ++stale;
    if (check) {
      std::fprintf(stderr, "qbond: %s: its key tables differ from the declarations; regenerate: qbond key-tables%s\n",
                   f.c_str(), all.c_str());
      continue;
    }
    std::ofstream out(f, std::ios::binary | std::ios::trunc);
    out << written;
    out.close();
    if (!out) throw std::runtime_error("cannot write " + f);
    std::printf("wrote %s\n", f.c_str());
  }
  return check && stale ? kExitFailure : 0;
}

// `qbond experiment`: runs the paper's experiments (experiments/), writes their CSVs,
// summaries and results.json, draws their plots with plot.py; exit 1 when a claim fails.
struct ExperimentArgs {
  std::vector<std::string> names;
  bool fast = false, list = false, plots = true, update_results = false;
  std::string out = "experiment_results";
};

int experiment(const ExperimentArgs& a) {
  namespace ex = qbond::experiments;
  if (a.list) {
    for (const ex::Experiment& e : ex::all()) std::printf("%-15s %s\n", e.name, e.title);
    return 0;
  }
  // plot.py and fig11_getfem.py are found beside the program (its share/qbond), so that it runs
  // wherever it is built or installed.
  const std::filesystem::path scripts = ex::find_scripts(std::filesystem::read_symlink("/proc/self/exe"));
  const int failed = ex::run_experiments(ex::all(), a.names, {a.fast, a.plots, a.update_results, a.out, QBOND_PYTHON, scripts});
  return failed ? kExitFailure : 0;
}

}  // namespace

int main(int argc, char** argv) {
  qbond::cli::use_huge_pages(argc, argv);  // first: it may start the program again
  const qbond::MpiSession mpi(argc, argv);  // when mpirun or srun started this program as a rank
  CLI::App app{"qbond: the quanta-bond method. Deformable, breakable solids, stepped implicitly."};
  app.formatter(std::make_shared<HelpFormatter>());  // before the subcommands, which copy it
  app.set_version_flag("--version", std::string("qbond ") + QBOND_VERSION);
  app.require_subcommand(1);
  Options o;
  CLI::App* run_cmd = app.add_subcommand("run", "run a scene file or a built-in scene (default: the pendulum)");
  run_cmd->add_option("scene", o.scene, "scene file (.json) or built-in scene name (see --list)");
  run_cmd->add_flag("--list", o.list, "list the built-in scenes");
  run_cmd->add_option("--resume", o.resume, "continue from a checkpoint (e.g. out/checkpoint.qbc)");
  auto* steps = run_cmd->add_option("--steps", o.steps, "run until this step count (default: the scene's)")
                    ->check(kNonNegative);
  run_cmd->add_option("--duration", o.duration, "run until this simulated time [s]")
      ->check(kPositive)
      ->excludes(steps);
  run_cmd->add_option("--dt", o.timestep, "timestep [s] (default: the scene's)")->check(kPositive);
  run_cmd->add_option("-o,--out", o.out, "output directory (default: the scene's output.dir)");
  run_cmd->add_option("--every", o.every, "steps between output rows and frames")->check(kPositive);
  run_cmd
      ->add_option("--checkpoint-every", o.checkpoint_every, "steps between checkpoints (0: at the end only)")
      ->check(kNonNegative);
  run_cmd->add_flag("--no-vtk", o.no_vtk, "write no ParaView frames");
  run_cmd->add_flag(
      "--no-ledger", o.no_ledger,
      "charge no energy ledger: a pass over the bonds less a step; the ledger's columns are nan and "
      "no energy gain is checked (not over MPI ranks)");
  run_cmd->add_flag("--frame-pieces", o.frame_pieces,
                    "over MPI ranks, write each frame as a .pvtp with one .vtp piece per rank");
  run_cmd->add_option("--integrator", o.integrator, integrator_help());
  run_cmd->add_option("--neighbours", o.neighbours, option_help(qbond::IntegratorOption::neighbours));
  run_cmd->add_option("--solver", o.solver, option_help(qbond::IntegratorOption::solver));
  run_cmd->add_option("--preconditioner", o.preconditioner, option_help(qbond::IntegratorOption::preconditioner));
  run_cmd->add_option("--iterations", o.iterations, option_help(qbond::IntegratorOption::iterations))
      ->check(kPositive);
  run_cmd->add_option("--tolerance", o.tolerance, option_help(qbond::IntegratorOption::tolerance))
      ->check(kPositive);
  run_cmd
      ->add_option("-j,--threads", o.threads,
                   "threads (0: all cores; default: the scene's integrator.threads); the results are the "
                   "same bits for any count")
      ->check(kNonNegative);
  run_cmd->add_flag("-q,--quiet", o.quiet, "print nothing but errors");
  std::string max_memory;
  const std::string memory_help = "refuse a scene whose run is estimated to need more memory than this, e.g. 8G or "
                                  "512MiB (default: 3/4 of this machine's memory, " +
                                  qbond::format_bytes(static_cast<double>(qbond::default_memory_limit())) + ")";
  run_cmd->add_option("--max-memory", max_memory, memory_help)->check(memory_size());

  std::vector<std::string> to_validate;
  CLI::App* validate_cmd = app.add_subcommand("validate", "check scene files and print their summaries");
  validate_cmd->add_option("scenes", to_validate, "scene files or built-in scene names")->required();
  validate_cmd->add_option("--max-memory", max_memory, memory_help)->check(memory_size());
  StaticsArgs sa;
  CLI::App* statics_cmd = app.add_subcommand(
      "statics",
      "solve a scene's static equilibrium: displacements, reactions and stresses (docs/running.md)");
  statics_cmd->add_option("scene", sa.scene, "scene file (.json) or built-in scene name");
  statics_cmd->add_option("-o,--out", sa.out, "output directory (default: the scene's output.dir)");
  statics_cmd
      ->add_option("--tolerance", sa.tolerance,
                   "relative residual of the net force at which Newton stops "
                   "(default: 1e-8)")
      ->check(kPositive);
  statics_cmd->add_option("--max-iterations", sa.max_iterations, "Newton iterations at most (default: 50)")
      ->check(kPositive);
  statics_cmd->add_flag("--no-vtk", sa.no_vtk, "write no ParaView frame");
  statics_cmd->add_flag("-q,--quiet", sa.quiet, "print nothing but errors");
  statics_cmd->add_option("--max-memory", max_memory, memory_help)->check(memory_size());
  ExportArgs xa;
  CLI::App* export_cmd = app.add_subcommand(
      "export", "write the world a scene builds (before its first step) for another program (docs/running.md)");
  export_cmd->add_option("scene", xa.scene, "scene file (.json) or built-in scene name")->required();
  export_cmd
      ->add_option("--lammps", xa.lammps,
                   "write a LAMMPS data file (units si, atom_style bond: atoms, masses, velocities, bonds)")
      ->required();
  export_cmd->add_flag("-q,--quiet", xa.quiet, "print nothing but errors");
  export_cmd->add_option("--max-memory", max_memory, memory_help)->check(memory_size());
  CLI::App* schema_cmd = app.add_subcommand("schema",
                                            "print the JSON Schema of scene files, for editors "
                                            "(docs/scene-format.md)");
  std::vector<std::string> key_table_files;
  bool key_tables_check = false;
  CLI::App* key_tables_cmd = app.add_subcommand(
      "key-tables", "write the docs' key tables (each between its keys:NAME markers) from the declarations of the "
                    "laws, heuristics and body types (docs/architecture.md)");
  key_tables_cmd->add_option("files", key_table_files, "Markdown files, rewritten in place")->required();
  key_tables_cmd->add_flag("--check", key_tables_check, "write nothing; exit 1 when a file's tables differ");
  ExperimentArgs ea;
  CLI::App* experiment_cmd = app.add_subcommand("experiment", "reproduce the paper's experiments (docs/experiments.md)");
  experiment_cmd->add_option("names", ea.names, "experiments to run, or 'all'");
  experiment_cmd->add_flag("--list", ea.list, "list the experiments");
  experiment_cmd->add_flag("--fast", ea.fast, "smaller sizes and fewer steps (what CI runs)");
  experiment_cmd->add_option("-o,--out", ea.out, "results directory (default: ./experiment_results)");
  experiment_cmd->add_flag("--update-results", ea.update_results,
                           "allow -o to be the source tree's committed experiments/results");
  // Flags that turn something off by a callback: a negated flag's help would show CLI11's
  // "{false}".
  experiment_cmd->add_flag_callback(
      "--no-plots", [&ea] { ea.plots = false; }, "write the CSVs and summaries only");
  qbond::cli::BenchArgs ba;
  CLI::App* bench_cmd = app.add_subcommand("bench", "measure the canonical workload against the memory-bandwidth bound "
                                                    "(docs/performance.md)");
  bench_cmd->add_flag("--quick", ba.quick, "n = 10, one short repetition (what CI runs)");
  bench_cmd->add_option("-n,--sizes", ba.sizes, "lattice sizes n, comma-separated (default: 10,20,40)");
  bench_cmd->add_option("-j,--threads", ba.threads, "thread counts, comma-separated (default: 1)");
  bench_cmd->add_option("--integrators", ba.integrators,
                        "comma-separated integrator rows (default: hybrid_frozen, hybrid_sweep, velocity_verlet, default; "
                        "an unknown name lists every row)");
  bench_cmd->add_flag("--solve", ba.solve,
                      "compare solvers instead: one backward-Euler step at h = 1/60 s to a relative residual of 1e-6, "
                      "qbond's CG (block Jacobi, multigrid) against Eigen's CG and sparse Cholesky and, when built "
                      "with PETSc, PETSc's CG with GAMG and with BoomerAMG");
  bench_cmd->add_flag("--as-run", ba.as_run,
                      "time each step as `qbond run` takes it: energy ledger (blow-up check, diagnostics) and the "
                      "copy kept for a rollback (rows named INTEGRATOR+run)");
  bench_cmd->add_option("--dt", ba.dt, "timestep [s] (default: the workload's 1e-4)")->check(kPositive);
  bench_cmd->add_option("--repetitions", ba.repetitions, "repetitions; the median is reported (default: 3)")
      ->check(kPositive);
  bench_cmd->add_option("--json", ba.json, "also write the table as JSON to this file");
  bool realtime = false;
  qbond::cli::RealtimeArgs ra;
  bench_cmd->add_flag("--realtime", realtime,
                      "the wall time of a 1/60 s frame instead, for the canonical lattice (default integrator, one step "
                      "a frame, settling then pulled; at the default tolerance and at 1e-4) and every built-in scene "
                      "(its own settings), on 1 and 2 threads unless -j says");
  bench_cmd->add_option("--scenes", ra.scenes, "with --realtime or --contact: built-in scenes, comma-separated (default: every one; --contact: the contact scenes)");
  bench_cmd->add_option("--preconditioner", ra.preconditioner,
                        "with --realtime: the canonical lattice's CG preconditioner (block_jacobi, multigrid, automatic; "
                        "default: the default integrator's)");
  bench_cmd->add_option("--budget", ra.budget, "with --realtime: wall seconds measured per row at most (default: 8)")
      ->check(kPositive);
  bool contact_cost = false;
  qbond::cli::ContactCostArgs ca;
  bench_cmd->add_flag("--contact", contact_cost,
                      "what contact costs a step instead: each scene's step (one thread) with its obstacles and quanta "
                      "contact inside the implicit step, by projection and without contact, in interleaved rounds");
  bench_cmd->add_option("--rounds", ca.rounds, "with --contact: interleaved rounds (default: 5)")->check(kPositive);
  std::string view_scene;
  qbond::view::ViewOptions vo;
  CLI::App* view_cmd = app.add_subcommand("view", "the real-time viewer: watch a scene and pull on it with the mouse "
                                                  "(default scene: the pendulum; docs/viewer.md)");
  view_cmd->add_option("scene", view_scene,
                       "scene file (.json) or built-in scene name; or a finished run to replay: its directory or series.pvd");
  std::string camera_position, camera_target;
  view_cmd->add_option("--camera-position", camera_position, "the camera's eye X,Y,Z [m] (with --camera-target)")
      ->option_text("X,Y,Z");
  view_cmd->add_option("--camera-target", camera_target, "the point the camera looks at X,Y,Z [m] (with --camera-position)")
      ->option_text("X,Y,Z");
  double camera_fov = 0;
  auto* fov_opt = view_cmd->add_option("--camera-fov", camera_fov, "the camera's vertical field of view [degrees] (default 45.8)")
                      ->option_text("DEGREES");
  view_cmd->add_option("--time", vo.replay_time, "replay: start at the last frame at or before this time [s]")
      ->option_text("SECONDS");
  auto* frames =
      view_cmd->add_option("--frames", vo.frames, "run this many frames without user input, then exit")
          ->check(kPositive);
  view_cmd->add_option("--screenshot", vo.screenshot, "write the last frame as a PNG (with --frames)")->needs(frames);
  view_cmd->add_option("--record", vo.record, "write every frame as DIR/frame_NNNNN.png");
  view_cmd->add_option("--script", vo.script, "scripted mouse and key input (JSON; docs/viewer.md)");
  view_cmd->add_option("--stats", vo.stats, "write the measured frame and step times as JSON at the end");
  view_cmd->add_option("--save", vo.save, "write the final state as a VTK PolyData file (.vtp)");
  view_cmd
      ->add_option("--steps-per-frame", vo.steps_per_frame,
                   "with --frames: steps per frame (default: 1/60 s of simulated time)")
      ->check(kPositive)
      ->needs(frames);
  view_cmd->add_option("--size", vo.width, "window width in pixels (height: 9/16 of it)")->check(CLI::Range(64, 8192));
  view_cmd->add_flag_callback(
      "--no-ui", [&vo] { vo.ui = false; }, "hide the control panel");
  view_cmd->add_flag("--follow", vo.follow, "keep the camera aimed at the structure as it moves");
  view_cmd->add_option("--bonds", vo.bonds, "bond colours: strain, tension or plain")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, qbond::view::BondColor>{{"strain", qbond::view::BondColor::strain},
                                                        {"tension", qbond::view::BondColor::tension},
                                                        {"plain", qbond::view::BondColor::none}}))
      ->option_text("strain|tension|plain");
  view_cmd->add_option("--quanta", vo.quanta, "quanta colours: body, von_mises or speed")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, qbond::view::QuantaColor>{{"body", qbond::view::QuantaColor::body},
                                                          {"von_mises", qbond::view::QuantaColor::von_mises},
                                                          {"speed", qbond::view::QuantaColor::speed}}))
      ->option_text("body|von_mises|speed");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help, version or the error
    return code == 0 ? 0 : kExitBadInput;
  }
  try {
    if (!max_memory.empty()) o.max_memory = qbond::parse_bytes(max_memory);
    if (run_cmd->parsed()) return run(o);
    if (validate_cmd->parsed()) return validate(to_validate, o.max_memory);
    if (statics_cmd->parsed()) return statics(sa, o.max_memory);
    if (export_cmd->parsed()) {
      require_directory_of("--lammps", xa.lammps);
      return export_scene(xa, o.max_memory);
    }
    if (schema_cmd->parsed()) {
      std::printf("%s\n", qbond::scene_schema().dump(2).c_str());
      return 0;
    }
    if (key_tables_cmd->parsed()) return key_tables(key_table_files, key_tables_check);
    if (bench_cmd->parsed()) {
      require_directory_of("--json", ba.json);
      if (realtime && contact_cost)
        throw std::invalid_argument("qbond bench: --realtime and --contact are two benchmarks: give one of them");
      if (realtime) {
        if (!ba.sizes.empty()) ra.sizes = ba.sizes;
        if (bench_cmd->count("--threads") > 0) ra.threads = ba.threads;
        ra.json = ba.json;
        for (int k = 0; k < argc; ++k) ra.command += (k ? " " : "") + std::string(k ? argv[k] : "build/qbond");
        return qbond::cli::bench_realtime(ra);
      }
      if (contact_cost) {
        if (bench_cmd->count("--scenes") > 0) ca.scenes = ra.scenes;
        ca.dt = ba.dt;
        ca.json = ba.json;
        for (int k = 0; k < argc; ++k) ca.command += (k ? " " : "") + std::string(k ? argv[k] : "build/qbond");
        return qbond::cli::bench_contact(ca);
      }
      return qbond::cli::bench(ba);
    }
    if (view_cmd->parsed()) {
      require_directory_of("--screenshot", vo.screenshot);
      require_directory_of("--stats", vo.stats);
      require_directory_of("--save", vo.save);
      vo.height = vo.width * 9 / 16;
      if (!camera_position.empty()) vo.camera.position = parse_point("--camera-position", camera_position);
      if (!camera_target.empty()) vo.camera.target = parse_point("--camera-target", camera_target);
      if (fov_opt->count() > 0) vo.camera.fov = camera_fov;
      if (names_replay(view_scene)) {
        vo.replay = view_scene;
        return qbond::view::run_viewer(qbond::Scene{}, vo);
      }
      return qbond::view::run_viewer(load_any(view_scene), vo);
    }
    if (experiment_cmd->parsed()) {
      if (ea.names.empty() && !ea.list) throw std::invalid_argument("name an experiment (or 'all'; see --list)");
      return experiment(ea);
    }
  } catch (const qbond::SceneError& e) {
    std::fprintf(stderr, "qbond: %s\n", e.what());
    return kExitBadInput;
  } catch (const qbond::CheckpointError& e) {
    std::fprintf(stderr, "qbond: %s\n", e.what());
    return kExitBadInput;
  } catch (const qbond::VtkReadError& e) {
    std::fprintf(stderr, "qbond: %s\n", e.what());
    return kExitBadInput;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "qbond: %s\n", e.what());
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "qbond: %s\n", e.what());
    return kExitFailure;
  }
  return 0;
}
