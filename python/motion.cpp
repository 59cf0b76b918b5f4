// Prescribed motion from Python: quanta held fixed, translated, rotated or moved through
// keyframes, as a scene's `anchors[].motion` (docs/scene-format.md).
#include <cmath>

#include "bindings.hpp"

namespace qbond::python {

namespace {

Vec3 finite_vec3(const py::object& o, const char* name) {
  const Vec3 v = to_vec3(o);
  if (!v.allFinite()) throw py::value_error(std::string(name) + ": must be finite");
  return v;
}

Keyframe keyframe_of(const py::handle& item, std::size_t k) {
  const std::string at = "keyframes[" + std::to_string(k) + "]";
  Keyframe key;
  if (py::isinstance<py::dict>(item)) {
    const py::dict d = py::reinterpret_borrow<py::dict>(item);
    for (const auto& [name, _] : d) {
      const std::string n = name.cast<std::string>();
      if (n != "time" && n != "offset" && n != "angle")
        throw py::value_error(at + "." + n + ": unknown key (accepted: time, offset, angle)");
    }
    if (!d.contains("time")) throw py::value_error(at + ".time: required key missing");
    key.time = d["time"].cast<double>();
    if (d.contains("offset")) key.offset = finite_vec3(d["offset"], "offset");
    if (d.contains("angle")) key.angle = d["angle"].cast<double>();
  } else {
    const py::tuple t = py::tuple(py::reinterpret_borrow<py::object>(item));
    if (t.size() < 2 || t.size() > 3)
      throw py::value_error(at +
                            ": expected (time, offset) or (time, offset, angle), or a dict of those keys");
    key.time = t[0].cast<double>();
    key.offset = finite_vec3(t[1], "offset");
    if (t.size() == 3) key.angle = t[2].cast<double>();
  }
  if (!std::isfinite(key.angle)) throw py::value_error(at + ".angle: must be finite");
  return key;
}

}  // namespace

Motion make_motion(const std::string& type, const py::object& velocity, const py::object& axis,
                   const py::object& center, double rate, const py::object& keyframes,
                   const std::string& interpolation) {
  Motion m;
  if (type == "fixed") {
    m.type = MotionType::fixed;
  } else if (type == "translate") {
    m.type = MotionType::translate;
    m.velocity = finite_vec3(velocity, "velocity");
  } else if (type == "rotate") {
    m.type = MotionType::rotate;
    m.axis = finite_vec3(axis, "axis");
    m.center = finite_vec3(center, "center");
    if (!std::isfinite(rate)) throw py::value_error("rate: must be finite");
    m.rate = rate;
  } else if (type == "keyframes") {
    m.type = MotionType::keyframes;
    m.axis = finite_vec3(axis, "axis");
    m.center = finite_vec3(center, "center");
    if (interpolation == "linear")
      m.interpolation = Interpolation::linear;
    else if (interpolation == "smooth")
      m.interpolation = Interpolation::smooth;
    else
      throw py::value_error("interpolation: must be linear or smooth, got '" + interpolation + "'");
    std::size_t k = 0;
    for (const py::handle item : keyframes) {
      Keyframe key = keyframe_of(item, k);
      const double previous = k ? m.keyframes.back().time : 0.0;
      if (!(key.time > previous) || !std::isfinite(key.time))
        throw py::value_error("keyframes[" + std::to_string(k) +
                              "].time: must be after the previous keyframe's " + std::to_string(previous) +
                              " s, got " + std::to_string(key.time));
      m.keyframes.push_back(key);
      ++k;
    }
    if (m.keyframes.empty()) throw py::value_error("keyframes: must hold at least one keyframe");
  } else {
    throw py::value_error("motion: must be one of fixed, translate, rotate, keyframes, got '" + type + "'");
  }
  if ((m.type == MotionType::rotate || m.type == MotionType::keyframes) && !(m.axis.norm() > 0))
    throw py::value_error("axis: must be non-zero");
  return m;
}

void prescribe_checked(World& w, std::vector<Index> quanta, Motion motion) {
  check_quanta(w, quanta);
  if (quanta.empty()) throw py::value_error("a prescribed motion needs at least one quanta");
  std::vector<std::uint8_t> moved(w.num_quanta(), 0);
  for (const Motion& m : w.model.motions)
    for (Index i : m.quanta) moved[i] = 1;
  for (Index i : quanta) {
    if (moved[i])
      throw py::value_error("quanta " + std::to_string(i) + " already follows a prescribed motion");
    moved[i] = 1;  // and not twice in this one
  }
  w.prescribe(std::move(quanta), std::move(motion));
}

void bind_world_motion(py::class_<World>& world) {
  world.def(
      "prescribe",
      [](World& w, const py::object& ids, const std::string& motion, const py::object& velocity,
         const py::object& axis, const py::object& center, double rate, const py::object& keyframes,
         const std::string& interpolation) {
        prescribe_checked(w, to_indices(ids),
                          make_motion(motion, velocity, axis, center, rate, keyframes, interpolation));
      },
      py::arg("quanta"), py::arg("motion") = "fixed", py::arg("velocity") = py::make_tuple(0, 0, 0),
      py::arg("axis") = py::make_tuple(0, 0, 1), py::arg("center") = py::make_tuple(0, 0, 0),
      py::arg("rate") = 0.0, py::arg("keyframes") = py::list(), py::arg("interpolation") = "linear",
      "Makes the quanta kinematic, following a motion from their current positions at the current time t0: "
      "'fixed'; 'translate', x = x0 + velocity (t − t0); 'rotate', `rate` [rad/s] about `axis` through "
      "`center`; "
      "'keyframes', poses (time after t0 [s], offset [m], angle [rad] about axis through center) reached in "
      "turn "
      "with 'linear' or 'smooth' (3s² − 2s³) interpolation and held after the last. Raises ValueError for a "
      "quanta "
      "already prescribed.");
}

}  // namespace qbond::python
