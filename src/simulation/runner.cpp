#include "qbond/simulation/runner.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "qbond/version.hpp"
#include "qbond/io/checkpoint.hpp"
#include "qbond/io/directory_lock.hpp"
#include "qbond/io/json_text.hpp"
#include "qbond/io/memory.hpp"
#include "qbond/io/diagnostics.hpp"
#include "qbond/io/files.hpp"
#include "qbond/io/probes.hpp"
#include "qbond/io/vtk.hpp"

#include "io/scene/json_reader.hpp"

namespace qbond {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// The run's output directory and its frames/, or an error that names them.
void make_output_dirs(const fs::path& out_dir) {
  std::error_code ec;
  fs::create_directories(out_dir / "frames", ec);
  if (ec)
    throw std::runtime_error("cannot create the output directory " + (out_dir / "frames").string() + ": " +
                             ec.message());
}

constexpr const char* kCsv = "diagnostics.csv";
constexpr const char* kPvd = "series.pvd";
constexpr const char* kCheckpoint = "checkpoint.qbc";
constexpr const char* kRunJson = "run.json";
constexpr const char* kEvents = "events.csv";
constexpr const char* kEventsHeader = "step,time,event,reason,bond,i,j,strain,tension";

// The events.csv row of a run whose energy first exceeded its initial value plus the external
// work by more than limits.energy_gain: the step, the time and the gain relative to what the
// system could hold (in the strain column); no bond.
std::string gain_row(const EnergyGain& g) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%llu,%.17g,energy_gain,exceeds_initial_plus_work,,,,%.17g,",
                static_cast<unsigned long long>(g.first_step), g.first_time, g.relative);
  return buf;
}

// One row of events.csv; bond and quanta named by their user ids (Bonds::id, Model::quanta_id).
std::string event_row(const BondEvent& e, const World& w) {
  const Model& m = w.model;
  char buf[256];
  std::snprintf(buf, sizeof buf, "%llu,%.17g,%s,%s,%llu,%llu,%llu,%.17g,%.17g", static_cast<unsigned long long>(e.step),
                e.time, std::string(to_string(e.kind)).c_str(), std::string(to_string(e.reason)).c_str(),
                static_cast<unsigned long long>(w.state.bonds.id[e.bond]),
                static_cast<unsigned long long>(m.quanta_id[e.i]),
                static_cast<unsigned long long>(m.quanta_id[e.j]), e.strain, e.tension);
  return buf;
}

// Keeps the lines of a CSV file (after its header) for which keep(line) holds; returns them.
std::vector<std::string> kept_lines(const std::string& text, const std::string& header,
                                    const std::function<bool(const std::string&)>& keep) {
  std::vector<std::string> kept;
  std::istringstream lines(text);
  std::string line;
  if (!std::getline(lines, line) || line != header) return kept;
  while (std::getline(lines, line)) {
    if (line.empty() || lines.eof()) break;  // a partial last line has no newline
    if (keep(line)) kept.push_back(line);
  }
  return kept;
}

std::uint64_t leading_step(const std::string& line) { return std::stoull(line.substr(0, line.find(','))); }

// The frame of a step: its whole-world .vtp, or its .pvtp when the ranks write pieces.
std::string frame_name(std::uint64_t step, bool pieces = false) { return frame_file(step, pieces ? "pvtp" : "vtp"); }

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// What reads the energy ledger every step cannot run without it.
void refuse_without_ledger(const Scene& scene) {
  const char* why = scene.adaptive.enabled             ? "the adaptive step is judged by the energy ledger"
                    : scene.limits.stop_on_energy_gain ? "limits.stop_on_energy_gain reads the energy ledger"
                    : scene.integrator.restore_energy  ? "integrator.restore_energy charges the energy ledger"
                                                       : nullptr;
  if (why) throw std::invalid_argument(std::string("--no-ledger: ") + why);
}

json to_json(const RunSettings& s) {
  return {{"out_dir", s.out_dir.string()},
          {"steps", s.steps},
          {"every", s.every},
          {"checkpoint_every", s.checkpoint_every},
          {"vtk", s.vtk},
          {"ledger", s.ledger}};
}

// A checkpoint's run settings, checked like a scene's (scene_detail's readers, which throw Bad
// with the JSON path). The directory the run wrote is not taken from the file: a resume writes
// beside its checkpoint, or where the command line says.
RunSettings settings_from_json(const json& j) {
  using namespace scene_detail;
  Obj o(j, "run", {"out_dir", "steps", "every", "checkpoint_every", "vtk", "ledger"});
  RunSettings s;
  string(o.required("out_dir"), o.at("out_dir"));
  s.steps = integer(o.required("steps"), o.at("steps"), 0);
  if (s.steps > kMaxSteps) bad(o.at("steps"), "must be <= 2^53, got " + std::to_string(s.steps));
  s.every = integer(o.required("every"), o.at("every"), 1);
  s.checkpoint_every = integer(o.required("checkpoint_every"), o.at("checkpoint_every"), 0);
  s.vtk = boolean(o.required("vtk"), o.at("vtk"));
  if (o.has("ledger")) s.ledger = boolean(o["ledger"], o.at("ledger"));  // older checkpoints: on
  return s;
}

std::vector<Probe> probes_of(const Scene& scene) {
  std::vector<Probe> probes;
  for (const ProbeSpec& p : scene.output.probes) probes.push_back({p.name, p.quanta, p.about});
  return probes;
}

std::vector<Obstacle> obstacles_of(const Scene& scene) {
  std::vector<Obstacle> obstacles;
  for (const HeuristicSpec& h : scene.heuristics)
    if (const auto* o = std::get_if<Obstacle>(&h)) obstacles.push_back(*o);
  return obstacles;
}

// Writes run.json when write_file_atomic cannot (a full disk has no room for a second copy):
// in place, over the old one's blocks.
void write_in_place(const fs::path& path, const std::string& text) {
  LineFile f(path, /*truncate=*/true);
  f.write_line(text);
}

const char* to_string(RunStatus s) {
  switch (s) {
    case RunStatus::completed: return "completed";
    case RunStatus::stopped: return "stopped";
    case RunStatus::blowup: return "blowup";
  }
  return "?";
}

/// A resume whose end is at or before the checkpoint's state would run nothing and exit as if it
/// had completed: refused (before anything is written), saying where the checkpoint is.
void refuse_nothing_to_run(const std::string& checkpoint, const Scene& scene, const RunSettings& settings) {
  const State& s = scene.world.state;
  const std::string at = "step " + std::to_string(s.step) + ", t = " + scene_detail::num_str(s.time) + " s";
  if (scene.adaptive.enabled) {
    const double end = static_cast<double>(settings.steps) * scene.timestep;
    if (s.time < end) return;
    throw std::invalid_argument(checkpoint + ": the checkpoint is at " + at + ", " +
                                (s.time > end ? "past" : "already at") +
                                " the run's end at t = " + scene_detail::num_str(end) +
                                " s: nothing to run (the length is the total, not the time to add; ask for a "
                                "--duration beyond " +
                                scene_detail::num_str(s.time) + " s to continue)");
  }
  if (s.step < settings.steps) return;
  throw std::invalid_argument(checkpoint + ": the checkpoint is at " + at + ", " +
                              (s.step > settings.steps ? "past" : "already at") + " the run's end at step " +
                              std::to_string(settings.steps) +
                              ": nothing to run (the step count is the total, not the steps to add; ask for "
                              "--steps above " +
                              std::to_string(s.step) + " to continue)");
}

}  // namespace

RunSettings settings_of(const Scene& scene) {
  RunSettings s;
  s.out_dir = scene.output.dir;
  s.steps = scene.steps;
  s.every = std::max<std::uint64_t>(1, scene.output.every);
  s.checkpoint_every = scene.output.checkpoint_every;
  s.vtk = scene.output.vtk;
  return s;
}

struct Runner::Impl {
  Scene scene;
  RunSettings settings;
  Simulation sim;
  Diagnostics diagnostics;
  std::unique_ptr<LineFile> csv;
  std::unique_ptr<LineFile> events;
  PvdSeries series;
  std::size_t series_written = 0;  ///< frames series.pvd lists
  std::uint64_t last_row = ~0ull;  ///< step of the last diagnostics row written
  std::string started_at = utc_now();
  std::string resumed_from;
  std::uint64_t first_step = 0;
  double last_h = 0;  ///< the step that led to the current state [s]
  std::optional<DirectoryLock> lock;  ///< held from before the first write to the directory

  Impl(Scene s, RunSettings rs)
      : scene(std::move(s)),
        settings(std::move(rs)),
        sim(std::move(scene.world), scene.integrator, scene.timestep),  // the simulation owns the world
        diagnostics(sim.world().model, probes_of(scene), obstacles_of(scene)) {
    if (settings.every == 0) throw std::invalid_argument("output interval must be >= 1 step");
    if (!settings.ledger) refuse_without_ledger(scene);
    settings.out_dir = fs::absolute(settings.out_dir);
    sim.limits() = scene.limits;
    sim.set_keep_last_good(true);
    sim.set_track_energy(settings.ledger);
    diagnostics.set_ledger(settings.ledger);
    for (const HeuristicSpec& h : scene.heuristics) sim.add_heuristic(make_heuristic(h));
    first_step = sim.world().state.step;
    last_h = scene.timestep;
  }

  /// Adaptive runs end at the scene's horizon (steps × timestep), fixed ones after `steps` steps.
  bool finished() const {
    const State& s = sim.world().state;
    return scene.adaptive.enabled ? s.time >= end_time() : s.step >= settings.steps;
  }
  double end_time() const { return static_cast<double>(settings.steps) * scene.timestep; }
  const EnergyGain& energy_gain() const { return stepper ? stepper->energy_gain() : sim.energy_gain(); }

  std::optional<Stepper> stepper;  ///< set_stepper's, else the simulation's own

  StepReport step() {
    if (stepper) {
      StepReport r = stepper->step();
      last_h = stepper->steps().first;
      return r;
    }
    if (!scene.adaptive.enabled) return sim.step();
    const AdaptiveReport a = adaptive_step(sim, scene.adaptive, end_time());
    last_h = a.h;
    return a.step;
  }

  fs::path out(const std::string& name) const { return settings.out_dir / name; }

  std::string metadata() const {
    json j = {{"format", "qbond-run"}, {"qbond_version", QBOND_VERSION}, {"scene", scene.resolved},
              {"run", to_json(settings)}};
    // The adaptive controller's state: the step it proposes next, and the one it took last (the
    // diagnostics' timestep column). Doubles print and parse back to the same bits.
    if (scene.adaptive.enabled)
      j["adaptive"] = {{"next_step", stepper ? stepper->steps().second : sim.timestep()}, {"last_step", last_h}};
    if (settings.ranks_layout) j["ranks"] = json::parse(settings.ranks_layout());
    return j.dump();
  }

  // Makes the output directory, takes its lock, and clears what killed runs left there.
  void claim_output_dir() {
    make_output_dirs(settings.out_dir);
    lock.emplace(settings.out_dir);
    remove_stale_temporaries(settings.out_dir);
    remove_stale_temporaries(settings.out_dir / "frames");
  }

  // run.json once an error ends the run: status "failed" and the reason. Best effort: the error
  // being reported may be the disk's, so it falls back to writing in place, then gives up.
  void write_failed(const std::string& why) const noexcept {
    RunResult r;
    r.message = why;
    try {
      write_run_json("failed", &r);
    } catch (const std::exception&) {
      try {
        write_run_json("failed", &r, /*in_place=*/true);
      } catch (const std::exception&) {
      }
    }
  }

  // One diagnostics row and, with VTK on, one frame of the current state.
  void output() {
    const World& w = sim.world();
    const std::uint64_t step = w.state.step;
    if (step == last_row) return;
    csv->write_line(diagnostics.row(w.model, w.state, stepper ? stepper->stats() : sim.integrator().stats(), last_h));
    last_row = step;
    if (!settings.vtk) return;
    const std::string name = frame_name(step, static_cast<bool>(settings.write_frame));
    if (settings.write_frame)
      settings.write_frame(out(name));
    else
      write_vtp(out(name), w.model, w.state);
    series.add(w.state.time, name);
    // Rewritten whole, so only once it has grown by a sixteenth: rewritten every frame, its bytes
    // would grow with the square of the frames. The run's end writes the rest (write_series).
    if (series.size() >= series_written + std::max<std::size_t>(1, series_written / 16)) write_series();
  }

  void write_series() {
    if (!settings.vtk || series.size() == series_written) return;
    series.write(out(kPvd));
    series_written = series.size();
  }

  // The checkpoint, durable, and before it the frames and rows written so far (Durability).
  void checkpoint() {
    flush_file_system(settings.out_dir);
    save_checkpoint(out(kCheckpoint), metadata(), sim.world().state);
    sim.forget_history();  // as a run resumed from this checkpoint starts
  }

  void write_run_json(const std::string& status, const RunResult* r, bool in_place = false) const {
    const State& s = sim.world().state;
    json j = {{"qbond_version", QBOND_VERSION},
              {"status", status},
              {"started_at", started_at},
              {"first_step", first_step},
              {"last_step", s.step},
              {"simulated_time", s.time},
              {"run", to_json(settings)},
              {"outputs",
               {{"diagnostics", kCsv},
                {"events", kEvents},
                {"series", settings.vtk ? json(kPvd) : json()},
                {"checkpoint", kCheckpoint}}},
              {"machine", {{"hardware_threads", std::thread::hardware_concurrency()}}},
              {"scene", scene.resolved}};
    if (!resumed_from.empty()) j["resumed_from"] = resumed_from;
    if (r) {
      j["finished_at"] = utc_now();
      j["message"] = r->message;
      j["steps_taken"] = r->steps_taken;
      j["wall_seconds"] = r->wall_seconds;
      j["steps_per_second"] = r->wall_seconds > 0 ? r->steps_taken / r->wall_seconds : 0.0;
      const World& w = sim.world();
      j["quanta"] = w.num_quanta();
      j["bonds"] = w.num_bonds();
      j["bonds_alive"] = w.num_alive_bonds();
      const EnergyGain& g = r->energy_gain;
      j["energy_gain"] = {{"exceeded", g.exceeded}, {"largest", g.largest}, {"relative", g.relative},
                          {"limit", scene.limits.energy_gain}};
      if (g.exceeded) {
        j["energy_gain"]["first_step"] = g.first_step;
        j["energy_gain"]["first_time"] = g.first_time;
      }
    }
    if (in_place) write_in_place(out(kRunJson), j.dump(2));
    else write_file_atomic(out(kRunJson), j.dump(2) + "\n");
  }
};

Runner::Runner(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Runner::Runner(Runner&&) noexcept = default;
Runner::~Runner() = default;

Runner::Runner(Scene scene, RunSettings settings)
    : impl_(std::make_unique<Impl>(std::move(scene), std::move(settings))) {
  Impl& r = *impl_;
  r.claim_output_dir();
  // Stale frames of an earlier run would show up in a file browser beside the new series.
  for (const auto& e : fs::directory_iterator(r.settings.out_dir / "frames"))
    if ((e.path().extension() == ".vtp" || e.path().extension() == ".pvtp") &&
        e.path().filename().string().starts_with("frame_"))
      fs::remove(e.path());
  fs::remove(r.out(kPvd));
  r.write_run_json("running", nullptr);
  try {
    r.csv = std::make_unique<LineFile>(r.out(kCsv), /*truncate=*/true);
    r.csv->write_line(r.diagnostics.header());
    r.events = std::make_unique<LineFile>(r.out(kEvents), /*truncate=*/true);
    r.events->write_line(kEventsHeader);
    r.output();
  } catch (const std::exception& e) {
    r.write_failed(e.what());
    throw;
  }
}

std::pair<Scene, RunSettings> Runner::read_checkpoint(const fs::path& checkpoint,
                                                      const std::function<void(Scene&, RunSettings&)>& adjust,
                                                      std::uint64_t max_memory) {
  const std::uint64_t limit = max_memory > 0 ? max_memory : default_memory_limit();
  Checkpoint ck = load_checkpoint(checkpoint, limit);
  const std::string name = checkpoint.string();
  // The metadata is checked like a scene: the checksum only says the bytes are the ones written,
  // not that whoever wrote them wrote sense.
  json meta;
  std::pair<Scene, RunSettings> out;
  auto& [scene, settings] = out;
  try {
    using namespace scene_detail;
    meta = parse_json_strict(ck.metadata);
    Obj top(meta, "", {"format", "qbond_version", "scene", "run", "adaptive", "ranks"});
    if (string(top.required("format"), "format") != "qbond-run") bad("format", "expected 'qbond-run'");
    if (!top.required("scene").is_object()) bad("scene", "expected an object, got " + type_name(top["scene"]));
    settings = settings_from_json(top.required("run"));
    if (top.has("ranks")) settings.resumed_ranks = top["ranks"].dump();  // checked by the run over ranks
    if (top.has("adaptive")) {
      Obj a(top["adaptive"], "adaptive", {"next_step", "last_step"});
      settings.resumed_next_step = positive(a.required("next_step"), a.at("next_step"));
      settings.resumed_last_step = positive(a.required("last_step"), a.at("last_step"));
    }
  } catch (const JsonTextError& e) {
    throw CheckpointError(name + ": metadata: " + e.what());
  } catch (const scene_detail::Bad& b) {
    throw CheckpointError(name + ": metadata: " + (b.path.empty() ? "" : b.path + ": ") + b.rule);
  }
  scene = parse_scene(meta["scene"].dump(), name + ", its scene", {.max_memory = max_memory});
  settings.out_dir = fs::absolute(checkpoint).parent_path();
  if (adjust) adjust(scene, settings);
  try {
    adopt_scene_bonds(ck, scene.world);
  } catch (const CheckpointError& e) {
    throw CheckpointError(name + ": " + e.what());
  }
  scene.world.state = std::move(ck.state);
  refuse_nothing_to_run(name, scene, settings);
  return out;
}

Runner Runner::resume(const fs::path& checkpoint, const std::function<void(Scene&, RunSettings&)>& adjust,
                      std::uint64_t max_memory) {
  auto [scene, settings] = read_checkpoint(checkpoint, adjust, max_memory);
  auto impl = std::make_unique<Impl>(std::move(scene), std::move(settings));
  Impl& r = *impl;
  r.resumed_from = fs::absolute(checkpoint).string();
  if (r.settings.resumed_next_step > 0 && r.scene.adaptive.enabled) {
    r.sim.set_timestep(r.settings.resumed_next_step);
    r.last_h = r.settings.resumed_last_step;
  }
  r.claim_output_dir();

  // Keep the rows (and their frames) a run that never stopped would have written up to here:
  // those on the output schedule up to the checkpoint's step; drop the rest.
  const std::uint64_t at = r.sim.world().state.step;
  try {
  auto text_of = [&](const char* name) {
    try {
      return read_file(r.out(name));
    } catch (const std::exception&) {
      return std::string();  // a new directory: the rows before the checkpoint are not there to keep
    }
  };
  const std::string header = r.diagnostics.header();
  const std::vector<std::string> kept = kept_lines(text_of(kCsv), header, [&](const std::string& line) {
    const std::uint64_t step = leading_step(line);
    const bool keep = step <= at && (step % r.settings.every == 0);
    if (keep) {
      // The frame the run wrote: whole, or in pieces (a .pvtp).
      for (bool pieces : {false, true})
        if (r.settings.vtk && fs::exists(r.out(frame_name(step, pieces))))
          r.series.add(std::strtod(line.c_str() + line.find(',') + 1, nullptr), frame_name(step, pieces));
      r.last_row = step;
    } else if (r.settings.vtk) {
      fs::remove(r.out(frame_name(step)));
      if (fs::remove(r.out(frame_name(step, true)))) {
        // and its pieces, frame_<step>_<rank>.vtp
        const std::string piece = fs::path(frame_name(step)).stem().string() + "_";
        for (const auto& e : fs::directory_iterator(r.settings.out_dir / "frames"))
          if (e.path().extension() == ".vtp" && e.path().filename().string().starts_with(piece)) fs::remove(e.path());
      }
    }
    return keep;
  });
  std::string text = header + "\n";
  for (const std::string& k : kept) text += k + "\n";
  write_file_atomic(r.out(kCsv), text);
  if (r.settings.vtk) {
    r.series.write(r.out(kPvd));
    r.series_written = r.series.size();
  }
  // Events of steps the checkpoint's state has taken (an event's step is the one it happened in).
  std::string events = std::string(kEventsHeader) + "\n";
  for (const std::string& k : kept_lines(text_of(kEvents), kEventsHeader,
                                         [&](const std::string& line) { return leading_step(line) < at; }))
    events += k + "\n";
  write_file_atomic(r.out(kEvents), events);
  r.events = std::make_unique<LineFile>(r.out(kEvents), /*truncate=*/false);
  r.csv = std::make_unique<LineFile>(r.out(kCsv), /*truncate=*/false);
  r.write_run_json("running", nullptr);
  } catch (const std::exception& e) {
    r.write_failed(e.what());
    throw;
  }
  return Runner(std::move(impl));
}

RunResult Runner::run(const std::function<bool()>& stop, const std::function<void(const RunProgress&)>& progress) {
  Impl& r = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  auto wall = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  RunResult result;
  const std::uint64_t start = r.sim.world().state.step;
  const double start_time = r.sim.world().state.time;
  RunProgress p;
  p.first_step = start;
  p.last_step = r.settings.steps;
  p.adaptive = r.scene.adaptive.enabled;
  bool gain_reported = r.energy_gain().exceeded;
  try {
  while (!r.finished()) {
    const StepReport rep = r.step();
    if (rep.status != StepReport::Status::ok) {
      result.status = RunStatus::blowup;
      result.message = rep.message;
      break;
    }
    for (const BondEvent& e : r.stepper ? r.stepper->events() : r.sim.events())
      r.events->write_line(event_row(e, r.sim.world()));
    if (r.energy_gain().exceeded && !gain_reported) {
      r.events->write_line(gain_row(r.energy_gain()));
      gain_reported = true;
    }
    const State& s = r.sim.world().state;
    if (s.step % r.settings.every == 0) r.output();
    if (r.settings.checkpoint_every && s.step % r.settings.checkpoint_every == 0) r.checkpoint();
    if (progress) {
      p.step = s.step;
      p.time = s.time;
      p.wall_seconds = wall();
      const double span = p.adaptive ? r.end_time() - start_time : static_cast<double>(p.last_step - start);
      const double done = p.adaptive ? s.time - start_time : static_cast<double>(s.step - start);
      p.fraction = r.finished() || span <= 0 ? 1.0 : std::min(1.0, done / span);
      progress(p);
    }
    if (stop && stop() && !r.finished()) {
      result.status = RunStatus::stopped;
      result.message = "interrupted at step " + std::to_string(s.step) +
                       " (t = " + scene_detail::num_str(s.time) + " s) before the end" +
                       (p.adaptive ? " at t = " + scene_detail::num_str(r.end_time()) + " s"
                                   : " at step " + std::to_string(r.settings.steps)) +
                       "; resume from " + r.out(kCheckpoint).string();
      break;
    }
  }
  result.steps_taken = r.sim.world().state.step - start;
  result.wall_seconds = wall();
  result.energy_gain = r.energy_gain();
  // The state the run ends with (the last good one after a blow-up) is always saved.
  r.output();
  r.write_series();
  r.checkpoint();
  r.write_run_json(to_string(result.status), &result);
  } catch (const std::exception& e) {
    r.write_failed(e.what());
    throw;
  }
  return result;
}

const Scene& Runner::scene() const { return impl_->scene; }
const RunSettings& Runner::settings() const { return impl_->settings; }
Simulation& Runner::simulation() { return impl_->sim; }
std::string frame_file(std::uint64_t step, std::string_view extension) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "frames/frame_%010llu.", static_cast<unsigned long long>(step));
  return buf + std::string(extension);
}

void Runner::set_stepper(Stepper stepper) { impl_->stepper = std::move(stepper); }

}  // namespace qbond
