#include "experiment.hpp"

#include <cmath>
#include <cstdio>

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

void Report::check(const std::string& claim, bool ok) {
  lines_.push_back(std::string(ok ? "- **pass**: " : "- **FAIL**: ") + claim);
  if (!ok) ++failed_;
  std::printf("  %s %s\n", ok ? "pass" : "FAIL", claim.c_str());
}

void Report::write(const std::string& title) const {
  std::filesystem::create_directories(out_);
  for (const auto& [name, content] : tables_) write_file_atomic(out_ / name, content);
  std::string md = "# " + title + "\n\n";
  for (const std::string& l : lines_) md += l + "\n";
  write_file_atomic(out_ / "summary.md", md);
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
