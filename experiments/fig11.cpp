// Figure 11: a bar twisted at one end, the lattice against a GetFEM linear-elasticity solution of
// the same bar (experiments/fig11_getfem.py) and Saint-Venant torsion: torque against twist
// angle, the displacement fields, and how the lattice's error shrinks as it is refined.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "experiment.hpp"
#include "qbond/laws/materials.hpp"
#include "qbond/io/probes.hpp"
#include "qbond/solvers/statics.hpp"

namespace qbond::experiments {
namespace {

constexpr double kL = 0.1, kB = 0.02, kE = 200e9;

// Rows of numbers of a CSV with a header line.
std::vector<std::vector<double>> read_rows(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::string line;
  std::vector<std::vector<double>> rows;
  std::getline(f, line);
  while (std::getline(f, line)) {
    std::vector<double> r;
    std::stringstream s(line);
    std::string cell;
    while (std::getline(s, cell, ',')) r.push_back(std::stod(cell));
    rows.push_back(r);
  }
  return rows;
}

struct Twist {
  double torque = 0;  // reaction torque about the bar's axis at the twisted end [N·m]
  std::vector<Vec3> site, u;  // sites in the continuum's frame and their displacements
};

// The bar at n quanta across (calibrated steel, default cubic lattice), x = 0 layer clamped,
// x = L layer turned by θ about the axis, solved for static equilibrium.
Twist twist_lattice(int n, double theta) {
  SteelBar bar = steel_bar(n, kL, kB, kE);
  World& w = bar.world;
  const double a = bar.spacing, c = 0.5 * (n - 1) * a;
  const std::vector<Index>&ids = bar.ids, &end = bar.end;
  const std::vector<Vec3> x0 = w.state.x;
  w.prescribe(end, Motion{});
  const Mat3 R = Eigen::AngleAxisd(theta, Vec3::UnitX()).toRotationMatrix();
  const Vec3 axis_point(0, c, c);
  for (Index i : end) w.state.x[i] = axis_point + R * (x0[i] - axis_point);
  solve_static(w, 1e-10);
  Twist t;
  // The torque the turned end's support applies to the bar.
  t.torque = measure_probe(w.model, w.state, {"end", end, Vec3(kL, c, c)}).torque.x();
  for (Index i : ids) {
    t.site.push_back(x0[i] + Vec3(0, 0.5 * a, 0.5 * a));  // the continuum's frame: cells centred on sites
    t.u.push_back(w.state.x[i] - x0[i]);
  }
  return t;
}

}  // namespace

void fig11(const Options& opt, Report& rep) {
  rep.paper("a large bar twisted at one end, against Getfem++ (Figure 11)",
            "The results of the quanta-bond method, as seen in Figure 11, show the same shape and form as the Getfem++ "
            "solution");
  const double nu = lattice_elastic_constants(cubic_cell(Shells::face_diagonal), 1, 1).poisson_ratio;
  const double G = kE / (2 * (1 + nu));
  const double theta = 0.01;
  const double sv = 0.1406 * G * kB * kB * kB * kB / kL;  // Saint-Venant, square section: J = 0.1406 b⁴
  const std::vector<int> res = opt.fast ? std::vector<int>{2, 3, 4} : std::vector<int>{4, 6, 8, 12};
  rep.note("A steel bar (E = 200 GPa, the lattice's ν = " + num(nu) + ") " + num(kL) + " m long, " + num(kB) +
           " m square, clamped at x = 0 and turned at x = L about its axis, both ends held flat. Saint-Venant: T/θ = "
           "0.1406 G b⁴ / L = " + num(sv, 6) + " N·m/rad (free warping).\n");

  // The lattice: torque against angle at the finest resolution, and T/θ at each resolution.
  rep.table("torque_angle.csv", "theta,lattice_torque");
  std::vector<double> angle_ratio;
  for (double th : {0.005, 0.01, 0.02, 0.04}) {
    const Twist t = twist_lattice(res.back(), th);
    rep.row({th, t.torque});
    angle_ratio.push_back(t.torque / th);
  }
  rep.table("refinement.csv", "quanta_across,lattice_stiffness");
  std::vector<double> stiff;
  Twist finest;
  for (int n : res) {
    rep.progress("lattice, " + std::to_string(n) + " quanta across");
    Twist t = twist_lattice(n, theta);
    stiff.push_back(t.torque / theta);
    rep.row({static_cast<double>(n), t.torque / theta});
    if (n == res.back()) finest = std::move(t);
  }
  // GetFEM on the same bar, evaluated at the finest lattice's sites.
  rep.table("lattice_displacement.csv", "x,y,z,ux,uy,uz");
  for (std::size_t k = 0; k < finest.site.size(); ++k)
    rep.row({finest.site[k].x(), finest.site[k].y(), finest.site[k].z(), finest.u[k].x(), finest.u[k].y(), finest.u[k].z()});
  rep.write("fig11", "Figure 11: the twisted bar against GetFEM and Saint-Venant");  // GetFEM reads the sites
  if (opt.scripts.empty()) {
    rep.check("fig11_getfem.py (GetFEM's side of the comparison) was found beside the program", false);
    return;
  }
  const int fem_across = opt.fast ? 3 : 6;
  rep.progress("GetFEM, up to " + std::to_string(fem_across) + " elements across");
  const std::string cmd = opt.python + " '" + (opt.scripts / "fig11_getfem.py").string() + "' '" + opt.out.string() +
                          "' " + num(kL, 17) + " " + num(kB, 17) + " " + num(kE, 17) + " " + num(nu, 17) + " " +
                          num(theta, 17) + " " + std::to_string(fem_across);
  if (std::system(cmd.c_str()) != 0) {
    rep.check("GetFEM solved the bar (" + cmd + ")", false);
    return;
  }
  const auto fem = read_rows(opt.out / "getfem.csv");
  const double fem_k = fem.back()[2] / theta, fem_prev = fem[fem.size() - 2][2] / theta;
  const auto at_sites = read_rows(opt.out / "getfem_at_sites.csv");
  double diff2 = 0, umax = 0;
  for (std::size_t k = 0; k < at_sites.size(); ++k) {
    const Vec3 uf(at_sites[k][3], at_sites[k][4], at_sites[k][5]);
    diff2 += (uf - finest.u[k]).squaredNorm();
    umax = std::max(umax, uf.norm());
  }
  const double rms = std::sqrt(diff2 / static_cast<double>(at_sites.size())) / umax;

  rep.note("| quanta across | lattice T/θ [N·m/rad] | / GetFEM | / Saint-Venant |");
  rep.note("|---|---|---|---|");
  std::vector<double> err;
  for (std::size_t k = 0; k < res.size(); ++k) {
    err.push_back(std::abs(stiff[k] / fem_k - 1));
    rep.note("| " + std::to_string(res[k]) + " | " + num(stiff[k], 6) + " | " + num(stiff[k] / fem_k, 4) + " | " +
             num(stiff[k] / sv, 4) + " |");
  }
  rep.note("\nGetFEM (Q2 hexahedra, " + std::to_string(fem_across) + " across): T/θ = " + num(fem_k, 6) +
           " N·m/rad (" + num(std::abs(fem_k / fem_prev - 1) * 100, 2) + "% from the next coarser mesh).\n");
  rep.check("GetFEM agrees with Saint-Venant within 3% (" + num(fem_k / sv, 4) +
                "; the flat ends restrain warping, which stiffens the bar a little)",
            std::abs(fem_k / sv - 1) < 0.03);
  rep.check("the lattice's torque is linear in the twist angle up to 0.04 rad (T/θ varies by " +
                num((angle_ratio.back() / angle_ratio.front() - 1) * 100, 2) + "% < 1%)",
            std::abs(angle_ratio.back() / angle_ratio.front() - 1) < 0.01);
  bool shrinking = true;
  for (std::size_t k = 1; k < err.size(); ++k) shrinking = shrinking && err[k] < err[k - 1];
  rep.check("refining the lattice brings its torque closer to GetFEM's (errors " + num(err.front() * 100, 3) +
                "% ... " + num(err.back() * 100, 3) + "%)",
            shrinking);
  const double order = std::log(err[err.size() - 2] / err.back()) /
                       std::log(static_cast<double>(res.back()) / res[res.size() - 2]);
  rep.check("the torque error falls at least as 1/n (observed order " + num(order, 3) + ")", order > 0.9);
  if (!opt.fast)
    rep.check("the finest lattice (" + std::to_string(res.back()) + " across) is within 5% of GetFEM's torque (" +
                  num(err.back() * 100, 3) + "%)",
              err.back() < 0.05);
  else
    rep.inform("the finest lattice is within 5% of GetFEM's torque (" + num(err.back() * 100, 3) + "% at " +
                   std::to_string(res.back()) + " across)",
               "the fast mode's lattices are too coarse for it; the full run checks it");
  rep.check("the finest lattice's displacement field matches GetFEM's at its sites (RMS difference " +
                num(rms * 100, 3) + "% of the largest displacement < 10%)",
            rms < 0.10);
  rep.value("getfem", fem_k);
  rep.value("saint_venant", sv);
  rep.value("order", order);
  rep.value("finest_across", res.back());
  rep.value("finest_error_percent", err.back() * 100);
  rep.value("field_rms_percent", rms * 100);
  rep.headline("torque " + num(err.back() * 100, 2) + "% " + (stiff.back() < fem_k ? "below" : "above") +
                   " GetFEM's at " + std::to_string(res.back()) + " quanta across, error falling as n^−" +
                   num(order, 2) + "; displacement field within " + num(rms * 100, 2) + "%",
               "yes, and converging");
}

}  // namespace qbond::experiments
