// The docs' key tables (scene_docs.hpp): each written from the declaration the scene reader reads
// by, so that a new law, heuristic or body type reaches the docs by `qbond key-tables`, not by hand.
#include <algorithm>
#include <stdexcept>

#include "qbond/io/scene.hpp"
#include "qbond/io/scene_docs.hpp"
#include "qbond/laws/registry.hpp"

namespace qbond {

namespace {

// A table cell: a '|' inside would end it.
std::string cell(std::string_view text) {
  std::string s;
  for (char c : text) {
    if (c == '|') s += '\\';
    s += c;
  }
  return s;
}

std::string row(std::initializer_list<std::string> cells) {
  std::string r = "|";
  for (const std::string& c : cells) {
    if (!c.empty()) r.append(" ").append(c);
    r += " |";
  }
  return r + "\n";
}

// `key`, appended (GCC 12 warns, wrongly, of overlapping copies in "literal" + std::string).
std::string code(std::string_view key) {
  std::string s = "`";
  return s.append(key).append("`");
}

// The items joined by ", ".
std::string listed(const std::vector<std::string>& items) {
  std::string s;
  for (const std::string& i : items) s.append(s.empty() ? "" : ", ").append(i);
  return s;
}

// "Force laws": per law its strength, the modulus that calibrates it, then its shape parameters.
std::string law_table() {
  std::string t = row({"law", "key", "unit", "default", "meaning"}) + "|---|---|---|---|---|\n";
  for (const LawInfo& l : all_laws()) {
    const LawParam& k = l.strength;
    t += row({code(l.name), code(k.key), cell(k.unit),
              l.calibrated_by_modulus ? std::string("one of ").append(listed({code(k.key), "`youngs_modulus`"}))
                                      : std::string("required"),
              cell(std::string(k.doc) + ": " + std::string(l.doc))});
    if (l.calibrated_by_modulus)
      t += row({code(l.name), "`youngs_modulus`", "Pa", "",
                std::string("E, calibrates ").append(code(k.key)).append(" ([materials.md](materials.md))")});
    for (const LawParam& p : l.shape)
      t += row({code(l.name), code(p.key), cell(p.unit), p.fallback.empty() ? "required" : cell(p.fallback),
                cell(std::string(p.doc) + (p.note.empty() ? "" : ". " + std::string(p.note)))});
  }
  return t;
}

// A section's types and the keys each accepts besides those every type takes (`type`, and a
// body's placement), as the reader names them in its errors.
std::string key_table(const std::vector<SceneType>& types) {
  std::string t = "| type | keys |\n|---|---|\n";
  for (const SceneType& s : types) {
    std::vector<std::string> keys;
    for (std::string_view k : s.keys)
      if (!std::all_of(types.begin(), types.end(), [&](const SceneType& o) {
            return std::find(o.keys.begin(), o.keys.end(), k) != o.keys.end();
          }))
        keys.push_back(code(k));
    t += row({code(s.type), listed(keys)});
  }
  return t;
}

// The heuristic types and what each does.
std::string heuristic_type_table() {
  std::string t = "| type | what it does |\n|---|---|\n";
  for (const SceneType& s : heuristic_types()) t += row({code(s.type), cell(s.doc)});
  return t;
}

}  // namespace

std::vector<std::string_view> scene_doc_table_names() { return {"laws", "heuristics", "heuristic_types", "bodies"}; }

std::string scene_doc_table(std::string_view name) {
  if (name == "laws") return law_table();
  if (name == "heuristics") return key_table(heuristic_types());
  if (name == "heuristic_types") return heuristic_type_table();
  if (name == "bodies") return key_table(body_types());
  std::vector<std::string> known;
  for (std::string_view n : scene_doc_table_names()) known.emplace_back(n);
  throw std::invalid_argument(std::string("unknown key table '").append(name).append("' (known: ").append(listed(known)).append(")"));
}

std::string with_scene_doc_tables(std::string_view markdown, std::string_view file) {
  static constexpr std::string_view open = "<!-- keys:", close = " -->";
  std::string out;
  std::size_t at = 0;
  auto line_of = [&](std::size_t pos) {
    return std::to_string(1 + std::count(markdown.begin(), markdown.begin() + static_cast<std::ptrdiff_t>(pos), '\n'));
  };
  for (std::size_t start; (start = markdown.find(open, at)) != std::string_view::npos;) {
    const std::size_t name_end = markdown.find(close, start);
    const std::size_t line_end = markdown.find('\n', start);
    if (name_end == std::string_view::npos || line_end == std::string_view::npos || name_end > line_end)
      throw std::invalid_argument(std::string(file) + ":" + line_of(start) + ": a `<!-- keys:NAME -->` marker needs a line of its own");
    const std::string name(markdown.substr(start + open.size(), name_end - start - open.size()));
    const std::string end_marker = "<!-- /keys:" + name + " -->";
    const std::size_t end = markdown.find(end_marker, line_end);
    if (end == std::string_view::npos)
      throw std::invalid_argument(std::string(file) + ":" + line_of(start) + ": key table '" + name + "' has no " + end_marker);
    std::string table;
    try {
      table = scene_doc_table(name);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string(file) + ":" + line_of(start) + ": " + e.what());
    }
    out.append(markdown.substr(at, line_end + 1 - at));
    out += table;
    at = end;
  }
  out.append(markdown.substr(at));
  return out;
}

}  // namespace qbond
