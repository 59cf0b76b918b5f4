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
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

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

std::string machine() {
  char host[256] = "unknown";
  gethostname(host, sizeof host - 1);
  return std::string(host) + ", " + std::to_string(sysconf(_SC_NPROCESSORS_ONLN)) + " cores";
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
};

// Frames of 1/60 s as the viewer's headless mode takes them: round(1/(60 h)) steps of the scene's
// timestep (at least one), each an adaptive step to time + h when the scene is adaptive.
Measured run_frames(const Scene& scene, int threads, const RealtimeArgs& a) {
  IntegratorConfig cfg = scene.integrator;
  cfg.threads = threads;
  Simulation sim(scene.world, cfg, scene.timestep);
  sim.limits() = scene.limits;
  for (const HeuristicSpec& hs : scene.heuristics) sim.add_heuristic(make_heuristic(hs));
  const double h = scene.timestep;
  const int steps = std::max(1, static_cast<int>(std::lround(kFrame / h)));
  Measured m;
  auto frame = [&]() -> bool {
    for (int k = 0; k < steps; ++k) {
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
  while (static_cast<int>(m.frames.size()) < a.frames) {
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
  };
  std::vector<Workload> work;
  for (int n : sizes) {
    Scene s = canonical_lattice(n);
    s.timestep = kFrame;  // the default integrator at one step a frame
    s.integrator = default_integrator();
    if (!a.preconditioner.empty()) s.integrator.preconditioner = parse_preconditioner(a.preconditioner);
    work.push_back({"lattice n=" + std::to_string(n), "canonical", std::move(s)});
  }
  // The host's load (runnable processes, 1-minute average) at the start and the end: on a shared
  // machine, wall time over CPU time follows it.
  double load_start = NAN, load_end = NAN;
  getloadavg(&load_start, 1);
  std::vector<std::string> names = split(a.scenes);
  if (names.empty())
    for (const BuiltinScene& b : builtin_scenes()) names.emplace_back(b.name);
  for (const std::string& name : names) work.push_back({name, "scene", builtin_scene(name)});

  std::printf(
      "qbond bench --realtime: wall time of a 1/60 s frame (the viewer's steps: round(1/(60 h)), at least "
      "1),\n"
      "median of up to %d frames after %d warm-up frames, at most %g s measured per row; keeps up: median <= "
      "1/60 s\n\n",
      a.frames, kWarmupFrames, a.budget);
  std::printf("%-22s %8s %8s %7s %11s %6s %10s %10s %10s %8s %9s %s\n", "workload", "quanta", "bonds",
              "threads", "h [s]", "steps", "frame ms", "max ms", "cpu ms", "x real", "keeps up", "note");
  json rows = json::array();
  for (const Workload& w : work)
    for (int t : threads) {
      const Measured m = run_frames(w.scene, t, a);
      const double med = median(m.frames), med_cpu = median(m.cpu);
      const double worst = m.frames.empty() ? NAN : *std::max_element(m.frames.begin(), m.frames.end());
      const int steps = std::max(1, static_cast<int>(std::lround(kFrame / w.scene.timestep)));
      const bool keeps = !m.frames.empty() && m.failure.empty() && med <= kFrame;
      std::string note = !m.failure.empty() ? "blew up: " + m.failure
                         : m.warmup_only    ? "cut off by the budget: one warm-up frame measured"
                         : m.cut_off
                             ? "cut off by the budget after " + std::to_string(m.frames.size()) + " frames"
                             : "";
      std::printf("%-22s %8zu %8zu %7d %11.4g %6d %10.3f %10.3f %10.3f %8.2f %9s %s\n", w.name.c_str(),
                  w.scene.world.num_quanta(), w.scene.world.num_bonds(), t, w.scene.timestep, steps,
                  med * 1e3, worst * 1e3, med_cpu * 1e3, kFrame / med, keeps ? "yes" : "no", note.c_str());
      std::fflush(stdout);
      rows.push_back({{"workload", w.name},
                      {"kind", w.kind},
                      {"quanta", w.scene.world.num_quanta()},
                      {"bonds", w.scene.world.num_bonds()},
                      {"threads", t},
                      {"integrator", std::string(to_string(w.scene.integrator.type))},
                      {"preconditioner", std::string(to_string(w.scene.integrator.preconditioner))},
                      {"timestep", w.scene.timestep},
                      {"adaptive", w.scene.adaptive.enabled},
                      {"steps_per_frame", steps},
                      {"frames", m.frames.size()},
                      {"median_frame_seconds", m.frames.empty() ? json(nullptr) : json(med)},
                      {"max_frame_seconds", m.frames.empty() ? json(nullptr) : json(worst)},
                      {"median_frame_cpu_seconds", m.frames.empty() ? json(nullptr) : json(med_cpu)},
                      {"real_time_factor", m.frames.empty() ? json(nullptr) : json(kFrame / med)},
                      {"keeps_up", keeps},
                      {"cut_off", m.cut_off},
                      {"warmup_only", m.warmup_only},
                      {"failure", m.failure}});
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
                      {"frame_seconds", kFrame},
                      {"warmup_frames", kWarmupFrames},
                      {"max_frames", a.frames},
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
