// qbond_mode_damping: the damping ratio of the canonical lattice's first vibration modes under
// the default integrator, hybrid_frozen and velocity_verlet at h = 1e-4 s, 1e-3 s and 1/60 s,
// measured from runs (mode_damping.hpp) beside backward Euler's analytic value, and the same
// measurement on a single spring, where the default's is backward Euler's exactly. Writes JSON,
// which scripts/bench_tables.py renders into docs/integrators.md.
//
//   qbond_mode_damping --json docs/bench/damping-DATE.json [--n=5] [--modes=3] [--periods=3]
#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <nlohmann/json.hpp>
#include <string>

#include "bench_integrators.hpp"
#include "mode_damping.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/io/files.hpp"

namespace {

using namespace qbond;
using nlohmann::json;

constexpr double kAmplitude = 1e-8;  // [m] largest displacement: 1e-6 of the spacing, linear

json row(const std::string& integrator, int mode, const bench::ModeDamping& d) {
  return {{"integrator", integrator},
          {"mode", mode},
          {"h", d.h},
          {"omega", d.omega},
          {"omega_h", d.omega * d.h},
          {"steps", d.steps},
          {"stable", d.stable},
          {"amplification", d.stable ? json(d.amplification) : json(nullptr)},
          {"damping_ratio", d.stable ? json(d.damping_ratio()) : json(nullptr)},
          {"backward_euler_amplification", d.backward_euler_amplification()},
          {"backward_euler_damping_ratio", d.backward_euler_damping_ratio()}};
}

}  // namespace

int main(int argc, char** argv) {
  std::string out;
  int n = 5, modes = 3;
  double periods = 3;
  std::string command = "build/qbond_mode_damping";
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    command += " " + a;
    if (a.rfind("--json=", 0) == 0)
      out = a.substr(7);
    else if (a == "--json" && k + 1 < argc)
      out = argv[++k], command += " " + out;
    else if (a.rfind("--n=", 0) == 0)
      n = std::atoi(a.c_str() + 4);
    else if (a.rfind("--modes=", 0) == 0)
      modes = std::atoi(a.c_str() + 8);
    else if (a.rfind("--periods=", 0) == 0)
      periods = std::atof(a.c_str() + 10);
    else {
      std::fprintf(stderr,
                   "qbond_mode_damping: unknown argument '%s' (--json FILE --n=N --modes=K --periods=P)\n",
                   argv[k]);
      return 2;
    }
  }
  if (n < 2 || modes < 1 || !(periods > 0)) {
    std::fprintf(stderr, "qbond_mode_damping: --n must be at least 2, --modes and --periods positive\n");
    return 2;
  }
  const double steps[] = {1e-4, 1e-3, 1.0 / 60};
  std::vector<bench::NamedIntegrator> integrators;
  for (const auto& i : bench::known_integrators())
    if (i.name == "default" || i.name == "hybrid_frozen" || i.name == "velocity_verlet")
      integrators.push_back(i);
  for (auto& i : integrators) i.config.threads = 1;

  // The canonical lattice without gravity or material damping: the damping measured is the
  // integrator's alone.
  World lattice = canonical_lattice(n).world;
  lattice.model.gravity = Vec3::Zero();
  for (std::size_t b = 0; b < lattice.num_bonds(); ++b) lattice.state.bonds.damping[b] = 0;
  const std::vector<bench::VibrationMode> shapes = bench::vibration_modes(lattice, modes);
  json rows = json::array();
  std::printf("%-16s %4s %10s %10s %8s %7s %12s %12s %12s %12s\n", "integrator", "mode", "h [s]", "omega",
              "omega h", "steps", "|lambda|", "BE |lambda|", "zeta", "BE zeta");
  for (const auto& integ : integrators)
    for (double h : steps)
      for (std::size_t k = 0; k < shapes.size(); ++k) {
        const bench::ModeDamping d =
            bench::measure_mode_damping(lattice, integ.config, h, shapes[k], kAmplitude, periods);
        std::printf("%-16s %4zu %10.3g %10.4g %8.3g %7d %12.6g %12.6g %12.4g %12.4g%s\n", integ.name.c_str(),
                    k + 1, h, d.omega, d.omega * h, d.steps, d.amplification,
                    d.backward_euler_amplification(), d.damping_ratio(), d.backward_euler_damping_ratio(),
                    d.stable ? "" : "  unstable");
        rows.push_back(row(integ.name, static_cast<int>(k) + 1, d));
      }

  // A single spring (two 1 g quanta, k = 1000 N/m): one mode, ω = sqrt(2k/m), linear at this amplitude.
  World spring;
  spring.add_quanta(Vec3(0, 0, 0), Vec3::Zero(), 1e-3);
  spring.add_quanta(Vec3(0.01, 0, 0), Vec3::Zero(), 1e-3);
  spring.add_bond(0, 1, {.law = Law::linear, .stiffness = 1000, .damping = 0, .rest_length = 0.01});
  const bench::VibrationMode axial = bench::vibration_modes(spring, 1).at(0);
  json spring_rows = json::array();
  for (double h : steps) {
    IntegratorConfig cfg = default_integrator();
    cfg.threads = 1;
    const bench::ModeDamping d = bench::measure_mode_damping(spring, cfg, h, axial, kAmplitude, periods);
    spring_rows.push_back(row("default", 1, d));
  }
  if (!out.empty()) {
    const std::time_t now = std::time(nullptr);
    char date[32];
    std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    char host[256] = "unknown";
    gethostname(host, sizeof host - 1);
    const json doc = {
        {"date", date},
        {"machine", std::string(host) + ", " + std::to_string(sysconf(_SC_NPROCESSORS_ONLN)) + " cores"},
        {"command", command},
        {"nice", getpriority(PRIO_PROCESS, 0)},
        {"structure", "canonical lattice n=" + std::to_string(n) +
                          " (x = 0 face anchored), no gravity, no material damping"},
        {"amplitude", kAmplitude},
        {"periods", periods},
        {"rows", rows},
        {"single_spring", spring_rows}};
    write_file_atomic(out, doc.dump(1) + "\n");
  }
  return 0;
}
