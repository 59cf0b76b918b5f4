#include "qbond/io/scene.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "qbond/io/files.hpp"
#include "qbond/io/json_text.hpp"
#include "qbond/io/memory.hpp"

#include "io/scene/builder.hpp"

namespace qbond {
using json = nlohmann::json;
using namespace scene_detail;  // Builder and the JSON reading helpers

SceneError::SceneError(const std::string& source, std::string p, std::string r)
    : std::runtime_error(source + ": " + (p.empty() ? "" : p + ": ") + r), path(std::move(p)), rule(std::move(r)) {}


Scene parse_scene(std::string_view text, const std::string& source, const SceneFiles& files) {
  try {
    json root;
    try {
      root = parse_json_strict(text, kMaxJsonDepth, /*comments=*/true);
    } catch (const JsonTextError& e) {
      throw SceneError(source, e.path, e.rule);
    }
    if (!root.is_object()) throw SceneError(source, "", "a scene is a JSON object, got " + type_name(root));
    return Builder(root, std::filesystem::path(source).stem().string(), files).build();
  } catch (const Bad& b) {
    throw SceneError(source, b.path, b.rule);
  }
}

std::string camera_problem(const Vec3& position, const Vec3& target) {
  const Vec3 d = position - target;
  if (!(d.norm() > 0)) return "the camera's position and target must differ";
  if (std::abs(d.z()) / d.norm() > std::cos(kCameraVerticalLimit))
    return "the camera must not look straight up or down (z is the picture's up): move the position sideways of the target";
  return "";
}

std::uint64_t steps_for_duration(double duration, double timestep) {
  const double n = std::ceil(duration / timestep - 1e-9);
  const auto g = [](double v) { return num_str(v); };
  if (!(n <= static_cast<double>(kMaxSteps)))
    throw std::invalid_argument(g(duration) + " s at " + g(timestep) +
                                " s a step is more than 2^53 steps, the most a run can count");
  if (!(n >= 1))
    throw std::invalid_argument(g(duration) + " s rounds to no step of " + g(timestep) + " s");
  return static_cast<std::uint64_t>(n);
}

Scene load_scene(const std::filesystem::path& file, std::uint64_t max_memory) {
  std::string text;
  try {
    text = read_file(file);
  } catch (const std::exception& e) {
    throw SceneError(file.string(), "", e.what());
  }
  return parse_scene(text, file.string(), {.dir = file.parent_path(), .max_memory = max_memory});
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
    << s.timestep / hint << " x that\n"
    << "  memory     about " << format_bytes(static_cast<double>(estimated_run_memory(
                                    static_cast<double>(m.num_quanta()), static_cast<double>(w.num_bonds()))))
    << " for a run (estimated peak resident memory)";
  return o.str();
}

}  // namespace qbond
