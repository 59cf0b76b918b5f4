#include "qbond/io/vtk.hpp"

#include <algorithm>
#include <cassert>
#include <cstdio>
#include <cstring>
#include <type_traits>

#include "qbond/analysis/analysis.hpp"
#include "qbond/model/ordering.hpp"
#include "qbond/analysis/stress.hpp"
#include "qbond/io/files.hpp"

namespace qbond {
namespace {

// Builds the XML header and the appended binary block side by side: each array is declared with
// its offset into the block, where its bytes follow a UInt64 byte count.
class Appended {
 public:
  template <class T>
  void array(std::string& xml, const char* type, const std::string& name, int components, const T* data,
             std::size_t count) {
    xml += "<DataArray type=\"" + std::string(type) + "\"";
    if (!name.empty()) xml += " Name=\"" + name + "\"";
    xml += " NumberOfComponents=\"" + std::to_string(components) + "\" format=\"appended\" offset=\"" +
           std::to_string(block.size()) + "\"/>\n";
    const std::uint64_t bytes = count * sizeof(T);
    block.append(reinterpret_cast<const char*>(&bytes), sizeof bytes);
    block.append(reinterpret_cast<const char*>(data), bytes);
  }
  std::string block;
};

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// One frame's arrays in file order: per point (x, v: 3 components, stress: 9), then per cell,
// the verts before the lines; write_vtp and write_vtp_piece fill it, write_frame writes it.
struct Frame {
  std::vector<double> x, v, mass, mises, stress;
  std::vector<std::int64_t> id;
  std::vector<std::int32_t> body;
  std::vector<std::uint8_t> kinematic;
  std::vector<double> cell_strain, cell_tension;
  std::vector<std::int64_t> cell_bond, vert_conn, vert_off, line_conn, line_off;
};

// Writes `f` as a .vtp file; `more_point_data(a, xml)` adds the point arrays that follow stress
// (the caller's extra arrays, a piece's ghost flags).
template <class MorePointData>
void write_frame(const std::filesystem::path& path, const Frame& f, MorePointData&& more_point_data) {
  const std::size_t m = f.mass.size();
  Appended a;
  std::string xml =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
      "<PolyData>\n<Piece NumberOfPoints=\"" +
      std::to_string(m) + "\" NumberOfVerts=\"" + std::to_string(f.vert_off.size()) + "\" NumberOfLines=\"" +
      std::to_string(f.line_off.size()) + "\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n";
  xml += "<PointData Scalars=\"mass\" Vectors=\"velocity\">\n";
  a.array(xml, "Float64", "velocity", 3, f.v.data(), 3 * m);
  a.array(xml, "Float64", "mass", 1, f.mass.data(), m);
  a.array(xml, "Int64", "id", 1, f.id.data(), m);
  a.array(xml, "Int32", "body", 1, f.body.data(), m);
  a.array(xml, "UInt8", "kinematic", 1, f.kinematic.data(), m);
  a.array(xml, "Float64", "von_mises", 1, f.mises.data(), m);
  a.array(xml, "Float64", "stress", 9, f.stress.data(), 9 * m);
  more_point_data(a, xml);
  xml += "</PointData>\n<CellData Scalars=\"tension\">\n";
  a.array(xml, "Float64", "strain", 1, f.cell_strain.data(), f.cell_strain.size());
  a.array(xml, "Float64", "tension", 1, f.cell_tension.data(), f.cell_tension.size());
  a.array(xml, "Int64", "bond", 1, f.cell_bond.data(), f.cell_bond.size());
  xml += "</CellData>\n<Points>\n";
  a.array(xml, "Float64", "", 3, f.x.data(), 3 * m);
  xml += "</Points>\n<Verts>\n";
  a.array(xml, "Int64", "connectivity", 1, f.vert_conn.data(), f.vert_conn.size());
  a.array(xml, "Int64", "offsets", 1, f.vert_off.data(), f.vert_off.size());
  xml += "</Verts>\n<Lines>\n";
  a.array(xml, "Int64", "connectivity", 1, f.line_conn.data(), f.line_conn.size());
  a.array(xml, "Int64", "offsets", 1, f.line_off.data(), f.line_off.size());
  xml += "</Lines>\n</Piece>\n</PolyData>\n<AppendedData encoding=\"raw\">\n_";
  xml += a.block;
  xml += "\n</AppendedData>\n</VTKFile>\n";
  write_file_atomic(path, xml, Durability::atomic);
}

}  // namespace

void write_vtp(const std::filesystem::path& path, const Model& model, const State& state,
               std::span<const PointArray> extra) {
  const std::size_t n = model.num_quanta();
  // Point k is the quanta of user id k and lines come in bond-id order, so that files read the
  // same whatever the world's numbering (ordering.hpp).
  const std::vector<Index> quanta_at = quanta_by_id(model), bond_at = bonds_by_id(state.bonds);
  // values (n × components, world order) in file order.
  auto gather = [&](const auto* values, int components) {
    using T = std::remove_cvref_t<decltype(*values)>;
    std::vector<T> out(n * static_cast<std::size_t>(components));
    for (std::size_t k = 0; k < n; ++k)
      for (int c = 0; c < components; ++c)
        out[k * components + c] = values[std::size_t{quanta_at[k]} * components + c];
    return out;
  };
  static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");
  static_assert(sizeof(Mat3) == 9 * sizeof(double), "Mat3 must be nine packed doubles");

  Frame f;
  std::vector<double> tension, strain;
  bond_tension_strain(model, state, tension, strain);
  f.vert_conn.resize(n);
  f.vert_off.resize(n);
  f.cell_strain.assign(n, 0.0);
  f.cell_tension.assign(n, 0.0);
  f.cell_bond.assign(n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    f.vert_conn[i] = static_cast<std::int64_t>(i);
    f.vert_off[i] = static_cast<std::int64_t>(i + 1);
  }
  for (Index b : bond_at) {
    if (!state.bonds.alive[b]) continue;
    f.line_conn.push_back(model.quanta_id[state.bonds.i[b]]);
    f.line_conn.push_back(model.quanta_id[state.bonds.j[b]]);
    f.line_off.push_back(static_cast<std::int64_t>(f.line_conn.size()));
    f.cell_strain.push_back(strain[b]);
    f.cell_tension.push_back(tension[b]);
    f.cell_bond.push_back(state.bonds.id[b]);
  }
  f.id.resize(n);
  f.body.resize(n);
  f.kinematic.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const Index i = quanta_at[k];
    f.id[k] = static_cast<std::int64_t>(k);
    f.body[k] = static_cast<std::int32_t>(model.body[i]);
    f.kinematic[k] = model.is_kinematic(i);
  }
  // Stress where volumes are known (stress.hpp); 0 elsewhere.
  std::vector<Mat3> sigma;
  virial_stress(model, state, sigma);
  f.mises.resize(n);
  for (std::size_t k = 0; k < n; ++k) f.mises[k] = von_mises(sigma[quanta_at[k]]);
  f.x = gather(reinterpret_cast<const double*>(state.x.data()), 3);
  f.v = gather(reinterpret_cast<const double*>(state.v.data()), 3);
  f.mass = gather(model.mass.data(), 1);
  f.stress = gather(reinterpret_cast<const double*>(sigma.data()), 9);
  write_frame(path, f, [&](Appended& a, std::string& xml) {
    for (const PointArray& p : extra) {
      assert(p.values.size() == n * static_cast<std::size_t>(p.components));
      a.array(xml, "Float64", escape(p.name), p.components, gather(p.values.data(), p.components).data(),
              p.values.size());
    }
  });
}

void write_vtp_piece(const std::filesystem::path& path, const Model& model, const State& state,
                     std::span<const std::uint8_t> owned, std::span<const std::uint8_t> shown) {
  const std::size_t n = model.num_quanta();
  const Bonds& bonds = state.bonds;
  assert(owned.size() == n && shown.size() == bonds.size());
  // The points: the owned quanta and the other ends of the shown bonds, in ascending user id.
  std::vector<std::uint8_t> point(n, 0);
  for (std::size_t q = 0; q < n; ++q) point[q] = owned[q];
  std::vector<Index> lines;  // shown alive bonds, in bond-id order
  for (std::size_t b = 0; b < bonds.size(); ++b) {
    if (!shown[b] || !bonds.alive[b]) continue;
    lines.push_back(static_cast<Index>(b));
    point[bonds.i[b]] = point[bonds.j[b]] = 1;
  }
  std::sort(lines.begin(), lines.end(), [&](Index a, Index b) { return bonds.id[a] < bonds.id[b]; });
  std::vector<Index> at;  // file point → local quanta
  for (std::size_t q = 0; q < n; ++q)
    if (point[q]) at.push_back(static_cast<Index>(q));
  std::sort(at.begin(), at.end(), [&](Index a, Index b) { return model.quanta_id[a] < model.quanta_id[b]; });
  const std::size_t m = at.size();
  std::vector<std::int64_t> point_of(n, -1);
  for (std::size_t k = 0; k < m; ++k) point_of[at[k]] = static_cast<std::int64_t>(k);

  std::vector<double> tension, strain;
  bond_tension_strain(model, state, tension, strain);
  std::vector<Mat3> sigma;
  virial_stress(model, state, sigma);
  Frame f;
  f.x.resize(3 * m);
  f.v.resize(3 * m);
  f.mass.resize(m);
  f.mises.resize(m);
  f.stress.resize(9 * m);
  f.id.resize(m);
  f.body.resize(m);
  f.kinematic.resize(m);
  std::vector<std::uint8_t> ghost(m);
  for (std::size_t k = 0; k < m; ++k) {
    const Index q = at[k];
    for (int c = 0; c < 3; ++c) {
      f.x[3 * k + c] = state.x[q][c];
      f.v[3 * k + c] = state.v[q][c];
    }
    for (int c = 0; c < 9; ++c) f.stress[9 * k + c] = sigma[q].data()[c];
    f.mass[k] = model.mass[q];
    f.mises[k] = von_mises(sigma[q]);
    f.id[k] = static_cast<std::int64_t>(model.quanta_id[q]);
    f.body[k] = static_cast<std::int32_t>(model.body[q]);
    f.kinematic[k] = model.is_kinematic(q);
    ghost[k] = owned[q] ? 0 : 1;  // vtkGhostType's DUPLICATEPOINT
    if (!owned[q]) continue;
    f.vert_conn.push_back(static_cast<std::int64_t>(k));
    f.vert_off.push_back(static_cast<std::int64_t>(f.vert_conn.size()));
    f.cell_strain.push_back(0);
    f.cell_tension.push_back(0);
    f.cell_bond.push_back(-1);
  }
  for (Index b : lines) {
    f.line_conn.push_back(point_of[bonds.i[b]]);
    f.line_conn.push_back(point_of[bonds.j[b]]);
    f.line_off.push_back(static_cast<std::int64_t>(f.line_conn.size()));
    f.cell_strain.push_back(strain[b]);
    f.cell_tension.push_back(tension[b]);
    f.cell_bond.push_back(bonds.id[b]);
  }
  write_frame(path, f, [&](Appended& a, std::string& xml) {
    a.array(xml, "UInt8", "vtkGhostType", 1, ghost.data(), m);
  });
}

void write_pvtp(const std::filesystem::path& path, std::span<const std::string> pieces) {
  // The arrays write_vtp_piece writes, declared once for all pieces.
  std::string xml =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"PPolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
      "<PPolyData GhostLevel=\"0\">\n"
      "<PPointData Scalars=\"mass\" Vectors=\"velocity\">\n"
      "<PDataArray type=\"Float64\" Name=\"velocity\" NumberOfComponents=\"3\"/>\n"
      "<PDataArray type=\"Float64\" Name=\"mass\" NumberOfComponents=\"1\"/>\n"
      "<PDataArray type=\"Int64\" Name=\"id\" NumberOfComponents=\"1\"/>\n"
      "<PDataArray type=\"Int32\" Name=\"body\" NumberOfComponents=\"1\"/>\n"
      "<PDataArray type=\"UInt8\" Name=\"kinematic\" NumberOfComponents=\"1\"/>\n"
      "<PDataArray type=\"Float64\" Name=\"von_mises\" NumberOfComponents=\"1\"/>\n"
      "<PDataArray type=\"Float64\" Name=\"stress\" NumberOfComponents=\"9\"/>\n"
      "<PDataArray type=\"UInt8\" Name=\"vtkGhostType\" NumberOfComponents=\"1\"/>\n"
      "</PPointData>\n<PCellData Scalars=\"tension\">\n"
      "<PDataArray type=\"Float64\" Name=\"strain\" NumberOfComponents=\"1\"/>\n"
      "<PDataArray type=\"Float64\" Name=\"tension\" NumberOfComponents=\"1\"/>\n"
      "<PDataArray type=\"Int64\" Name=\"bond\" NumberOfComponents=\"1\"/>\n"
      "</PCellData>\n<PPoints>\n<PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n</PPoints>\n";
  for (const std::string& p : pieces) xml += "<Piece Source=\"" + escape(p) + "\"/>\n";
  xml += "</PPolyData>\n</VTKFile>\n";
  write_file_atomic(path, xml, Durability::atomic);
}

void PvdSeries::add(double time, std::string file) { frames_.emplace_back(time, std::move(file)); }

void PvdSeries::write(const std::filesystem::path& pvd) const {
  std::string xml =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n<Collection>\n";
  char t[32];
  for (const auto& [time, file] : frames_) {
    std::snprintf(t, sizeof t, "%.17g", time);
    xml += "<DataSet timestep=\"" + std::string(t) + "\" group=\"\" part=\"0\" file=\"" + escape(file) + "\"/>\n";
  }
  xml += "</Collection>\n</VTKFile>\n";
  write_file_atomic(pvd, xml, Durability::atomic);
}

}  // namespace qbond
