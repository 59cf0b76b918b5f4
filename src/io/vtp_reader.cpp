#include "qbond/io/vtp_reader.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <optional>

#include "qbond/io/files.hpp"

namespace qbond {
namespace {

namespace fs = std::filesystem;

/// One XML tag: its name (with a leading '/' for a closing tag) and attributes.
struct Tag {
  std::string name;
  std::map<std::string, std::string> attr;
};

/// Splits the XML text before the appended block into tags (no text content is needed).
std::vector<Tag> tags_of(std::string_view xml, const std::string& file) {
  std::vector<Tag> tags;
  std::size_t at = 0;
  while ((at = xml.find('<', at)) != std::string_view::npos) {
    const std::size_t end = xml.find('>', at);
    if (end == std::string_view::npos) throw VtkReadError(file + ": unterminated XML tag");
    std::string_view body = xml.substr(at + 1, end - at - 1);
    at = end + 1;
    if (body.empty() || body[0] == '?' || body[0] == '!') continue;
    if (body.back() == '/') body.remove_suffix(1);
    Tag t;
    std::size_t k = body.find_first_of(" \t\r\n");
    t.name = std::string(body.substr(0, k));
    while (k != std::string_view::npos && k < body.size()) {
      k = body.find_first_not_of(" \t\r\n", k);
      if (k == std::string_view::npos) break;
      const std::size_t eq = body.find('=', k);
      if (eq == std::string_view::npos || eq + 1 >= body.size() || body[eq + 1] != '"')
        throw VtkReadError(file + ": malformed attribute in <" + t.name + ">");
      const std::size_t close = body.find('"', eq + 2);
      if (close == std::string_view::npos) throw VtkReadError(file + ": unterminated attribute in <" + t.name + ">");
      t.attr[std::string(body.substr(k, eq - k))] = std::string(body.substr(eq + 2, close - eq - 2));
      k = close + 1;
    }
    tags.push_back(std::move(t));
  }
  return tags;
}

/// The XML entities vtk.hpp escapes, unescaped.
std::string unescape(const std::string& s) {
  std::string out;
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (s[k] != '&') {
      out += s[k];
      continue;
    }
    static const std::pair<const char*, char> kEntities[] = {{"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
    bool known = false;
    for (const auto& [name, c] : kEntities)
      if (s.compare(k, std::strlen(name), name) == 0) {
        out += c, k += std::strlen(name) - 1, known = true;
        break;
      }
    if (!known) out += '&';
  }
  return out;
}

double number(const std::map<std::string, std::string>& attr, const std::string& key, const std::string& where) {
  const auto it = attr.find(key);
  if (it == attr.end()) throw VtkReadError(where + ": missing " + key);
  try {
    std::size_t used = 0;
    const double v = std::stod(it->second, &used);
    if (used != it->second.size() || !std::isfinite(v)) throw std::invalid_argument(it->second);
    return v;
  } catch (const std::exception&) {
    throw VtkReadError(where + ": " + key + " is not a number: \"" + it->second + "\"");
  }
}

/// A count attribute: an integer in [0, 2^40] (far above any frame this program can write).
std::size_t count_of(const std::map<std::string, std::string>& attr, const std::string& key, const std::string& where) {
  const double v = number(attr, key, where);
  if (!(v >= 0 && v <= 1099511627776.0 && v == std::floor(v))) throw VtkReadError(where + ": " + key + " must be a count");
  return static_cast<std::size_t>(v);
}

/// A data array declared in the XML: where its bytes are in the appended block.
struct ArrayRef {
  std::string type;
  int components = 1;
  std::uint64_t offset = 0;
};

/// The values of an appended array, converted to double, checked to hold `expected` values.
std::vector<double> values(std::string_view block, const ArrayRef& a, std::size_t expected, const std::string& where) {
  std::size_t size = 0;
  if (a.type == "Float64" || a.type == "Int64" || a.type == "UInt64") size = 8;
  else if (a.type == "Float32" || a.type == "Int32" || a.type == "UInt32") size = 4;
  else if (a.type == "Int16" || a.type == "UInt16") size = 2;
  else if (a.type == "Int8" || a.type == "UInt8") size = 1;
  else throw VtkReadError(where + ": unsupported type \"" + a.type + "\"");
  std::uint64_t bytes = 0;
  if (a.offset > block.size() || block.size() - a.offset < sizeof bytes) throw VtkReadError(where + ": offset past the end of the data");
  std::memcpy(&bytes, block.data() + a.offset, sizeof bytes);
  if (bytes != static_cast<std::uint64_t>(expected) * size)
    throw VtkReadError(where + ": holds " + std::to_string(bytes) + " bytes, expected " + std::to_string(expected) + " values of " +
                       a.type);
  if (block.size() - a.offset - sizeof bytes < bytes) throw VtkReadError(where + ": data cut short");
  const char* p = block.data() + a.offset + sizeof bytes;
  std::vector<double> out(expected);
  auto convert = [&]<class T>(T) {
    for (std::size_t k = 0; k < expected; ++k) {
      T v;
      std::memcpy(&v, p + k * sizeof(T), sizeof(T));
      out[k] = static_cast<double>(v);
    }
  };
  if (a.type == "Float64") convert(double{});
  else if (a.type == "Float32") convert(float{});
  else if (a.type == "Int64") convert(std::int64_t{});
  else if (a.type == "UInt64") convert(std::uint64_t{});
  else if (a.type == "Int32") convert(std::int32_t{});
  else if (a.type == "UInt32") convert(std::uint32_t{});
  else if (a.type == "Int16") convert(std::int16_t{});
  else if (a.type == "UInt16") convert(std::uint16_t{});
  else if (a.type == "Int8") convert(std::int8_t{});
  else convert(std::uint8_t{});
  return out;
}

std::string read_text(const fs::path& path) {
  try {
    return read_file(path, std::uint64_t{1} << 40);
  } catch (const std::exception& e) {
    throw VtkReadError(e.what());
  }
}

/// A .vtp file's frame, and a piece's point ids, ghost flags (vtkGhostType) and lines' bond ids
/// (each empty when the file has none).
struct PieceFrame {
  VtpFrame frame;
  std::vector<double> id, ghost, bond;
};

PieceFrame read_piece(const fs::path& path, const std::string& text) {
  const std::string file = path.string();
  // The appended block starts after the '_' that follows <AppendedData ...>.
  const std::size_t appended = text.find("<AppendedData");
  if (appended == std::string::npos) throw VtkReadError(file + ": no <AppendedData> block (only binary appended frames are read)");
  const std::size_t open_end = text.find('>', appended);
  const std::size_t underscore = open_end == std::string::npos ? open_end : text.find('_', open_end);
  if (underscore == std::string::npos) throw VtkReadError(file + ": <AppendedData> without its '_' marker");
  const std::string_view block = std::string_view(text).substr(underscore + 1);
  const std::vector<Tag> tags = tags_of(std::string_view(text).substr(0, open_end + 1), file);

  std::optional<Tag> piece;
  bool polydata = false;
  std::string section;  // PointData, CellData, Points, Verts or Lines
  std::map<std::string, ArrayRef> arrays;  // "section/name"
  for (const Tag& t : tags) {
    if (t.name == "VTKFile") {
      polydata = t.attr.count("type") && t.attr.at("type") == "PolyData";
      if (!polydata) throw VtkReadError(file + ": not a VTK PolyData file");
      if (t.attr.count("byte_order") && t.attr.at("byte_order") != "LittleEndian")
        throw VtkReadError(file + ": only little-endian data is read");
      if (!t.attr.count("header_type") || t.attr.at("header_type") != "UInt64")
        throw VtkReadError(file + ": only UInt64 array headers are read");
      if (t.attr.count("compressor")) throw VtkReadError(file + ": compressed data is not read");
    } else if (t.name == "Piece") {
      if (piece) throw VtkReadError(file + ": more than one <Piece>");
      piece = t;
    } else if (t.name == "PointData" || t.name == "CellData" || t.name == "Points" || t.name == "Verts" || t.name == "Lines" ||
               t.name == "Polys" || t.name == "Strips") {
      section = t.name;
    } else if (!t.name.empty() && t.name[0] == '/') {
      section.clear();
    } else if (t.name == "DataArray") {
      const std::string name = t.attr.count("Name") ? unescape(t.attr.at("Name")) : "";
      const std::string where = file + ": " + section + " array \"" + name + "\"";
      if (!t.attr.count("format") || t.attr.at("format") != "appended")
        throw VtkReadError(where + ": only format=\"appended\" is read");
      ArrayRef a;
      a.type = t.attr.count("type") ? t.attr.at("type") : "";
      a.components = t.attr.count("NumberOfComponents") ? static_cast<int>(count_of(t.attr, "NumberOfComponents", where)) : 1;
      a.offset = count_of(t.attr, "offset", where);
      arrays[section + "/" + name] = a;
    }
  }
  if (!polydata) throw VtkReadError(file + ": not a VTK PolyData file");
  if (!piece) throw VtkReadError(file + ": no <Piece>");
  const std::string where = file + ": <Piece>";
  const std::size_t n = count_of(piece->attr, "NumberOfPoints", where);
  const std::size_t verts = piece->attr.count("NumberOfVerts") ? count_of(piece->attr, "NumberOfVerts", where) : 0;
  const std::size_t nlines = piece->attr.count("NumberOfLines") ? count_of(piece->attr, "NumberOfLines", where) : 0;

  auto find = [&](const std::string& key) -> const ArrayRef* {
    const auto it = arrays.find(key);
    return it == arrays.end() ? nullptr : &it->second;
  };
  auto read = [&](const std::string& key, std::size_t expected, int components) -> std::vector<double> {
    const ArrayRef* a = find(key);
    if (!a) return {};
    const std::string at = file + ": array " + key;
    if (a->components != components)
      throw VtkReadError(at + ": has " + std::to_string(a->components) + " components, expected " + std::to_string(components));
    return values(block, *a, expected * static_cast<std::size_t>(components), at);
  };
  auto vec3s = [](const std::vector<double>& d) {
    std::vector<Vec3> out(d.size() / 3);
    for (std::size_t k = 0; k < out.size(); ++k) out[k] = Vec3(d[3 * k], d[3 * k + 1], d[3 * k + 2]);
    return out;
  };

  PieceFrame out;
  VtpFrame& f = out.frame;
  out.id = read("PointData/id", n, 1);
  out.ghost = read("PointData/vtkGhostType", n, 1);
  // The points array has no name.
  const std::vector<double> points = read("Points/", n, 3);
  if (points.size() != 3 * n) throw VtkReadError(file + ": no <Points> array");
  f.x = vec3s(points);
  f.v = vec3s(read("PointData/velocity", n, 3));
  if (f.v.empty()) f.v.assign(n, Vec3::Zero());
  f.mass = read("PointData/mass", n, 1);
  f.von_mises = read("PointData/von_mises", n, 1);
  f.body.assign(n, 0), f.kinematic.assign(n, 0);
  const std::vector<double> body = read("PointData/body", n, 1), kinematic = read("PointData/kinematic", n, 1);
  for (std::size_t k = 0; k < body.size(); ++k) f.body[k] = static_cast<std::int32_t>(body[k]);
  for (std::size_t k = 0; k < kinematic.size(); ++k) f.kinematic[k] = kinematic[k] != 0;

  if (nlines > 0) {
    const std::vector<double> off = read("Lines/offsets", nlines, 1);
    if (off.size() != nlines) throw VtkReadError(file + ": <Lines> without offsets");
    if (!(off.back() == 2.0 * static_cast<double>(nlines)))
      throw VtkReadError(file + ": <Lines> offsets must end at twice the line count (two-point lines)");
    const std::vector<double> conn = read("Lines/connectivity", 2 * nlines, 1);
    if (conn.size() != 2 * nlines) throw VtkReadError(file + ": <Lines> without connectivity");
    double prev = 0;
    f.lines.reserve(nlines);
    for (std::size_t c = 0; c < nlines; ++c) {
      if (off[c] != prev + 2) throw VtkReadError(file + ": line " + std::to_string(c) + " is not a two-point line");
      const double a = conn[static_cast<std::size_t>(prev)], b = conn[static_cast<std::size_t>(prev) + 1];
      if (!(a >= 0 && a < static_cast<double>(n) && b >= 0 && b < static_cast<double>(n)))
        throw VtkReadError(file + ": line " + std::to_string(c) + " names a point outside [0, " + std::to_string(n) + ")");
      f.lines.emplace_back(static_cast<Index>(a), static_cast<Index>(b));
      prev = off[c];
    }
  }
  // Cell arrays cover the vertex cells first, then the lines (vtk.hpp): keep the lines' values.
  for (auto [key, to] : {std::pair{"CellData/strain", &f.strain}, std::pair{"CellData/tension", &f.tension},
                         std::pair{"CellData/bond", &out.bond}}) {
    std::vector<double> cells = read(key, verts + nlines, 1);
    if (!cells.empty()) to->assign(cells.begin() + static_cast<std::ptrdiff_t>(verts), cells.end());
  }
  return out;
}

/// A .pvtp file's frame: its pieces (write_vtp_piece's) put together as write_vtp writes a whole
/// frame, point k the quanta of id k (each owned by one piece), lines in bond-id order.
VtpFrame read_pieces(const fs::path& path, const std::string& text) {
  const std::string file = path.string();
  std::vector<PieceFrame> pieces;
  for (const Tag& t : tags_of(text, file))
    if (t.name == "Piece") {
      if (!t.attr.count("Source")) throw VtkReadError(file + ": a <Piece> without its Source");
      const fs::path source = path.parent_path() / unescape(t.attr.at("Source"));
      pieces.push_back(read_piece(source, read_text(source)));
    }
  if (pieces.empty()) throw VtkReadError(file + ": no <Piece>");
  auto missing = [&](const std::string& what) { throw VtkReadError(file + ": a piece without " + what); };
  std::size_t n = 0;
  for (const PieceFrame& p : pieces) {
    const std::size_t m = p.frame.x.size();
    if (m > 0 && (p.id.size() != m || p.ghost.size() != m)) missing("its points' id and vtkGhostType");
    if (!p.frame.lines.empty() && p.bond.size() != p.frame.lines.size()) missing("its lines' bond ids");
    for (double g : p.ghost) n += g == 0;
  }
  // An array is the frame's when every piece with points (lines) has it.
  auto all_have = [&](auto member, bool lines) {
    return std::all_of(pieces.begin(), pieces.end(), [&](const PieceFrame& p) {
      const std::size_t m = lines ? p.frame.lines.size() : p.frame.x.size();
      return m == 0 || (p.frame.*member).size() == m;
    });
  };
  VtpFrame f;
  f.x.resize(n);
  f.v.resize(n);
  f.body.resize(n);
  f.kinematic.resize(n);
  const bool mass = all_have(&VtpFrame::mass, false), von_mises = all_have(&VtpFrame::von_mises, false);
  if (mass) f.mass.resize(n);
  if (von_mises) f.von_mises.resize(n);
  std::vector<std::uint8_t> seen(n, 0);
  for (const PieceFrame& p : pieces)
    for (std::size_t k = 0; k < p.frame.x.size(); ++k) {
      if (p.ghost[k] != 0) continue;
      const double id = p.id[k];
      if (!(id >= 0 && id < static_cast<double>(n)) || seen[static_cast<std::size_t>(id)]++)
        throw VtkReadError(file + ": its pieces do not hold quanta 0 to " + std::to_string(n) + " once each (id " +
                           std::to_string(id) + ")");
      const auto q = static_cast<std::size_t>(id);
      f.x[q] = p.frame.x[k];
      f.v[q] = p.frame.v[k];
      f.body[q] = p.frame.body[k];
      f.kinematic[q] = p.frame.kinematic[k];
      if (mass) f.mass[q] = p.frame.mass[k];
      if (von_mises) f.von_mises[q] = p.frame.von_mises[k];
    }
  struct Line {
    double bond;
    Index i, j;
    double strain, tension;
  };
  const bool strain = all_have(&VtpFrame::strain, true), tension = all_have(&VtpFrame::tension, true);
  std::vector<Line> lines;
  for (const PieceFrame& p : pieces)
    for (std::size_t c = 0; c < p.frame.lines.size(); ++c) {
      const auto [a, b] = p.frame.lines[c];
      if (!(p.id[a] >= 0 && p.id[a] < static_cast<double>(n) && p.id[b] >= 0 && p.id[b] < static_cast<double>(n)))
        throw VtkReadError(file + ": bond " + std::to_string(p.bond[c]) + " ends at a quanta no piece holds");
      // A line's ends by id: a ghost end is the point its owner's piece holds.
      lines.push_back({p.bond[c], static_cast<Index>(p.id[a]), static_cast<Index>(p.id[b]),
                       strain ? p.frame.strain[c] : 0.0, tension ? p.frame.tension[c] : 0.0});
    }
  std::sort(lines.begin(), lines.end(), [](const Line& a, const Line& b) { return a.bond < b.bond; });
  for (std::size_t c = 0; c < lines.size(); ++c) {
    if (c > 0 && lines[c].bond == lines[c - 1].bond)
      throw VtkReadError(file + ": bond " + std::to_string(lines[c].bond) + " is in two pieces");
    f.lines.emplace_back(lines[c].i, lines[c].j);
    if (strain) f.strain.push_back(lines[c].strain);
    if (tension) f.tension.push_back(lines[c].tension);
  }
  return f;
}

}  // namespace

VtpFrame read_vtp(const fs::path& path) {
  const std::string text = read_text(path);
  // A ParaView parallel file lists its pieces (a run over MPI ranks with --frame-pieces).
  const std::size_t head = text.find("<VTKFile");
  if (head != std::string::npos && text.find("type=\"PPolyData\"", head) < text.find('>', head))
    return read_pieces(path, text);
  return read_piece(path, text).frame;
}

std::vector<PvdEntry> read_pvd(const fs::path& path) {
  const std::string file = path.string();
  std::string text;
  try {
    text = read_file(path);
  } catch (const std::exception& e) {
    throw VtkReadError(e.what());
  }
  std::vector<PvdEntry> out;
  bool collection = false;
  for (const Tag& t : tags_of(text, file)) {
    if (t.name == "VTKFile") collection = t.attr.count("type") && t.attr.at("type") == "Collection";
    if (t.name != "DataSet") continue;
    const std::string where = file + ": <DataSet> " + std::to_string(out.size());
    if (!t.attr.count("file")) throw VtkReadError(where + ": missing file");
    PvdEntry e;
    e.time = t.attr.count("timestep") ? number(t.attr, "timestep", where) : static_cast<double>(out.size());
    e.file = path.parent_path() / unescape(t.attr.at("file"));
    out.push_back(std::move(e));
  }
  if (!collection) throw VtkReadError(file + ": not a VTK Collection (.pvd) file");
  if (out.empty()) throw VtkReadError(file + ": the collection lists no frame");
  std::stable_sort(out.begin(), out.end(), [](const PvdEntry& a, const PvdEntry& b) { return a.time < b.time; });
  return out;
}

}  // namespace qbond
