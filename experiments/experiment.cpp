#include "experiment.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "qbond/builders/builders.hpp"
#include "qbond/io/files.hpp"
#include "qbond/laws/materials.hpp"

namespace qbond::experiments {

void Report::table(const std::string& name, const std::string& header) { tables_.emplace_back(name, header + "\n"); }

void Report::row(std::initializer_list<double> values) {
  std::string& t = tables_.back().second;
  char buf[32];
  bool first = true;
  for (double v : values) {
    std::snprintf(buf, sizeof buf, first ? "%.17g" : ",%.17g", v);
    t += buf;
    first = false;
  }
  t += '\n';
}

void Report::row(const std::string& label, std::initializer_list<double> values) {
  std::string& t = tables_.back().second;
  t += label;
  char buf[32];
  for (double v : values) {
    std::snprintf(buf, sizeof buf, ",%.17g", v);
    t += buf;
  }
  t += '\n';
}

void Report::note(const std::string& line) { lines_.push_back(line); }

void Report::paper(const std::string& system, const std::string& quote) {
  system_ = system;
  quote_ = quote;
}

void Report::headline(const std::string& measured, const std::string& verdict) {
  measured_ = measured;
  verdict_ = verdict;
}

void Report::value(const std::string& key, double v) { values_.emplace_back(key, v); }

void Report::progress(const std::string& what) const {
  std::printf("  .. %s\n", what.c_str());
  std::fflush(stdout);
}

void Report::check(const std::string& claim, bool ok) {
  lines_.push_back(std::string(ok ? "- **pass**: " : "- **FAIL**: ") + claim);
  checks_.emplace_back(claim, ok);
  if (!ok) ++failed_;
  std::printf("  %s %s\n", ok ? "pass" : "FAIL", claim.c_str());
  std::fflush(stdout);
}

void Report::inform(const std::string& statement, const std::string& why) {
  lines_.push_back("- **informative** (not checked: " + why + "): " + statement);
  informative_.emplace_back(statement, why);
  std::printf("  info %s\n", statement.c_str());
  std::fflush(stdout);
}

void Report::write(const std::string& name, const std::string& title) const {
  std::filesystem::create_directories(out_);
  for (const auto& [file, content] : tables_) write_file_atomic(out_ / file, content);
  std::string md = "# " + title + "\n\n";
  if (quote_.empty())
    md += "**The paper**: not in the paper" + (system_.empty() ? std::string() : " (" + system_ + ")") + ".\n\n";
  else
    md += "**The paper**, for " + system_ + ":\n\n> " + quote_ + "\n\n";
  if (fast_) md += "*Fast mode: smaller sizes, fewer steps and seeds than the committed results.*\n\n";
  for (const std::string& l : lines_) md += l + "\n";
  write_file_atomic(out_ / "summary.md", md);
  nlohmann::ordered_json j;
  j["name"] = name;
  j["title"] = title;
  j["fast"] = fast_;
  j["paper"] = {{"system", system_}, {"quote", quote_}};
  j["measured"] = measured_;
  j["verdict"] = verdict_;
  nlohmann::ordered_json values = nlohmann::ordered_json::object();
  // Non-finite numbers (a method that blew up) have no JSON form: null.
  for (const auto& [k, v] : values_) values[k] = std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json();
  j["values"] = values;
  j["checks"] = nlohmann::ordered_json::array();
  for (const auto& [claim, ok] : checks_) j["checks"].push_back({{"claim", claim}, {"pass", ok}});
  j["informative"] = nlohmann::ordered_json::array();
  for (const auto& [claim, why] : informative_) j["informative"].push_back({{"statement", claim}, {"why", why}});
  j["passed"] = passed();
  write_file_atomic(out_ / "results.json", j.dump(1) + "\n");
}

double student_t975(int dof) {
  // Two-sided 95% quantiles of Student's t for 1–30 degrees of freedom; beyond, the
  // Cornish–Fisher series t ≈ z + (z³ + z)/(4ν) + (5z⁵ + 16z³ + 3z)/(96ν²), within 1e-4 there.
  static constexpr double table[] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
                                     2.201,  2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
                                     2.080,  2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042};
  if (dof < 1) return INFINITY;
  if (dof <= 30) return table[dof - 1];
  const double z = 1.959964, z3 = z * z * z, nu = dof;
  return z + (z3 + z) / (4 * nu) + (5 * z3 * z * z + 16 * z3 + 3 * z) / (96 * nu * nu);
}

std::filesystem::path find_scripts(const std::filesystem::path& exe) {
  const std::filesystem::path dir = exe.parent_path();
  for (const std::filesystem::path& d : {dir / "share" / "qbond", dir / ".." / "share" / "qbond"})
    if (std::filesystem::exists(d / "plot.py")) return d.lexically_normal();
  return {};
}

namespace {

// A qbond source tree's committed results: a folder `results` beside experiments/experiment.cpp.
bool is_committed_results(const std::filesystem::path& out) {
  const std::filesystem::path abs = std::filesystem::weakly_canonical(std::filesystem::absolute(out));
  return abs.filename() == "results" && std::filesystem::exists(abs.parent_path() / "experiment.cpp");
}

}  // namespace

int run_experiments(std::span<const Experiment> list, const std::vector<std::string>& names, const RunOptions& opt) {
  std::vector<const Experiment*> chosen;
  for (const std::string& n : names) {
    if (n == "all") {
      for (const Experiment& e : list) chosen.push_back(&e);
      continue;
    }
    const auto it = std::find_if(list.begin(), list.end(), [&](const Experiment& e) { return n == e.name; });
    if (it == list.end()) throw std::invalid_argument("unknown experiment '" + n + "' (see --list)");
    chosen.push_back(&*it);
  }
  if (is_committed_results(opt.out) && !opt.update_results)
    throw std::invalid_argument("'" + opt.out.string() +
                                "' holds the committed results of a qbond source tree: give --update-results to "
                                "replace them, or another -o folder");
  if (opt.plots && opt.scripts.empty())
    std::printf("plot.py was not found beside the program (share/qbond or ../share/qbond): no plots drawn\n");
  int failed = 0;
  for (const Experiment* e : chosen) {
    std::printf("%s: %s%s\n", e->name, e->title, opt.fast ? " (fast)" : "");
    std::fflush(stdout);
    const auto t0 = std::chrono::steady_clock::now();
    const std::filesystem::path dir = opt.out / e->name;
    Report rep(dir, opt.fast);
    e->run({opt.fast, dir, opt.python, opt.scripts}, rep);
    rep.write(e->name, e->title);
    if (!rep.passed()) ++failed;
    if (opt.plots && !opt.scripts.empty()) {
      const std::string cmd = opt.python + " '" + (opt.scripts / "plot.py").string() + "' " + e->name + " '" + dir.string() + "'";
      std::fflush(stdout);
      if (std::system(cmd.c_str()) != 0) {
        std::fprintf(stderr, "qbond: %s: drawing the plots failed (%s)\n", e->name, cmd.c_str());
        ++failed;
      }
    }
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("  -> %s (%s, %.1f s)\n", dir.string().c_str(), rep.passed() ? "every claim holds" : "a claim FAILED", sec);
    std::fflush(stdout);
  }
  return failed;
}

std::span<const Experiment> all() {
  static const Experiment list[] = {
      {"drag", "Drag: the paper's hybrid is not Galilean invariant", drag},
      {"fig3", "Figure 3: time per step against the number of quanta", fig3},
      {"fig4_5", "Figures 4-5: two bonded quanta against the exact solution", fig4_5},
      {"fig6_7", "Figures 6-7: energy of four bonded quanta", fig6_7},
      {"eq14_15", "Eqs. 14-15: bonds in series and in parallel reduced to one", eq14_15},
      {"fig9", "Figure 9: von Mises stress in a loaded block", fig9},
      {"fig10", "Figure 10: the pendulum, swinging and tugged", fig10},
      {"fig11", "Figure 11: the twisted bar against GetFEM and Saint-Venant", fig11},
      {"fig12", "Figure 12: symmetric and asymmetric lattices tearing", fig12},
      {"cantilever", "Cantilever: a calibrated lattice beam against beam theory", cantilever},
      {"energy_momentum", "Section 5: an integrator that pays attention to the total energy", energy_momentum},
      {"integrators", "Every integrator on the canonical lattice: cost per step and energy error", integrator_table},
      {"gas", "Gases: wall pressure from momentum transfer, and the speeds relaxing to Maxwell-Boltzmann", gas},
  };
  return list;
}

std::string num(double v, int digits) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

std::size_t index_of(const std::vector<Method>& methods, std::string_view name) {
  for (std::size_t k = 0; k < methods.size(); ++k)
    if (methods[k].name == name) return k;
  return methods.size();
}

SteelBar steel_bar(int n, double L, double b, double E) {
  SteelBar bar;
  bar.spacing = b / n;
  const double a = bar.spacing;
  const int nx = static_cast<int>(std::lround(L / a)) + 1;
  CubicLattice lat;
  lat.size = {nx, n, n};
  lat.spacing = a;
  lat.bond = {.stiffness = calibrated_stiffness(cubic_cell(lat.shells), E, a)};
  lat.quanta_mass = calibrated_mass(cubic_cell(lat.shells), 7850, a);
  bar.ids = add_cubic_lattice(bar.world, lat);
  for (Index i : bar.ids) {
    if (bar.world.state.x[i].x() < 0.5 * a) bar.clamp.push_back(i);
    if (bar.world.state.x[i].x() > (nx - 1.5) * a) bar.end.push_back(i);
  }
  bar.world.prescribe(bar.clamp, Motion{});
  return bar;
}

}  // namespace qbond::experiments
