// Gmsh .msh files (ASCII 2.2 and 4.1) as tetrahedral meshes (tet_mesh.hpp).
#include <map>
#include <unordered_map>

#include "io/text_fields.hpp"
#include "qbond/builders/tet_mesh.hpp"

namespace qbond {

namespace {

using text::malformed;

/// Gmsh element types: 4 the four-node tetrahedron; 15 point, 1 line, 2 triangle, 3 quadrangle
/// (and their higher orders 8, 9, 10, 16, 20, 21, …) are lower-dimensional groups a volume mesh
/// carries for its boundaries.
bool is_volume_element(long long type) {
  switch (type) {
    case 4: case 5: case 6: case 7: case 11: case 12: case 13: case 14: case 17: case 18: case 19:
    case 29: case 30: case 31: case 92: case 93:
      return true;
    default:
      return false;
  }
}

class GmshReader {
 public:
  GmshReader(std::string_view text, const std::string& name) : lines_(text), name_(name) {}

  TetMesh read() {
    std::string_view line;
    bool format = false, nodes = false, elements = false;
    while (next(line)) {
      const auto t = text::tokens(line);
      if (t.empty()) continue;
      if (t[0] == "$MeshFormat") {
        mesh_format();
        format = true;
      } else if (t[0] == "$Nodes") {
        if (!format) fail("$Nodes before $MeshFormat");
        version_ == 2 ? nodes_2() : nodes_4();
        nodes = true;
      } else if (t[0] == "$Elements") {
        if (!nodes) fail("$Elements before $Nodes");
        version_ == 2 ? elements_2() : elements_4();
        elements = true;
      } else if (t[0].starts_with("$") && !t[0].starts_with("$End")) {
        skip_section(std::string(t[0].substr(1)));  // $PhysicalNames, $Entities, $NodeData, …
      } else {
        fail("expected a section ($MeshFormat, $Nodes, $Elements, …), got " + text::quoted(t[0]));
      }
    }
    if (!format) malformed(name_, 0, "no $MeshFormat section: not a Gmsh mesh");
    if (!elements) malformed(name_, 0, "no $Elements section");
    if (mesh_.tets.empty())
      malformed(name_, 0, "no four-node tetrahedra (element type 4): not a tetrahedral volume mesh");
    return std::move(mesh_);
  }

 private:
  bool next(std::string_view& line) { return lines_.next(line); }
  [[noreturn]] void fail(const std::string& rule) const { malformed(name_, lines_.number(), rule); }

  /// The fields of the next non-blank line; `what` names it when the file ends instead.
  std::vector<std::string_view> row(const char* what) {
    std::string_view line;
    while (next(line)) {
      auto t = text::tokens(line);
      if (!t.empty()) return t;
    }
    malformed(name_, lines_.number(), std::string("the file ends where ") + what + " should be");
  }
  long long integer(std::string_view t, const char* what) const {
    long long v = 0;
    if (!text::parse_long(t, v)) fail(std::string(what) + " " + text::quoted(t) + " is not an integer");
    return v;
  }
  std::size_t count(std::string_view t, const char* what) const {
    const long long v = integer(t, what);
    // A count larger than the bytes left cannot be honest: refuse it before reserving anything.
    if (v < 0 || v > 50'000'000) fail(std::string(what) + " " + text::quoted(t) + " is not a count in [0, 5e7]");
    return static_cast<std::size_t>(v);
  }
  double number(std::string_view t, const char* what) const {
    double v = 0;
    if (!text::parse_double(t, v)) fail(std::string(what) + " " + text::quoted(t) + " is not a finite number");
    return v;
  }
  void end(const char* section) {
    const auto t = row((std::string("$End") + section).c_str());
    if (t[0] != std::string("$End") + section)
      fail(std::string("expected $End") + section + ", got " + text::quoted(t[0]));
  }
  void skip_section(const std::string& section) {
    std::string_view line;
    const std::string closing = "$End" + section;
    const std::size_t start = lines_.number();
    while (next(line))
      if (text::trim(line) == closing) return;
    malformed(name_, start, "section $" + section + " has no " + closing);
  }

  void mesh_format() {
    const auto t = row("the format line (version file-type data-size)");
    if (t.size() < 3) fail("the format line needs version, file-type and data-size");
    if (t[1] != "0") fail("binary Gmsh files (file-type " + std::string(t[1]) + ") are not read: save as ASCII");
    if (t[0] == "2.2" || t[0] == "2.1" || t[0] == "2.0" || t[0] == "2")
      version_ = 2;
    else if (t[0] == "4.1")
      version_ = 4;
    else
      fail("Gmsh format version " + text::quoted(t[0]) + " is not read (accepted: 2.2, 4.1)");
    end("MeshFormat");
  }

  void add_node(long long tag, const std::vector<std::string_view>& t, std::size_t at) {
    if (t.size() < at + 3) fail("a node needs x y z");
    const Vec3 p(number(t[at], "coordinate"), number(t[at + 1], "coordinate"), number(t[at + 2], "coordinate"));
    if (!node_id_.emplace(tag, static_cast<Index>(mesh_.nodes.size())).second)
      fail("node " + std::to_string(tag) + " is defined twice");
    mesh_.nodes.push_back(p);
  }

  void nodes_2() {
    const std::size_t n = count(row("the node count")[0], "node count");
    for (std::size_t k = 0; k < n; ++k) {
      const auto t = row("a node (tag x y z)");
      if (t.size() != 4) fail("a node line is: tag x y z");
      add_node(integer(t[0], "node tag"), t, 1);
    }
    end("Nodes");
  }

  void nodes_4() {
    const auto h = row("the nodes' header (blocks nodes min-tag max-tag)");
    if (h.size() != 4) fail("the $Nodes header is: numEntityBlocks numNodes minNodeTag maxNodeTag");
    const std::size_t blocks = count(h[0], "block count"), total = count(h[1], "node count");
    std::size_t read = 0;
    for (std::size_t b = 0; b < blocks; ++b) {
      const auto e = row("a node block header (dim tag parametric count)");
      if (e.size() != 4) fail("a node block header is: entityDim entityTag parametric numNodesInBlock");
      const std::size_t n = count(e[3], "node count");
      if (read + n > total) fail("the node blocks hold more nodes than the header's " + std::to_string(total));
      std::vector<long long> tags(n);
      for (auto& tag : tags) {
        const auto t = row("a node tag");
        if (t.size() != 1) fail("a node block lists one node tag a line, then the coordinates");
        tag = integer(t[0], "node tag");
      }
      for (const long long tag : tags) add_node(tag, row("node coordinates (x y z)"), 0);
      read += n;
    }
    if (read != total) fail("the node blocks hold " + std::to_string(read) + " nodes, the header says " + std::to_string(total));
    end("Nodes");
  }

  void add_tet(const std::vector<std::string_view>& t, std::size_t at) {
    std::array<Index, 4> tet{};
    for (int c = 0; c < 4; ++c) {
      const long long tag = integer(t[at + static_cast<std::size_t>(c)], "node tag");
      const auto it = node_id_.find(tag);
      if (it == node_id_.end()) fail("tetrahedron node " + std::to_string(tag) + " is not in $Nodes");
      tet[static_cast<std::size_t>(c)] = it->second;
    }
    mesh_.tets.push_back(tet);
    mesh_.tet_line.push_back(lines_.number());
  }

  void check_type(long long type) const {
    if (type != 4 && is_volume_element(type))
      fail("element type " + std::to_string(type) +
           " is a volume element other than the four-node tetrahedron (type 4): mesh with first-order "
           "tetrahedra only");
  }

  void elements_2() {
    const std::size_t n = count(row("the element count")[0], "element count");
    for (std::size_t k = 0; k < n; ++k) {
      const auto t = row("an element (tag type ntags tags… nodes…)");
      if (t.size() < 3) fail("an element line is: tag type ntags tags… nodes…");
      const long long type = integer(t[1], "element type");
      const std::size_t tags = count(t[2], "tag count");
      check_type(type);
      if (type != 4) continue;
      if (t.size() != 3 + tags + 4) fail("a tetrahedron (type 4) lists 4 nodes after its " + std::to_string(tags) + " tags");
      add_tet(t, 3 + tags);
    }
    end("Elements");
  }

  void elements_4() {
    const auto h = row("the elements' header (blocks elements min-tag max-tag)");
    if (h.size() != 4) fail("the $Elements header is: numEntityBlocks numElements minElementTag maxElementTag");
    const std::size_t blocks = count(h[0], "block count"), total = count(h[1], "element count");
    std::size_t read = 0;
    for (std::size_t b = 0; b < blocks; ++b) {
      const auto e = row("an element block header (dim tag type count)");
      if (e.size() != 4) fail("an element block header is: entityDim entityTag elementType numElementsInBlock");
      const long long type = integer(e[2], "element type");
      check_type(type);
      const std::size_t n = count(e[3], "element count");
      if (read + n > total) fail("the element blocks hold more elements than the header's " + std::to_string(total));
      for (std::size_t k = 0; k < n; ++k) {
        const auto t = row("an element (tag nodes…)");
        if (type == 4) {
          if (t.size() != 5) fail("a tetrahedron (type 4) line is: tag n1 n2 n3 n4");
          integer(t[0], "element tag");
          add_tet(t, 1);
        }
      }
      read += n;
    }
    if (read != total)
      fail("the element blocks hold " + std::to_string(read) + " elements, the header says " + std::to_string(total));
    end("Elements");
  }

  text::Lines lines_;
  const std::string& name_;
  int version_ = 0;
  TetMesh mesh_;
  std::unordered_map<long long, Index> node_id_;
};

}  // namespace

TetMesh parse_gmsh(std::string_view text, const std::string& name) { return GmshReader(text, name).read(); }

}  // namespace qbond
