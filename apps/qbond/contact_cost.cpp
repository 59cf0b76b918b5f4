#include "contact_cost.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "machine.hpp"
#include "realtime.hpp"
#include "qbond/builders/samples.hpp"
#include "qbond/io/files.hpp"
#include "qbond/simulation/simulation.hpp"

namespace qbond::cli {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr double kWarmup = 1.0;  // [s] of simulated time stepped before timing: the contacts formed

enum class Variant { implicit, projection, none };
constexpr std::array<Variant, 3> kVariants = {Variant::implicit, Variant::projection, Variant::none};

const char* name(Variant v) {
  return v == Variant::implicit ? "implicit" : v == Variant::projection ? "projection" : "none";
}

// The scene with every obstacle and the quanta contact held one way (or not at all): implicit ones
// in the Model, projection ones as heuristics; the scene's other heuristics are kept.
Scene with_contact(Scene s, Variant v) {
  std::vector<Obstacle> obstacles = s.world.model.obstacles;
  QuantaContactRule contact = s.world.model.quanta_contact;
  std::vector<HeuristicSpec> kept;
  for (HeuristicSpec& h : s.heuristics) {
    if (const auto* ob = std::get_if<Obstacle>(&h)) obstacles.push_back(*ob);
    else if (const auto* c = std::get_if<QuantaContactRule>(&h)) contact = *c;
    else kept.push_back(std::move(h));
  }
  s.heuristics = std::move(kept);
  s.world.model.obstacles.clear();
  s.world.model.quanta_contact = QuantaContactRule{};
  if (v == Variant::none) return s;
  for (Obstacle ob : obstacles) {
    ob.method = v == Variant::implicit ? ContactMethod::implicit : ContactMethod::projection;
    ob.record = -1;  // the wall impulse is not recorded: diagnostics are not written
    if (v == Variant::implicit) s.world.model.obstacles.push_back(ob);
    else s.heuristics.emplace_back(ob);
  }
  if (contact.radius > 0) {
    contact.method = v == Variant::implicit ? ContactMethod::implicit : ContactMethod::projection;
    if (v == Variant::implicit) s.world.model.quanta_contact = contact;
    else s.heuristics.emplace_back(contact);
  }
  return s;
}

struct Run {
  Simulation sim;
  std::vector<double> seconds;  // every timed step's wall time
  std::string failure;          // a step that blew up, or empty
};

Run start(const Scene& s) {
  IntegratorConfig cfg = s.integrator;
  cfg.threads = 1;
  Run r{Simulation(s.world, cfg, s.timestep), {}, {}};
  r.sim.limits() = s.limits;
  for (const HeuristicSpec& hs : s.heuristics) r.sim.add_heuristic(make_heuristic(hs));
  return r;
}

// Steps the run `steps` times; timed: each step's wall time is kept. False once a step blew up.
bool advance(Run& r, int steps, bool timed) {
  for (int k = 0; k < steps && r.failure.empty(); ++k) {
    const auto t0 = Clock::now();
    const StepReport rep = r.sim.step();
    const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
    if (rep.status == StepReport::Status::blowup) r.failure = rep.message;
    else if (timed) r.seconds.push_back(dt);
  }
  return r.failure.empty();
}


}  // namespace

int bench_contact(const ContactCostArgs& a) {
  if (a.rounds < 1 || a.steps < 1) throw std::invalid_argument("qbond bench --contact: rounds and steps must be positive");
  const std::vector<std::string> names = split(a.scenes);
  if (names.empty()) throw std::invalid_argument("qbond bench --contact: name at least one built-in scene");
  std::printf("qbond bench --contact: a step's wall time (one thread) with contact inside the implicit step, by\n"
              "projection and without contact, after %g s of simulated time; %d interleaved rounds of %d steps\n\n",
              kWarmup, a.rounds, a.steps);
  std::printf("%-12s %7s %7s %10s %12s %14s %10s %14s %16s\n", "scene", "quanta", "bonds", "h [s]", "implicit ms",
              "projection ms", "none ms", "implicit/none", "implicit/proj.");
  json rows = json::array();
  for (const std::string& scene_name : names) {
    Scene scene = builtin_scene(scene_name);
    if (scene.adaptive.enabled)
      throw std::invalid_argument("qbond bench --contact: " + scene_name + " takes adaptive steps; name a fixed-step scene");
    if (a.dt > 0) scene.timestep = a.dt;
    if (scene.integrator.type != IntegratorType::coupled_implicit)
      throw std::invalid_argument("qbond bench --contact: " + scene_name + " is stepped by " +
                                  std::string(to_string(scene.integrator.type)) +
                                  "; implicit contact needs coupled_implicit");
    std::vector<Run> runs;
    for (Variant v : kVariants) runs.push_back(start(with_contact(scene, v)));
    const int warmup = std::max(1, static_cast<int>(std::lround(kWarmup / scene.timestep)));
    for (Run& r : runs) advance(r, warmup, false);
    // Interleaved: each round steps every variant in turn, starting from a different one, so
    // that the host's load falls on all of them alike.
    std::array<std::vector<double>, 3> round_ms;
    for (int round = 0; round < a.rounds; ++round)
      for (std::size_t k = 0; k < runs.size(); ++k) {
        Run& r = runs[(k + static_cast<std::size_t>(round)) % runs.size()];
        const std::size_t before = r.seconds.size();
        if (!advance(r, a.steps, true)) continue;
        const std::vector<double> these(r.seconds.begin() + static_cast<std::ptrdiff_t>(before), r.seconds.end());
        round_ms[(k + static_cast<std::size_t>(round)) % runs.size()].push_back(median(these) * 1e3);
      }
    auto ratio = [&](std::size_t x, std::size_t y) {
      std::vector<double> q;
      for (std::size_t k = 0; k < std::min(round_ms[x].size(), round_ms[y].size()); ++k) q.push_back(round_ms[x][k] / round_ms[y][k]);
      return median(q);
    };
    std::array<double, 3> ms{};
    for (std::size_t k = 0; k < runs.size(); ++k) ms[k] = median(runs[k].seconds) * 1e3;
    const double over_none = ratio(0, 2), over_projection = ratio(0, 1);
    std::printf("%-12s %7zu %7zu %10.4g %12.3f %14.3f %10.3f %14.3f %16.3f\n", scene_name.c_str(), scene.world.num_quanta(),
                scene.world.num_bonds(), scene.timestep, ms[0], ms[1], ms[2], over_none, over_projection);
    for (std::size_t k = 0; k < runs.size(); ++k)
      if (!runs[k].failure.empty()) std::printf("  %s: blew up: %s\n", name(kVariants[k]), runs[k].failure.c_str());
    std::fflush(stdout);
    json row = {{"scene", scene_name},
                {"quanta", scene.world.num_quanta()},
                {"bonds", scene.world.num_bonds()},
                {"timestep", scene.timestep},
                {"implicit_over_none", std::isfinite(over_none) ? json(over_none) : json(nullptr)},
                {"implicit_over_projection", std::isfinite(over_projection) ? json(over_projection) : json(nullptr)}};
    for (std::size_t k = 0; k < runs.size(); ++k)
      row[name(kVariants[k])] = {{"median_ms", std::isfinite(ms[k]) ? json(ms[k]) : json(nullptr)},
                                 {"rounds_ms", round_ms[k]},
                                 {"failure", runs[k].failure}};
    rows.push_back(row);
  }
  if (!a.json.empty()) {
    const std::time_t now = std::time(nullptr);
    char date[32];
    std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    const json doc = {{"date", date},       {"machine", machine()}, {"command", a.command},
                      {"nice", getpriority(PRIO_PROCESS, 0)},        {"warmup_seconds", kWarmup},
                      {"rounds", a.rounds}, {"steps", a.steps},     {"rows", rows}};
    write_file_atomic(a.json, doc.dump(1) + "\n");
  }
  return 0;
}

}  // namespace qbond::cli
