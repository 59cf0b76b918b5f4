// Scene: a world and how to step it, from a scene file, JSON text or a dict; checkpoints read back.
#include <memory>

#include "bindings.hpp"

#include "qbond/io/checkpoint.hpp"
#include "qbond/io/scene.hpp"

namespace qbond::python {

void bind_scene(py::module_& m) {
  py::class_<Scene, std::shared_ptr<Scene>>(m, "Scene",
      "A loaded scene (docs/scene-format.md): its world built, the step, integrator and heuristics it asks for.")
      .def_static(
          "load", [](const std::string& path) { return std::make_shared<Scene>(load_scene(path)); }, py::arg("path"),
          "Loads a scene file; files it names are relative to its directory. Raises SceneError.")
      .def_static(
          "parse",
          [](const py::object& doc, const std::string& source) {
            const std::string text = py::isinstance<py::str>(doc) ? doc.cast<std::string>() : json_dumps(doc);
            return std::make_shared<Scene>(parse_scene(text, source));
          },
          py::arg("doc"), py::arg("source") = "<string>",
          "Parses a scene from JSON text or a dict; `source` names it in errors. Raises SceneError.")
      .def_readonly("name", &Scene::name)
      .def_readonly("description", &Scene::description)
      .def_readonly("seed", &Scene::seed)
      .def_readonly("timestep", &Scene::timestep, "[s]")
      .def_readonly("steps", &Scene::steps, "Steps the scene runs for.")
      .def_property_readonly(
          "resolved", [](const Scene& s) { return json_loads(s.resolved.dump()); },
          "The scene with every default filled in, as a dict.")
      .def_property_readonly(
          "integrator", [](const Scene& s) { return json_loads(s.resolved["integrator"].dump()); },
          "The integrator and its options, as a dict.")
      .def_property_readonly("world", [](const Scene& s) { return s.world; }, "A copy of the scene's world.")
      .def_property_readonly(
          "adaptive", [](const Scene& s) { return json_loads(s.resolved.value("adaptive", nlohmann::json(nullptr)).dump()); },
          "The scene's adaptive step control, as a dict (None when its steps are fixed).")
      .def("__repr__", [](const Scene& s) { return "<qbond.Scene '" + s.name + "'>"; });

  m.def(
      "read_checkpoint",
      [](const std::string& path) {
        Checkpoint c = load_checkpoint(path);
        py::dict d;
        d["metadata"] = json_loads(c.metadata.empty() ? "null" : c.metadata);
        d["step"] = c.state.step;
        d["time"] = c.state.time;
        d["positions"] = vec3_copy(c.state.x);
        d["velocities"] = vec3_copy(c.state.v);
        return d;
      },
      py::arg("path"),
      "Reads a checkpoint (a `qbond run`'s or Simulation.save_checkpoint's): a dict of its metadata, step, time, "
      "positions and velocities. Raises CheckpointError.");
}

}  // namespace qbond::python
