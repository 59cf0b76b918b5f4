// CSV tables of quanta and bonds (csv_table.hpp).
#include "qbond/builders/csv_table.hpp"

#include <algorithm>
#include <map>
#include <set>

#include "io/text_fields.hpp"

namespace qbond {

namespace {

using text::malformed;

/// The comma-separated fields of a line, each without surrounding blanks.
std::vector<std::string_view> fields(std::string_view line) {
  std::vector<std::string_view> out;
  for (;;) {
    const std::size_t comma = line.find(',');
    out.push_back(text::trim(line.substr(0, comma)));
    if (comma == std::string_view::npos) return out;
    line.remove_prefix(comma + 1);
  }
}

/// A table's rows after its header: which column holds each named quantity (-1: none), and the
/// rows' fields with their line numbers.
struct Table {
  std::map<std::string, int> column;
  std::size_t header_line = 0;  ///< the header's (or the first row's) line
  std::vector<std::pair<std::size_t, std::vector<std::string_view>>> rows;
};

/// Splits `text` into rows; a first row whose first field is not a number is the header, whose
/// names must be among `names`; without one, `by_count` gives the names for each accepted column
/// count.
Table table(std::string_view text, const std::string& name, const std::vector<std::string>& names,
            const std::map<std::size_t, std::vector<std::string>>& by_count) {
  Table t;
  text::Lines lines(text);
  std::string_view line;
  std::size_t width = 0;
  bool first = true;
  while (lines.next(line)) {
    const std::string_view trimmed = text::trim(line);
    if (trimmed.empty() || trimmed.front() == '#') continue;
    auto f = fields(trimmed);
    if (first) {
      first = false;
      t.header_line = lines.number();
      double ignored;
      if (!text::parse_double(f[0], ignored)) {  // a header
        for (std::size_t c = 0; c < f.size(); ++c) {
          std::string key(f[c]);
          std::transform(key.begin(), key.end(), key.begin(), [](unsigned char ch) { return std::tolower(ch); });
          if (std::find(names.begin(), names.end(), key) == names.end()) {
            std::string all;
            for (const auto& n : names) all.append(all.empty() ? "" : ", ").append(n);
            malformed(name, lines.number(), "unknown column " + text::quoted(f[c]) + " in the header (accepted: " + all + ")");
          }
          if (!t.column.emplace(key, static_cast<int>(c)).second)
            malformed(name, lines.number(), "column " + text::quoted(f[c]) + " appears twice in the header");
        }
        width = f.size();
        continue;
      }
      const auto it = by_count.find(f.size());
      if (it == by_count.end()) {
        std::string counts;
        for (const auto& [n, cols] : by_count) {
          std::string list;
          for (const auto& c : cols) list.append(list.empty() ? "" : ",").append(c);
          counts.append(counts.empty() ? "" : "; ").append(std::to_string(n)).append(": ").append(list);
        }
        malformed(name, lines.number(),
                  "a row without a header has " + std::to_string(f.size()) + " fields; accepted (" + counts +
                      "), or name the columns in a header row");
      }
      for (std::size_t c = 0; c < it->second.size(); ++c) t.column.emplace(it->second[c], static_cast<int>(c));
      width = f.size();
    }
    if (f.size() != width)
      malformed(name, lines.number(),
                "has " + std::to_string(f.size()) + " fields, the table's rows have " + std::to_string(width));
    t.rows.emplace_back(lines.number(), std::move(f));
  }
  return t;
}

double number(const std::string& name, std::size_t line, std::string_view f, const char* column) {
  double v = 0;
  if (!text::parse_double(f, v))
    malformed(name, line, std::string("column ") + column + ": " + text::quoted(f) + " is not a finite number");
  return v;
}

}  // namespace

CsvQuanta parse_quanta_csv(std::string_view text, const std::string& name) {
  const Table t = table(text, name, {"x", "y", "z", "mass", "vx", "vy", "vz"},
                        {{3, {"x", "y", "z"}},
                         {4, {"x", "y", "z", "mass"}},
                         {6, {"x", "y", "z", "vx", "vy", "vz"}},
                         {7, {"x", "y", "z", "mass", "vx", "vy", "vz"}}});
  if (t.rows.empty()) malformed(name, 0, "no rows: a quanta table needs at least one");
  for (const char* c : {"x", "y", "z"})
    if (!t.column.contains(c)) malformed(name, t.header_line, std::string("the header has no column '") + c + "'");
  const int nv = static_cast<int>(t.column.contains("vx")) + t.column.contains("vy") + t.column.contains("vz");
  if (nv != 0 && nv != 3) malformed(name, t.header_line, "give all three velocity columns vx, vy, vz or none");
  const bool has_mass = t.column.contains("mass");
  CsvQuanta q;
  auto at = [&](const std::vector<std::string_view>& f, const char* c) { return f[static_cast<std::size_t>(t.column.at(c))]; };
  for (const auto& [line, f] : t.rows) {
    q.x.emplace_back(number(name, line, at(f, "x"), "x"), number(name, line, at(f, "y"), "y"), number(name, line, at(f, "z"), "z"));
    if (has_mass) {
      const double m = number(name, line, at(f, "mass"), "mass");
      if (!(m > 0)) malformed(name, line, "column mass: must be > 0, got " + text::quoted(at(f, "mass")));
      q.mass.push_back(m);
    }
    if (nv == 3)
      q.v.emplace_back(number(name, line, at(f, "vx"), "vx"), number(name, line, at(f, "vy"), "vy"),
                       number(name, line, at(f, "vz"), "vz"));
  }
  return q;
}

CsvBonds parse_bonds_csv(std::string_view text, const std::string& name, std::size_t quanta) {
  const Table t = table(text, name, {"i", "j", "material"}, {{2, {"i", "j"}}, {3, {"i", "j", "material"}}});
  if (t.rows.empty()) return {};  // an empty table: no bonds
  for (const char* c : {"i", "j"})
    if (!t.column.contains(c)) malformed(name, t.header_line, std::string("the header has no column '") + c + "'");
  const bool has_material = t.column.contains("material");
  CsvBonds b;
  std::set<std::pair<Index, Index>> seen;
  auto at = [&](const std::vector<std::string_view>& f, const char* c) { return f[static_cast<std::size_t>(t.column.at(c))]; };
  for (const auto& [line, f] : t.rows) {
    Index end[2];
    for (int e = 0; e < 2; ++e) {
      const char* c = e ? "j" : "i";
      long long v = 0;
      if (!text::parse_long(at(f, c), v) || v < 0 || static_cast<std::size_t>(v) >= quanta)
        malformed(name, line, std::string("column ") + c + ": " + text::quoted(at(f, c)) +
                                  " is not a row of the quanta table (0-based, " + std::to_string(quanta) + " rows)");
      end[e] = static_cast<Index>(v);
    }
    if (end[0] == end[1]) malformed(name, line, "bonds quanta " + std::to_string(end[0]) + " to itself");
    if (!seen.emplace(std::min(end[0], end[1]), std::max(end[0], end[1])).second)
      malformed(name, line, "bonds " + std::to_string(end[0]) + " and " + std::to_string(end[1]) + " a second time");
    b.ends.emplace_back(end[0], end[1]);
    if (has_material) {
      if (at(f, "material").empty()) malformed(name, line, "column material: empty");
      b.material.emplace_back(at(f, "material"));
    }
  }
  return b;
}

}  // namespace qbond
