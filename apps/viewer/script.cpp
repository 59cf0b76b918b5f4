#include "script.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string_view>

namespace qbond::view {

namespace {
using nlohmann::json;

struct Reader {
  const std::string& source;
  [[noreturn]] void fail(const std::string& path, const std::string& rule) const {
    throw std::invalid_argument(source + ": " + (path.empty() ? "" : path + ": ") + rule);
  }
  const json& member(const json& j, const std::string& path, const char* key) const {
    if (!j.is_object()) fail(path, "must be an object");
    if (!j.contains(key)) fail(path, std::string("missing '") + key + "'");
    return j.at(key);
  }
  Vec3 vec3(const json& j, const std::string& path) const {
    if (!j.is_array() || j.size() != 3) fail(path, "must be an array of 3 numbers");
    Vec3 v;
    for (int k = 0; k < 3; ++k) {
      if (!j[k].is_number()) fail(path, "must be an array of 3 numbers");
      v[k] = j[k].get<double>();
    }
    if (!v.allFinite()) fail(path, "must be finite");
    return v;
  }
  Index quanta(const json& j, const std::string& path, std::size_t n) const {
    if (!j.is_number_integer() || j.get<long long>() < 0 || static_cast<std::size_t>(j.get<long long>()) >= n)
      fail(path, "must be a quanta id in [0, " + std::to_string(n) + ")");
    return static_cast<Index>(j.get<long long>());
  }
};
}  // namespace

std::vector<ScriptEvent> parse_script(const std::string& json_text, const std::string& source, std::size_t num_quanta) {
  const Reader r{source};
  json doc;
  try {
    doc = json::parse(json_text);
  } catch (const json::parse_error& e) {
    r.fail("", std::string("not valid JSON: ") + e.what());
  }
  const json& events = r.member(doc, "", "events");
  if (!events.is_array()) r.fail("events", "must be an array");
  std::vector<ScriptEvent> out;
  for (std::size_t k = 0; k < events.size(); ++k) {
    const std::string at = "events[" + std::to_string(k) + "]";
    const json& e = events[k];
    ScriptEvent ev;
    const json& frame = r.member(e, at, "frame");
    if (!frame.is_number_integer() || frame.get<long long>() < 0) r.fail(at + ".frame", "must be an integer >= 0");
    ev.frame = frame.get<std::uint64_t>();
    int kinds = 0;
    for (const char* key : {"drag", "release", "push", "key", "mouse"}) kinds += e.contains(key) ? 1 : 0;
    if (kinds != 1) r.fail(at, "must have exactly one of 'drag', 'release', 'push', 'key', 'mouse'");
    if (e.contains("drag")) {
      const std::string p = at + ".drag";
      ev.kind = ScriptEvent::Kind::drag;
      ev.quanta = r.quanta(r.member(e["drag"], p, "quanta"), p + ".quanta", num_quanta);
      if (e["drag"].contains("to") == e["drag"].contains("by")) r.fail(p, "must have exactly one of 'to', 'by'");
      if (e["drag"].contains("to")) ev.to = r.vec3(e["drag"]["to"], p + ".to");
      else ev.by = r.vec3(e["drag"]["by"], p + ".by");
    } else if (e.contains("push")) {
      const std::string p = at + ".push";
      ev.kind = ScriptEvent::Kind::push;
      ev.quanta = r.quanta(r.member(e["push"], p, "quanta"), p + ".quanta", num_quanta);
      ev.force = r.vec3(r.member(e["push"], p, "force"), p + ".force");
    } else if (e.contains("mouse")) {
      const std::string p = at + ".mouse";
      const json& m = e["mouse"];
      if (!m.is_object() || m.size() != 1) r.fail(p, "must be an object with one of 'press_on', 'move_by', 'release'");
      if (m.contains("press_on")) {
        ev.kind = ScriptEvent::Kind::mouse_press;
        ev.quanta = r.quanta(m["press_on"], p + ".press_on", num_quanta);
      } else if (m.contains("move_by")) {
        ev.kind = ScriptEvent::Kind::mouse_move;
        const json& d = m["move_by"];
        if (!d.is_array() || d.size() != 2 || !d[0].is_number() || !d[1].is_number())
          r.fail(p + ".move_by", "must be an array of 2 numbers (pixels)");
        ev.pixels = {d[0].get<double>(), d[1].get<double>()};
      } else if (m.contains("release")) {
        if (m["release"] != true) r.fail(p + ".release", "must be true");
        ev.kind = ScriptEvent::Kind::mouse_release;
      } else {
        r.fail(p, "must be an object with one of 'press_on', 'move_by', 'release'");
      }
    } else if (e.contains("release")) {
      if (e["release"] != true) r.fail(at + ".release", "must be true");
      ev.kind = ScriptEvent::Kind::release;
    } else {
      const json& key = e["key"];
      static constexpr std::string_view keys = " .rhf";
      if (!key.is_string()) r.fail(at + ".key", "must be one of \"space\", \".\", \"r\", \"h\", \"f\"");
      const std::string s = key.get<std::string>();
      ev.kind = ScriptEvent::Kind::key;
      ev.key = s == "space" ? ' ' : (s.size() == 1 && keys.find(s[0]) != std::string_view::npos && s[0] != ' ') ? s[0] : 0;
      if (ev.key == 0) r.fail(at + ".key", "must be one of \"space\", \".\", \"r\", \"h\", \"f\", got \"" + s + "\"");
    }
    out.push_back(ev);
  }
  std::stable_sort(out.begin(), out.end(), [](const ScriptEvent& a, const ScriptEvent& b) { return a.frame < b.frame; });
  return out;
}

}  // namespace qbond::view
