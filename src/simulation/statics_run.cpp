#include "qbond/simulation/statics_run.hpp"

#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <numeric>

#include "qbond/analysis/analysis.hpp"
#include "qbond/analysis/stress.hpp"
#include "qbond/io/diagnostics.hpp"
#include "qbond/io/directory_lock.hpp"
#include "qbond/io/files.hpp"
#include "qbond/io/vtk.hpp"
#include "qbond/version.hpp"

namespace qbond {
namespace fs = std::filesystem;

namespace {

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

nlohmann::json vec(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

StaticsReport run_statics(Scene& scene, const StaticsSettings& settings) {
  const fs::path dir = fs::absolute(settings.out_dir);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec)
    throw std::runtime_error("cannot create the output directory " + dir.string() + ": " + ec.message());
  const DirectoryLock lock(dir);
  remove_stale_temporaries(dir);

  World& w = scene.world;
  const Model& m = w.model;
  State& s = w.state;
  const std::size_t n = m.num_quanta();
  const std::vector<Vec3> x_start(s.x.begin(), s.x.end());
  // The energy accounts open at the start, and the loads' work is theirs over the displacement
  // (constant forces), so that the diagnostics row's numerical column is the energy a structure
  // loaded at once from rest must lose to come to rest at the equilibrium.
  open_ledger(m, s, s.energy);
  EnergyLedger& ledger = s.energy;
  StaticsReport report;
  report.result = solve_static(w, settings.tolerance, settings.max_iterations);
  for (const Load& l : m.loads)
    for (Index i : l.quanta)
      ledger.work_loads += l.share().dot(s.x[i] - x_start[i]);

  // Reactions: what the supports apply to hold their quanta, −Σ bond forces on them (velocities
  // are 0 at equilibrium, so no damping).
  std::vector<double> reaction(3 * n, 0.0), displacement(3 * n, 0.0);
  for (std::size_t b = 0; b < s.bonds.size(); ++b) {
    if (!s.bonds.alive[b]) continue;
    const Index i = s.bonds.i[b], j = s.bonds.j[b];
    if (!m.is_kinematic(i) && !m.is_kinematic(j)) continue;
    const Vec3 fi = s.bonds.force_on_i(m.shapes, b, s.x[j] - s.x[i], s.v[j] - s.v[i], s.bonds.rest[b]);
    for (int c = 0; c < 3; ++c) {
      if (m.is_kinematic(i)) reaction[3 * i + c] -= fi[c];
      if (m.is_kinematic(j)) reaction[3 * j + c] += fi[c];
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 u = s.x[i] - x_start[i];
    for (int c = 0; c < 3; ++c) displacement[3 * i + c] = u[c];
    report.max_displacement = std::max(report.max_displacement, u.norm());
    if (m.is_kinematic(i))
      report.reaction += Vec3(reaction[3 * i], reaction[3 * i + 1], reaction[3 * i + 2]);
    else
      report.load += m.gravity * m.mass[i];
  }
  for (const Load& l : m.loads) report.load += l.force;

  std::vector<Mat3> sigma;
  virial_stress(m, s, sigma);
  std::vector<double> tension, strain;
  bond_tension_strain(m, s, tension, strain);

  // Rows by the user's ids, as in the frames.
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return m.quanta_id[a] < m.quanta_id[b]; });
  std::string quanta = "id,body,kinematic,x,y,z,ux,uy,uz,rx,ry,rz,von_mises,sxx,syy,szz,syz,sxz,sxy\n";
  auto put = [](std::string& line, double v) {
    line += ',';
    line += number(v);
  };
  for (std::size_t i : order) {
    quanta += std::to_string(m.quanta_id[i]);
    quanta += ',';
    quanta += std::to_string(m.body[i]);
    quanta += m.is_kinematic(i) ? ",1" : ",0";
    for (int c = 0; c < 3; ++c) put(quanta, s.x[i][c]);
    for (int c = 0; c < 3; ++c) put(quanta, displacement[3 * i + c]);
    for (int c = 0; c < 3; ++c) put(quanta, reaction[3 * i + c]);
    const Mat3& g = sigma[i];
    for (double v : {von_mises(g), g(0, 0), g(1, 1), g(2, 2), g(1, 2), g(0, 2), g(0, 1)}) put(quanta, v);
    quanta += '\n';
  }
  write_file_atomic(dir / "quanta.csv", quanta);
  std::string bonds = "bond,i,j,strain,tension\n";
  for (std::size_t b = 0; b < s.bonds.size(); ++b) {
    if (!s.bonds.alive[b]) continue;
    bonds += std::to_string(s.bonds.id[b]);
    for (Index q : {s.bonds.i[b], s.bonds.j[b]}) {
      bonds += ',';
      bonds += std::to_string(m.quanta_id[q]);
    }
    put(bonds, strain[b]);
    put(bonds, tension[b]);
    bonds += '\n';
  }
  write_file_atomic(dir / "bonds.csv", bonds);

  std::vector<Probe> probes;
  for (const ProbeSpec& p : scene.output.probes) probes.push_back({p.name, p.quanta, p.about});
  const Diagnostics diagnostics(m, std::move(probes));
  write_file_atomic(dir / "diagnostics.csv",
                    diagnostics.header() + "\n" + diagnostics.row(m, s, SolveStats{}) + "\n");
  if (settings.vtk) {
    const PointArray extra[] = {{"displacement", 3, displacement}, {"reaction", 3, reaction}};
    write_vtp(dir / "static.vtp", m, s, extra);
  }
  const nlohmann::json j = {{"qbond_version", QBOND_VERSION},
                            {"converged", report.result.converged},
                            {"iterations", report.result.iterations},
                            {"residual", report.result.residual},
                            {"tolerance", settings.tolerance},
                            {"load", vec(report.load)},
                            {"reaction", vec(report.reaction)},
                            {"max_displacement", report.max_displacement},
                            {"quanta", n},
                            {"bonds_alive", w.num_alive_bonds()},
                            {"outputs",
                             {{"quanta", "quanta.csv"},
                              {"bonds", "bonds.csv"},
                              {"diagnostics", "diagnostics.csv"},
                              {"frame", settings.vtk ? nlohmann::json("static.vtp") : nlohmann::json()}}},
                            {"scene", scene.resolved}};
  write_file_atomic(dir / "statics.json", j.dump(2) + "\n");
  return report;
}

}  // namespace qbond
