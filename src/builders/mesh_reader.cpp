#include "qbond/builders/mesh_reader.hpp"

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <map>
#include <stdexcept>
#include <unordered_map>

#include "builders/bonded_points.hpp"
#include "io/text_fields.hpp"
#include "qbond/io/files.hpp"

namespace qbond {

namespace {

using text::malformed;
using text::parse_double;
using text::parse_long;
using text::quoted;
using text::tokens;

/// Merges vertices with identical coordinates (STL stores every triangle's corners separately).
class Welder {
 public:
  explicit Welder(TriangleMesh& mesh) : mesh_(mesh) {}
  Index add(const Vec3& p) {
    // + 0.0 turns −0 into +0, so the two zeros weld.
    const std::array<std::uint64_t, 3> key{std::bit_cast<std::uint64_t>(p.x() + 0.0),
                                           std::bit_cast<std::uint64_t>(p.y() + 0.0),
                                           std::bit_cast<std::uint64_t>(p.z() + 0.0)};
    const auto [it, fresh] = ids_.emplace(key, static_cast<Index>(mesh_.vertices.size()));
    if (fresh) mesh_.vertices.push_back(p);
    return it->second;
  }

 private:
  TriangleMesh& mesh_;
  std::map<std::array<std::uint64_t, 3>, Index> ids_;
};

bool degenerate(const std::array<Index, 3>& t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; }

}  // namespace

TriangleMesh parse_obj(std::string_view text, const std::string& name) {
  TriangleMesh mesh;
  std::size_t line_no = 0;
  std::vector<Index> face;
  while (!text.empty()) {
    const std::size_t end = std::min(text.find('\n'), text.size());
    std::string_view line = text.substr(0, end);
    text.remove_prefix(std::min(end + 1, text.size()));
    ++line_no;
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    const auto t = tokens(line);
    if (t.empty()) continue;
    if (t[0] == "v") {
      if (t.size() < 4) malformed(name, line_no, "a vertex needs 3 coordinates: v x y z");
      double c[3];
      for (int d = 0; d < 3; ++d)
        if (!parse_double(t[1 + d], c[d]))
          malformed(name, line_no, "vertex coordinate " + quoted(t[1 + d]) + " is not a finite number");
      for (std::size_t k = 4; k < t.size(); ++k) {
        double ignored;
        if (!parse_double(t[k], ignored))
          malformed(name, line_no, "vertex value " + quoted(t[k]) + " is not a finite number");
      }
      mesh.vertices.emplace_back(c[0], c[1], c[2]);
    } else if (t[0] == "f") {
      if (t.size() < 4) malformed(name, line_no, "a face needs at least 3 vertices");
      face.clear();
      for (std::size_t k = 1; k < t.size(); ++k) {
        const std::string_view ref = t[k].substr(0, t[k].find('/'));  // a, a/t, a//n, a/t/n
        long long v = 0;
        if (!parse_long(ref, v) || v == 0)
          malformed(
              name, line_no,
              "face vertex " + quoted(t[k]) + " is not a non-zero integer (1-based, or negative: relative)");
        const long long nv = static_cast<long long>(mesh.vertices.size());
        const long long id = v > 0 ? v - 1 : nv + v;
        if (id < 0 || id >= nv)
          malformed(name, line_no,
                    "face vertex " + std::to_string(v) + " does not exist (" + std::to_string(nv) +
                        " vertices defined so far)");
        face.push_back(static_cast<Index>(id));
      }
      for (std::size_t a = 0; a < face.size(); ++a)
        for (std::size_t b = a + 1; b < face.size(); ++b)
          if (face[a] == face[b])
            malformed(name, line_no,
                      "face uses vertex " + std::to_string(face[a] + 1) + " twice (degenerate)");
      for (std::size_t k = 1; k + 1 < face.size(); ++k)
        mesh.triangles.push_back({face[0], face[k], face[k + 1]});
    }
    // Everything else (vt, vn, o, g, s, usemtl, mtllib, l, ...) does not change the shape.
  }
  if (mesh.triangles.empty()) malformed(name, 0, "no faces ('f' lines): not a triangle mesh");
  return mesh;
}

TriangleMesh parse_stl(std::string_view bytes, const std::string& name) {
  TriangleMesh mesh;
  Welder weld(mesh);
  auto u32 = [&](std::size_t at) {
    return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at])) |
           static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + 1])) << 8 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + 2])) << 16 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + 3])) << 24;
  };
  // Binary: an 80-byte header, a triangle count, 50 bytes per triangle (normal, 3 corners as
  // little-endian float32, 2 attribute bytes). Some binary files start with "solid" too, so the
  // size decides first.
  if (bytes.size() >= 84 && bytes.size() == 84 + 50 * static_cast<std::uint64_t>(u32(80))) {
    const std::uint32_t n = u32(80);
    for (std::uint32_t t = 0; t < n; ++t) {
      std::array<Index, 3> tri{};
      for (int c = 0; c < 3; ++c) {
        Vec3 p;
        for (int d = 0; d < 3; ++d) {
          p[d] =
              static_cast<double>(std::bit_cast<float>(u32(84 + 50 * std::size_t{t} + 12 + 12 * c + 4 * d)));
          if (!std::isfinite(p[d]))
            malformed(name, 0, "triangle " + std::to_string(t) + " has a non-finite coordinate");
        }
        tri[c] = weld.add(p);
      }
      if (degenerate(tri)) malformed(name, 0, "triangle " + std::to_string(t) + " has two identical corners");
      mesh.triangles.push_back(tri);
    }
    if (mesh.triangles.empty()) malformed(name, 0, "binary STL with no triangles");
    return mesh;
  }
  // ASCII: solid NAME { facet normal n n n  outer loop  vertex x y z (x3)  endloop  endfacet } endsolid
  std::size_t pos = 0, line = 1;
  auto next = [&]() -> std::string_view {
    while (pos < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[pos])))
      line += bytes[pos++] == '\n';
    const std::size_t start = pos;
    while (pos < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[pos]))) ++pos;
    return bytes.substr(start, pos - start);
  };
  auto skip_line = [&] {
    while (pos < bytes.size() && bytes[pos] != '\n') ++pos;
  };
  auto expect = [&](std::string_view word) {
    const std::string_view t = next();
    if (t != word)
      malformed(
          name, line,
          "expected '" + std::string(word) + "', got " + (t.empty() ? "the end of the file" : quoted(t)));
  };
  auto number = [&] {
    const std::string_view t = next();
    double v;
    if (!parse_double(t, v))
      malformed(name, line,
                "expected a finite number, got " + (t.empty() ? "the end of the file" : quoted(t)));
    return v;
  };
  std::string_view t = next();
  if (t != "solid")
    malformed(name, 0,
              "neither binary STL (" + std::to_string(bytes.size()) +
                  " bytes is not 84 + 50 x the triangle count in its header) nor ASCII STL (does not start "
                  "with 'solid')");
  while (t == "solid") {
    skip_line();  // the solid's name
    for (t = next(); t == "facet"; t = next()) {
      const std::size_t facet_line = line;
      expect("normal");
      for (int d = 0; d < 3; ++d) number();
      expect("outer");
      expect("loop");
      std::array<Index, 3> tri{};
      for (int c = 0; c < 3; ++c) {
        expect("vertex");
        const double x = number(), y = number(), z = number();
        tri[c] = weld.add(Vec3(x, y, z));
      }
      expect("endloop");
      expect("endfacet");
      if (degenerate(tri)) malformed(name, facet_line, "facet has two identical corners");
      mesh.triangles.push_back(tri);
    }
    if (t != "endsolid")
      malformed(name, line,
                "expected 'facet' or 'endsolid', got " + (t.empty() ? "the end of the file" : quoted(t)));
    skip_line();
    t = next();
  }
  if (!t.empty()) malformed(name, line, "expected 'solid' or the end of the file, got " + quoted(t));
  if (mesh.triangles.empty()) malformed(name, 0, "ASCII STL with no facets");
  return mesh;
}

TriangleMesh parse_mesh(std::string_view bytes, const std::string& name) {
  const std::string ext = text::lower_extension(name);
  if (ext == ".obj") return parse_obj(bytes, name);
  if (ext == ".stl") return parse_stl(bytes, name);
  throw std::runtime_error(name + ": unknown mesh format '" + ext + "' (accepted: .obj, .stl)");
}

TriangleMesh read_obj(const std::filesystem::path& file) { return parse_obj(read_file(file), file.string()); }
TriangleMesh read_stl(const std::filesystem::path& file) { return parse_stl(read_file(file), file.string()); }
TriangleMesh read_mesh(const std::filesystem::path& file) {
  const std::string ext = text::lower_extension(file.string());
  if (ext != ".obj" && ext != ".stl")
    throw std::runtime_error(file.string() + ": unknown mesh format '" + ext + "' (accepted: .obj, .stl)");
  return parse_mesh(read_file(file), file.string());
}

void check_closed(const TriangleMesh& mesh, const std::string& name) {
  if (mesh.triangles.empty()) throw std::runtime_error(name + ": the mesh has no triangles");
  const std::size_t nv = mesh.vertices.size();
  std::vector<std::uint64_t> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    for (Index v : tri)
      if (v >= nv)
        throw std::runtime_error(name + ": triangle " + std::to_string(t) + " refers to a missing vertex");
    if (degenerate(tri))
      throw std::runtime_error(name + ": triangle " + std::to_string(t) + " repeats a vertex");
    for (int e = 0; e < 3; ++e) {
      const Index a = tri[e], b = tri[(e + 1) % 3];
      edges.push_back(static_cast<std::uint64_t>(std::min(a, b)) << 32 | std::max(a, b));
    }
  }
  std::sort(edges.begin(), edges.end());
  std::size_t bad = 0, first_count = 0;
  std::uint64_t first = 0;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i != 2 && bad++ == 0) {
      first = edges[i];
      first_count = j - i;
    }
    i = j;
  }
  if (bad > 0) {
    auto at = [&](std::uint64_t v) {
      const Vec3& p = mesh.vertices[v];
      return "(" + num(p.x()) + ", " + num(p.y()) + ", " + num(p.z()) + ")";
    };
    throw std::runtime_error(name + ": the mesh is not closed: " + std::to_string(bad) +
                             " edge(s) do not belong to exactly two triangles (the edge " + at(first >> 32) +
                             " - " + at(first & 0xffffffffu) + " belongs to " + std::to_string(first_count) +
                             "); a body needs a closed (watertight) surface");
  }
}

}  // namespace qbond
