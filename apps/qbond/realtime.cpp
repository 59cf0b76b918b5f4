#include "realtime.hpp"

#include <stdlib.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <numeric>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "huge_pages.hpp"
#include "machine.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/integrators/adaptive.hpp"
#include "qbond/io/files.hpp"
#include "qbond/simulation/simulation.hpp"

namespace qbond::cli {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr double kFrame = 1.0 / 60;  // [s] of simulated time a frame
constexpr int kWarmupFrames = 2;     // buffers grown, hierarchies built, caches warm
// The canonical lattice as a running simulation: it settles under gravity for kSettleFrames
// frames, then its free face is pulled up by twice the body's weight for as many.
constexpr int kSettleFrames = 60;
constexpr int kLatticeFrames = 2 * kSettleFrames;
constexpr double kPullWeights = 2;
// The CG tolerance of the lattice's real-time rows (beside the default integrator's).
constexpr double kRealtimeTolerance = 1e-4;
// A core slower than this fraction of the fastest is named in the row's note: the rows on more
// threads than one wait for it.
constexpr double kEvenCores = 0.9;

std::vector<int> split_ints(const std::string& s, const char* what) {
  std::vector<int> out;
  for (const std::string& t : split(s)) {
    std::size_t end = 0;
    int v = 0;
    try {
      v = std::stoi(t, &end);
    } catch (const std::exception&) {
      end = 0;
    }
    if (end != t.size() || v < 1 || v > 1000)
      throw std::invalid_argument(std::string("qbond bench --realtime: ") + what + ": '" + t +
                                  "' is not a positive integer");
    out.push_back(v);
  }
  return out;
}

// The process's CPU time [s], all threads together.
double cpu_now() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct Measured {
  std::vector<double> frames;  // [s] wall time of each measured frame
  std::vector<double> cpu;     // [s] the process's CPU time in each (every thread's)
  bool cut_off = false;        // the budget ended the measurement before `frames` frames
  bool warmup_only = false;    // the warm-up alone outlasted the budget: its frame is all there is
  std::string failure;         // a step that blew up, or empty
  // The pulled face's mean height [m] when the pull starts and after the last frame (NaN: no pull,
  // or not reached).
  double face_z_settled = NAN, face_z_end = NAN;
};

// The force on each quanta of the canonical lattice's free face (largest x) that pulls it up by
// kPullWeights times the body's weight, from frame kSettleFrames on (empty: no pull).
struct Pull {
  std::vector<Index> quanta;
  Vec3 force = Vec3::Zero();
};

Pull lattice_pull(const World& w) {
  Pull p;
  double far = -INFINITY, mass = 0;
  for (std::size_t i = 0; i < w.num_quanta(); ++i) far = std::max(far, w.state.x[i].x());
  for (std::size_t i = 0; i < w.num_quanta(); ++i) {
    mass += w.model.mass[i];
    if (w.state.x[i].x() > far - 1e-9) p.quanta.push_back(static_cast<Index>(i));
  }
  p.force = -kPullWeights * mass * w.model.gravity / static_cast<double>(p.quanta.size());
  return p;
}

// Frames of 1/60 s as the viewer's headless mode takes them: round(1/(60 h)) steps of the scene's
// timestep (at least one), each an adaptive step to time + h when the scene is adaptive; up to
// `frames` measured after the warm-up, the pull (if any) on from frame kSettleFrames.
Measured run_frames(const Scene& scene, const Pull& pull, int frames, int threads, const RealtimeArgs& a) {
  IntegratorConfig cfg = scene.integrator;
  cfg.threads = threads;
  Simulation sim(scene.world, cfg, scene.timestep);
  sim.limits() = scene.limits;
  for (const HeuristicSpec& hs : scene.heuristics) sim.add_heuristic(make_heuristic(hs));
  const double h = scene.timestep;
  const int steps = std::max(1, static_cast<int>(std::lround(kFrame / h)));
  Measured m;
  int taken = 0;
  auto face_z = [&] {
    double z = 0;
    for (Index i : pull.quanta) z += sim.world().state.x[i].z();
    return pull.quanta.empty() ? NAN : z / static_cast<double>(pull.quanta.size());
  };
  auto frame = [&]() -> bool {
    if (taken == kSettleFrames) m.face_z_settled = face_z();
    const bool pulled = !pull.quanta.empty() && taken++ >= kSettleFrames;
    for (int k = 0; k < steps; ++k) {
      if (pulled)
        for (Index i : pull.quanta) sim.add_force(i, pull.force);
      StepReport r;
      if (scene.adaptive.enabled) {
        const double t1 = sim.world().state.time + h;
        while (sim.world().state.time < t1 && r.status == StepReport::Status::ok)
          r = adaptive_step(sim, scene.adaptive, t1).step;
      } else {
        r = sim.step();
      }
      if (r.status == StepReport::Status::blowup) {
        m.failure = r.message;
        return false;
      }
    }
    return true;
  };
  const auto start = Clock::now();
  auto spent = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  for (int k = 0; k < kWarmupFrames; ++k) {
    const auto t0 = Clock::now();
    const double c0 = cpu_now();
    if (!frame()) return m;
    // A frame slower than the budget: the warm-up frame is all that is measured.
    if (spent() > a.budget) {
      m.frames.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
      m.cpu.push_back(cpu_now() - c0);
      m.cut_off = m.warmup_only = true;
      return m;
    }
  }
  const auto measured_from = Clock::now();
  while (static_cast<int>(m.frames.size()) < frames) {
    if (std::chrono::duration<double>(Clock::now() - measured_from).count() > a.budget) {
      m.cut_off = true;
      break;
    }
    const auto t0 = Clock::now();
    const double c0 = cpu_now();
    if (!frame()) break;
    m.frames.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    m.cpu.push_back(cpu_now() - c0);
  }
  m.face_z_end = face_z();
  return m;
}

}  // namespace

int bench_realtime(const RealtimeArgs& a) {
  if (!(a.budget > 0) || a.frames < 1)
    throw std::invalid_argument("qbond bench --realtime: the budget and the frame count must be positive");
  const std::vector<int> sizes = split_ints(a.sizes, "--sizes"), threads = split_ints(a.threads, "--threads");
  struct Workload {
    std::string name, kind;
    Scene scene;
    Pull pull;
    int frames;
  };
  std::vector<Workload> work;
  for (int n : sizes)
    for (const bool realtime_tolerance : {false, true}) {
      Scene s = canonical_lattice(n);
      s.timestep = kFrame;  // the default integrator at one step a frame
      s.integrator = default_integrator();
      if (realtime_tolerance) s.integrator.tolerance = kRealtimeTolerance;
      if (!a.preconditioner.empty()) s.integrator.preconditioner = parse_preconditioner(a.preconditioner);
      Pull pull = lattice_pull(s.world);
      std::string name = "lattice n=" + std::to_string(n);
      if (realtime_tolerance) name += " tol=1e-4";
      work.push_back({std::move(name), "canonical", std::move(s), std::move(pull), kLatticeFrames});
    }
  // The host's load (runnable processes, 1-minute average) at the start and the end: on a shared
  // machine, wall time over CPU time follows it.
  double load_start = NAN, load_end = NAN;
  getloadavg(&load_start, 1);
  std::vector<std::string> names = split(a.scenes);
  if (names.empty())
    for (const BuiltinScene& b : builtin_scenes()) names.emplace_back(b.name);
  for (const std::string& name : names) work.push_back({name, "scene", builtin_scene(name), {}, a.frames});

  std::printf(
      "qbond bench --realtime: wall time of a 1/60 s frame (the viewer's steps: round(1/(60 h)), at least "
      "1),\n"
      "median and mean of up to %d frames (the lattice: %d, settling under gravity, then its free face pulled up by %g "
      "weights from frame %d;\ntol=1e-4: CG to a relative residual of 1e-4) after %d warm-up frames, at most %g s "
      "measured per row; keeps up: mean <= 1/60 s (x real: 1/60 s over the mean)\n\n",
      a.frames, kLatticeFrames, kPullWeights, kSettleFrames, kWarmupFrames, a.budget);
  std::printf("%-26s %8s %8s %7s %11s %6s %10s %10s %10s %10s %8s %9s %s\n", "workload", "quanta", "bonds",
              "threads", "h [s]", "steps", "frame ms", "mean ms", "max ms", "cpu ms", "x real", "keeps up", "note");
  json rows = json::array();
  for (const Workload& w : work)
    for (int t : threads) {
      // The cores' speeds just before the row: a shared host may slow one core for a while. A
      // row on one thread runs on the fastest, so that its time does not depend on where the
      // kernel happened to put the process; rows on more threads run where the kernel puts them.
      const CoreSpeeds cores = core_speeds();
      const PinToCore pin(t == 1 ? cores.fastest() : -1);
      const Measured m = run_frames(w.scene, w.pull, w.frames, t, a);
      const double med = median(m.frames), med_cpu = median(m.cpu);
      // The mean is the run's throughput (frames over their total time), slow frames included.
      const double mean =
          m.frames.empty() ? NAN : std::accumulate(m.frames.begin(), m.frames.end(), 0.0) / static_cast<double>(m.frames.size());
      const double worst = m.frames.empty() ? NAN : *std::max_element(m.frames.begin(), m.frames.end());
      const int steps = std::max(1, static_cast<int>(std::lround(kFrame / w.scene.timestep)));
      const bool keeps = !m.frames.empty() && m.failure.empty() && mean <= kFrame;
      std::string note = !m.failure.empty() ? "blew up: " + m.failure
                         : m.warmup_only    ? "cut off by the budget: one warm-up frame measured"
                         : m.cut_off
                             ? "cut off by the budget after " + std::to_string(m.frames.size()) + " frames"
                             : "";
      if (cores.slowest() < kEvenCores) {
        char speeds[64];
        std::snprintf(speeds, sizeof speeds, "%sslowest core at %.2f of the fastest", note.empty() ? "" : "; ",
                      cores.slowest());
        note += speeds;
      }
      std::printf("%-26s %8zu %8zu %7d %11.4g %6d %10.3f %10.3f %10.3f %10.3f %8.2f %9s %s\n", w.name.c_str(),
                  w.scene.world.num_quanta(), w.scene.world.num_bonds(), t, w.scene.timestep, steps,
                  med * 1e3, mean * 1e3, worst * 1e3, med_cpu * 1e3, kFrame / mean, keeps ? "yes" : "no", note.c_str());
      std::fflush(stdout);
      rows.push_back({{"workload", w.name},
                      {"kind", w.kind},
                      {"quanta", w.scene.world.num_quanta()},
                      {"bonds", w.scene.world.num_bonds()},
                      {"threads", t},
                      {"integrator", std::string(to_string(w.scene.integrator.type))},
                      {"preconditioner", std::string(to_string(w.scene.integrator.preconditioner))},
                      {"tolerance", w.scene.integrator.tolerance},
                      {"timestep", w.scene.timestep},
                      {"adaptive", w.scene.adaptive.enabled},
                      {"steps_per_frame", steps},
                      {"frames", m.frames.size()},
                      {"median_frame_seconds", m.frames.empty() ? json(nullptr) : json(med)},
                      {"mean_frame_seconds", m.frames.empty() ? json(nullptr) : json(mean)},
                      {"max_frame_seconds", m.frames.empty() ? json(nullptr) : json(worst)},
                      {"median_frame_cpu_seconds", m.frames.empty() ? json(nullptr) : json(med_cpu)},
                      {"real_time_factor", m.frames.empty() ? json(nullptr) : json(kFrame / mean)},
                      {"keeps_up", keeps},
                      {"cut_off", m.cut_off},
                      {"warmup_only", m.warmup_only},
                      {"failure", m.failure},
                      {"core_speeds", {{"cpus", cores.cpus}, {"speed", cores.speed}}},
                      {"pulled_face_z", std::isnan(m.face_z_settled)
                                            ? json(nullptr)
                                            : json({{"settled", m.face_z_settled}, {"end", m.face_z_end}})}});
    }
  getloadavg(&load_end, 1);
  std::printf("\nload average (1 min): %.2f at the start, %.2f at the end, on %ld cores\n", load_start,
              load_end, sysconf(_SC_NPROCESSORS_ONLN));
  if (!a.json.empty()) {
    const std::time_t now = std::time(nullptr);
    char date[32];
    std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    const json doc = {{"date", date},
                      {"machine", machine()},
                      {"command", a.command},
                      {"nice", getpriority(PRIO_PROCESS, 0)},
                      {"huge_pages", huge_pages_asked()},
                      {"frame_seconds", kFrame},
                      {"warmup_frames", kWarmupFrames},
                      {"max_frames", a.frames},
                      {"lattice_frames", kLatticeFrames},
                      {"lattice_settle_frames", kSettleFrames},
                      {"lattice_pull_weights", kPullWeights},
                      {"budget_seconds", a.budget},
                      {"load_average", {load_start, load_end}},
                      {"rows", rows}};
    write_file_atomic(a.json, doc.dump(1) + "\n");
  }
  return 0;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? NAN : n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

}  // namespace qbond::cli
