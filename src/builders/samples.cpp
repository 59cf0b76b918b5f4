#include "qbond/builders/samples.hpp"

#include <stdexcept>
#include <string>

namespace qbond {

Scene builtin_scene(std::string_view name, std::uint64_t max_memory) {
  std::string names;
  for (const BuiltinScene& s : builtin_scenes()) {
    if (s.name == name)
      return parse_scene(s.json, std::string(s.name) + ".json (built-in)", {.builtin = true, .max_memory = max_memory});
    names += (names.empty() ? "" : ", ") + std::string(s.name);
  }
  throw std::invalid_argument("unknown built-in scene '" + std::string(name) + "' (built-in scenes: " + names +
                              ")");
}

Scene canonical_lattice(int n) {
  const std::string size = std::to_string(n);
  return parse_scene(R"({
    "name": "canonical_lattice_)" + size + R"(",
    "description": "the performance workload: )" + size + "^3 cubic lattice anchored at x = 0" + R"(",
    "timestep": 1e-4, "steps": 1000, "gravity": [0, 0, -9.81],
    "materials": {"bond": {"law": "linear", "stiffness": 1000, "damping": 0.01, "damping_model": "axial"}},
    "bodies": [{"name": "lattice", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal",
                "size": [)" + size + "," + size + "," + size + R"(], "spacing": 0.01, "quanta_mass": 1e-3,
                "material": "bond"}],
    "anchors": [{"select": {"box": [[-1e-9, -1, -1], [1e-9, 1e3, 1e3]]}}]
  })", "canonical_lattice(" + size + ")");
}

}  // namespace qbond
