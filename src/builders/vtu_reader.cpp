// VTK XML UnstructuredGrid (.vtu) files with ASCII data as tetrahedral meshes (tet_mesh.hpp).
#include <algorithm>

#include "io/text_fields.hpp"
#include "qbond/builders/tet_mesh.hpp"

namespace qbond {

namespace {

using text::malformed;

/// VTK cell types: 10 the tetra; 1–9 vertices, lines, triangles, polygons, pixels and quads (a
/// volume mesh's boundary groups); 11–16 and the higher-order ones ≥ 21 other cells.
bool is_skipped_cell(long long type) { return type >= 1 && type <= 9; }

class VtuReader {
 public:
  VtuReader(std::string_view text, const std::string& name) : text_(text), name_(name) {}

  TetMesh read() {
    const std::size_t grid = tag_at(0, "UnstructuredGrid");
    if (grid == npos) malformed(name_, 0, "no <UnstructuredGrid> element: not a VTK unstructured grid (.vtu)");
    if (const std::string f = attribute(text_.find("<VTKFile"), "type"); !f.empty() && f != "UnstructuredGrid")
      fail(0, "VTKFile type '" + f + "' is not UnstructuredGrid");
    const std::size_t piece = tag_at(grid, "Piece");
    if (piece == npos) fail(grid, "no <Piece> in the UnstructuredGrid");
    if (tag_at(piece + 1, "Piece") != npos) fail(tag_at(piece + 1, "Piece"), "more than one <Piece>: not read");
    const std::size_t points = count(piece, "NumberOfPoints"), cells = count(piece, "NumberOfCells");

    const std::size_t pts = tag_at(piece, "Points");
    if (pts == npos) fail(piece, "no <Points> in the Piece");
    const std::vector<double> xyz = array_numbers(tag_at(pts, "DataArray"), "Points");
    if (xyz.size() != 3 * points)
      fail(pts, "<Points> holds " + std::to_string(xyz.size()) + " numbers, not 3 × NumberOfPoints = " +
                    std::to_string(3 * points));
    TetMesh mesh;
    mesh.nodes.reserve(points);
    for (std::size_t i = 0; i < points; ++i) mesh.nodes.emplace_back(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);

    const std::size_t cel = tag_at(piece, "Cells");
    if (cel == npos) fail(piece, "no <Cells> in the Piece");
    const std::size_t conn_at = named_array(cel, "connectivity"), off_at = named_array(cel, "offsets"),
                      type_at = named_array(cel, "types");
    const std::vector<double> conn = array_numbers(conn_at, "connectivity");
    const std::vector<double> offsets = array_numbers(off_at, "offsets");
    const std::vector<double> types = array_numbers(type_at, "types");
    if (offsets.size() != cells || types.size() != cells)
      fail(cel, "the cells' offsets (" + std::to_string(offsets.size()) + ") and types (" +
                    std::to_string(types.size()) + ") must number NumberOfCells = " + std::to_string(cells));
    const std::size_t conn_line = line_of(conn_at);
    std::size_t start = 0;
    for (std::size_t c = 0; c < cells; ++c) {
      const double end = offsets[c];
      if (!(end == std::floor(end) && end >= static_cast<double>(start) && end <= static_cast<double>(conn.size())))
        fail(off_at, "offset " + std::to_string(c) + " (" + text_number(end) +
                         ") is not an integer between the previous offset and the connectivity's length " +
                         std::to_string(conn.size()));
      const auto stop = static_cast<std::size_t>(end);
      const double type = types[c];
      if (type == 10) {
        if (stop - start != 4) fail(off_at, "tetra cell " + std::to_string(c) + " has " + std::to_string(stop - start) + " points, not 4");
        std::array<Index, 4> tet{};
        for (std::size_t k = 0; k < 4; ++k) {
          const double v = conn[start + k];
          if (!(v == std::floor(v) && v >= 0 && v < static_cast<double>(points)))
            fail(conn_at, "cell " + std::to_string(c) + " names point " + text_number(v) + ", not one of the " +
                              std::to_string(points) + " points (0-based)");
          tet[k] = static_cast<Index>(v);
        }
        mesh.tets.push_back(tet);
        mesh.tet_line.push_back(conn_line);
      } else if (!(type == std::floor(type) && type >= 0 && type < 256 &&  // VTK's cell types fit a byte
                   is_skipped_cell(static_cast<long long>(type)))) {
        fail(type_at, "cell " + std::to_string(c) + " has VTK type " + text_number(type) +
                          ": only tetra cells (10) make a body (vertex, line, triangle and quad cells are skipped)");
      }
      start = stop;
    }
    if (mesh.tets.empty()) malformed(name_, 0, "no tetra cells (VTK type 10): not a tetrahedral volume mesh");
    return mesh;
  }

 private:
  static constexpr std::size_t npos = std::string_view::npos;

  std::size_t line_of(std::size_t pos) const {
    return 1 + static_cast<std::size_t>(std::count(text_.begin(), text_.begin() + static_cast<std::ptrdiff_t>(std::min(pos, text_.size())), '\n'));
  }
  [[noreturn]] void fail(std::size_t pos, const std::string& rule) const {
    malformed(name_, pos == npos ? 0 : line_of(pos), rule);
  }
  static std::string text_number(double v) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
  }

  /// Where the next opening tag <NAME (followed by a blank, '>' or '/') starts at or after `from`.
  std::size_t tag_at(std::size_t from, std::string_view tag) const {
    std::string open(1, '<');  // appended: GCC 12 warns (-Wrestrict) falsely on "<" + string
    open.append(tag);
    for (std::size_t p = text_.find(open, from); p != npos; p = text_.find(open, p + 1)) {
      const std::size_t after = p + open.size();
      if (after < text_.size() && (text::is_blank(text_[after]) || text_[after] == '\n' || text_[after] == '>' || text_[after] == '/'))
        return p;
    }
    return npos;
  }
  /// The value of attribute `key` in the tag starting at `at` ("" when it has none).
  std::string attribute(std::size_t at, std::string_view key) const {
    if (at == npos) return "";
    const std::size_t close = text_.find('>', at);
    const std::string_view tag = text_.substr(at, close == npos ? npos : close - at);
    for (std::size_t p = tag.find(key); p != npos; p = tag.find(key, p + 1)) {
      const bool starts = p > 0 && (text::is_blank(tag[p - 1]) || tag[p - 1] == '\n');
      std::size_t q = p + key.size();
      while (q < tag.size() && text::is_blank(tag[q])) ++q;
      if (!starts || q >= tag.size() || tag[q] != '=') continue;
      ++q;
      while (q < tag.size() && text::is_blank(tag[q])) ++q;
      if (q >= tag.size() || (tag[q] != '"' && tag[q] != '\'')) fail(at + p, "attribute " + std::string(key) + " is not quoted");
      const std::size_t end = tag.find(tag[q], q + 1);
      if (end == npos) fail(at + p, "attribute " + std::string(key) + "'s value is not closed");
      return std::string(tag.substr(q + 1, end - q - 1));
    }
    return "";
  }
  std::size_t count(std::size_t at, const char* key) const {
    const std::string v = attribute(at, key);
    long long n = 0;
    if (!text::parse_long(v, n) || n < 0 || n > 50'000'000)
      fail(at, std::string("<Piece ") + key + "> must be a count in [0, 5e7], got " + text::quoted(v));
    return static_cast<std::size_t>(n);
  }
  /// The DataArray named `name` in the element starting at `at`.
  std::size_t named_array(std::size_t at, const std::string& name) const {
    const std::size_t close = text_.find("</Cells>", at);
    for (std::size_t p = tag_at(at, "DataArray"); p != npos && p < close; p = tag_at(p + 1, "DataArray"))
      if (attribute(p, "Name") == name) return p;
    fail(at, "<Cells> has no DataArray Name=\"" + name + "\"");
  }
  /// The numbers of the ASCII DataArray starting at `at`.
  std::vector<double> array_numbers(std::size_t at, const std::string& what) const {
    if (at == npos) fail(at, "no DataArray for " + what);
    const std::string format = attribute(at, "format");
    if (format != "ascii")
      fail(at, what + "'s DataArray has format '" + format +
                   "': only ASCII arrays are read (ParaView: File > Save Data, Data Mode ASCII)");
    const std::size_t open_end = text_.find('>', at);
    if (open_end == npos) fail(at, what + "'s DataArray tag is not closed");
    if (text_[open_end - 1] == '/') return {};
    const std::size_t close = text_.find("</DataArray>", open_end);
    if (close == npos) fail(at, what + "'s DataArray has no </DataArray>");
    std::vector<double> out;
    std::size_t p = open_end + 1;
    while (p < close) {
      while (p < close && (text::is_blank(text_[p]) || text_[p] == '\n')) ++p;
      const std::size_t s = p;
      while (p < close && !(text::is_blank(text_[p]) || text_[p] == '\n')) ++p;
      if (p == s) break;
      double v = 0;
      if (!text::parse_double(text_.substr(s, p - s), v))
        fail(s, what + " value " + text::quoted(text_.substr(s, p - s)) + " is not a finite number");
      out.push_back(v);
    }
    return out;
  }

  std::string_view text_;
  const std::string& name_;
};

}  // namespace

TetMesh parse_vtu(std::string_view text, const std::string& name) { return VtuReader(text, name).read(); }

}  // namespace qbond
