// Each step of the canonical workload (the bare step qbond_bench times) timed on its own
// (docs/performance.md, "Running the benchmarks"): the fastest, the 10th and 25th percentiles and
// the median of the steps' times.
//
//   qbond_step_times [--n=40] [--integrator=hybrid_frozen] [--steps=250] [--threads=1]
//
// On a shared host the percentiles set a step's own cost apart from the slow steps the host's
// other load makes (qbond_bench averages those in); two builds compare by running both in turn,
// round after round, and taking each round's ratios.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "bench_integrators.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/simulation/simulation.hpp"

namespace {

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "qbond_step_times: %s\nusage: qbond_step_times [--n=40] [--integrator=hybrid_frozen] [--steps=250] "
               "[--threads=1]\n",
               why);
  std::exit(2);
}

// The value of --name=value as a positive integer.
int positive(std::string_view arg, std::size_t prefix) {
  char* end = nullptr;
  const std::string text(arg.substr(prefix));
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || v <= 0 || v > 1'000'000) usage(("not a positive integer: " + std::string(arg)).c_str());
  return static_cast<int>(v);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace qbond;
  int n = 40, steps = 250, threads = 1;
  std::string name = "hybrid_frozen";
  for (int k = 1; k < argc; ++k) {
    const std::string_view arg = argv[k];
    if (arg.starts_with("--n="))
      n = positive(arg, 4);
    else if (arg.starts_with("--steps="))
      steps = positive(arg, 8);
    else if (arg.starts_with("--threads="))
      threads = positive(arg, 10);
    else if (arg.starts_with("--integrator="))
      name = arg.substr(13);
    else
      usage(("unknown argument: " + std::string(arg)).c_str());
  }
  const auto all = bench::known_integrators();
  const auto found = std::find_if(all.begin(), all.end(), [&](const auto& i) { return i.name == name; });
  if (found == all.end()) usage(("unknown integrator: " + name).c_str());
  Scene scene = canonical_lattice(n);
  if (found->timestep > 0) scene.timestep = found->timestep;
  IntegratorConfig cfg = found->config;
  cfg.threads = threads;
  Simulation sim(std::move(scene.world), cfg, scene.timestep);
  sim.set_track_energy(false);  // the bare step, as qbond_bench times it
  sim.set_keep_last_good(false);
  for (int k = 0; k < 5; ++k) sim.step();  // buffers grown, caches warm
  std::vector<double> ms(static_cast<std::size_t>(steps));
  for (double& t : ms) {
    const auto start = std::chrono::steady_clock::now();
    const StepReport r = sim.step();
    t = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (r.status != StepReport::Status::ok) {
      std::fprintf(stderr, "qbond_step_times: the step failed: %s\n", r.message.c_str());
      return 1;
    }
  }
  std::sort(ms.begin(), ms.end());
  const auto at = [&](double p) { return ms[static_cast<std::size_t>(p * static_cast<double>(steps - 1))]; };
  std::printf("%s n=%d threads=%d steps=%d ms: min %.4g p10 %.4g p25 %.4g median %.4g\n", name.c_str(), n, threads,
              steps, ms.front(), at(0.1), at(0.25), at(0.5));
}
