// The docs' key tables (scene_docs.hpp): each written from the declaration the scene reader reads
// by, so that a new law, heuristic, body type, integrator or integrator option reaches the docs by
// `qbond key-tables`, not by hand.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "qbond/integrators/integrators.hpp"
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

// A number as the docs write it: 1e-6, 0.5, 20.
std::string number(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", x);
  std::string s = buffer;
  for (const char* zeros : {"e-0", "e+0"})
    if (const std::size_t at = s.find(zeros); at != std::string::npos) s.erase(at + 2, 1);
  return s;
}

// The `integrator` section: `type`, then every option with the values it takes, what it does, the
// integrators that read it (when not all) and its default.
std::string integrator_key_table() {
  using H = IntegratorOptionInfo::Holds;
  const IntegratorConfig d = default_integrator();
  std::string t = row({"key", "values", "default"}) + "|---|---|---|\n";
  std::vector<std::string> types;
  for (const IntegratorInfo& i : integrator_table()) types.push_back(code(i.key));
  t += row({code("type"), listed(types), code(to_string(d.type))});
  for (const IntegratorOptionInfo& o : integrator_options()) {
    std::string values, fallback;
    switch (o.holds) {
      case H::integer:
        values = "integer ≥ " + std::to_string(o.least);
        fallback = std::to_string(d.*o.integer);
        break;
      case H::number:
        values = o.positive ? "number > 0" : "number ≥ 0";
        if (std::isfinite(o.below)) values += ", below " + number(o.below);
        fallback = number(d.*o.number);
        break;
      case H::boolean:
        values = "boolean";
        fallback = d.*o.boolean ? "true" : "false";
        break;
      case H::name: {
        std::vector<std::string> names;
        for (std::string_view n : o.names()) names.push_back(code(n));
        values = listed(names);
        fallback = code(o.name_of(d));
        break;
      }
    }
    std::string text = values + ": " + std::string(o.doc);
    std::vector<std::string> readers;
    for (const IntegratorInfo& i : integrator_table())
      if (i.reads(o.option)) readers.push_back(code(i.key));
    if (readers.size() < integrator_table().size()) text += ". Read by " + listed(readers);
    t += row({code(o.key), cell(text), fallback});
  }
  return t;
}

}  // namespace

std::vector<std::string_view> scene_doc_table_names() {
  return {"laws", "heuristics", "heuristic_types", "bodies", "integrator"};
}

std::string scene_doc_table(std::string_view name) {
  if (name == "laws") return law_table();
  if (name == "heuristics") return key_table(heuristic_types());
  if (name == "heuristic_types") return heuristic_type_table();
  if (name == "bodies") return key_table(body_types());
  if (name == "integrator") return integrator_key_table();
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
