#include "qbond/io/scene.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_set>

#include "qbond/io/files.hpp"

#include "io/scene/builder.hpp"

namespace qbond {
using json = nlohmann::json;
using namespace scene_detail;  // Builder and the JSON reading helpers

SceneError::SceneError(const std::string& source, std::string p, std::string r)
    : std::runtime_error(source + ": " + (p.empty() ? "" : p + ": ") + r), path(std::move(p)), rule(std::move(r)) {}

namespace {

/// Parses JSON, refusing duplicate keys (the JSON library would keep the last one silently).
json parse_strict(std::string_view text) {
  struct Level {
    explicit Level(bool a) : array(a) {}
    bool array;
    std::size_t index = 0;
    std::string key;
    std::unordered_set<std::string> keys;
  };
  std::vector<Level> stack;
  auto path = [&] {
    std::string p;
    for (std::size_t d = 0; d + 1 < stack.size(); ++d)
      p = stack[d].array ? item(p, stack[d].index) : p + (p.empty() ? "" : ".") + stack[d].key;
    return p;
  };
  auto element_done = [&] {
    if (!stack.empty() && stack.back().array) ++stack.back().index;
  };
  using E = json::parse_event_t;
  return json::parse(text, [&](int, E e, json& parsed) {
    switch (e) {
      case E::object_start: stack.emplace_back(false); break;
      case E::array_start: stack.emplace_back(true); break;
      case E::key: {
        Level& l = stack.back();
        l.key = parsed.get<std::string>();
        if (!l.keys.insert(l.key).second) {
          stack.emplace_back(false);  // so that path() includes this key
          bad(path(), "duplicate key (JSON would silently keep only the last one)");
        }
        break;
      }
      case E::object_end:
      case E::array_end:
        stack.pop_back();
        element_done();
        break;
      case E::value: element_done(); break;
    }
    return true;
  });
}
}  // namespace

Scene parse_scene(std::string_view text, const std::string& source, const SceneFiles& files) {
  try {
    json root;
    try {
      root = parse_strict(text);
    } catch (const json::parse_error& e) {
      throw SceneError(source, "", std::string("invalid JSON: ") + e.what());
    }
    if (!root.is_object()) throw SceneError(source, "", "a scene is a JSON object, got " + type_name(root));
    return Builder(root, std::filesystem::path(source).stem().string(), files).build();
  } catch (const Bad& b) {
    throw SceneError(source, b.path, b.rule);
  }
}

Scene load_scene(const std::filesystem::path& file) {
  std::string text;
  try {
    text = read_file(file);
  } catch (const std::exception& e) {
    throw SceneError(file.string(), "", e.what());
  }
  return parse_scene(text, file.string(), {.dir = file.parent_path()});
}

double explicit_step_hint(const World& w) {
  const Model& m = w.model;
  std::vector<double> k_sum(m.num_quanta(), 0.0);
  const Bonds& bonds = w.state.bonds;
  for (std::size_t b = 0; b < bonds.size(); ++b) {
    if (!bonds.alive[b]) continue;
    const double k = rest_stiffness(bonds.law[b], bonds.law_args(m.shapes, b));
    k_sum[bonds.i[b]] += k;
    k_sum[bonds.j[b]] += k;
  }
  double w2 = 0;
  for (std::size_t i = 0; i < m.num_quanta(); ++i) w2 = std::max(w2, 2 * k_sum[i] * m.inv_mass[i]);
  return w2 > 0 ? 2 / std::sqrt(w2) : INFINITY;
}

std::string scene_summary(const Scene& s) {
  const World& w = s.world;
  const Model& m = w.model;
  std::size_t kinematic = 0;
  double mass = 0;
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (std::size_t i = 0; i < m.num_quanta(); ++i) {
    kinematic += m.is_kinematic(static_cast<Index>(i));
    mass += m.mass[i];
    lo = lo.cwiseMin(w.state.x[i]);
    hi = hi.cwiseMax(w.state.x[i]);
  }
  const double hint = explicit_step_hint(w);
  std::ostringstream o;
  o.precision(6);
  o << "  scene      " << s.name << (s.description.empty() ? "" : ": " + s.description) << "\n"
    << "  quanta     " << m.num_quanta() << " (" << m.num_quanta() - kinematic << " free, " << kinematic
    << " anchored or prescribed)\n"
    << "  bonds      " << w.num_bonds() << "\n"
    << "  bodies     " << m.body_names.size() << "\n"
    << "  mass       " << mass << " kg\n"
    << "  box        [" << lo.x() << ", " << lo.y() << ", " << lo.z() << "] .. [" << hi.x() << ", " << hi.y() << ", "
    << hi.z() << "] m\n"
    << "  timestep   " << s.timestep << " s x " << s.steps << " steps = " << s.timestep * static_cast<double>(s.steps)
    << " s, integrator " << to_string(s.integrator.type) << "\n"
    << "  explicit   stable below h = " << hint << " s (symplectic Euler, undamped); this step is "
    << s.timestep / hint << " x that";
  return o.str();
}

}  // namespace qbond
