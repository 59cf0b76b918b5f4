// The module's exceptions: the library's errors become Python exceptions with the same messages
// the qbond program prints (a scene error's JSON path and rule included).
#include "bindings.hpp"
#include "errors.hpp"

#include "qbond/io/checkpoint.hpp"
#include "qbond/io/scene.hpp"

namespace qbond::python {

namespace {
PyObject* scene_error = nullptr;
PyObject* checkpoint_error = nullptr;
PyObject* blowup_error = nullptr;
}  // namespace

void raise_blowup(const std::string& message) {
  PyErr_SetString(blowup_error, message.c_str());
  throw py::error_already_set();
}

void bind_errors(py::module_& m) {
  // Subclasses of ValueError and RuntimeError, so that generic handlers still catch them.
  scene_error = PyErr_NewExceptionWithDoc("qbond.SceneError",
      "A scene that breaks a rule. str(e) is 'SOURCE: PATH: RULE'; e.path is the JSON path, e.rule the rule.",
      PyExc_ValueError, nullptr);
  checkpoint_error = PyErr_NewExceptionWithDoc("qbond.CheckpointError",
      "A checkpoint that cannot be read: not one, another version, truncated or corrupted.", PyExc_RuntimeError, nullptr);
  blowup_error = PyErr_NewExceptionWithDoc("qbond.BlowupError",
      "A step that blew up (too fast, non-finite or an energy runaway); the world keeps the last good state.",
      PyExc_RuntimeError, nullptr);
  m.add_object("SceneError", py::handle(scene_error));
  m.add_object("CheckpointError", py::handle(checkpoint_error));
  m.add_object("BlowupError", py::handle(blowup_error));

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const SceneError& e) {
      py::object err = py::reinterpret_borrow<py::object>(scene_error)(e.what());
      err.attr("path") = e.path;
      err.attr("rule") = e.rule;
      PyErr_SetObject(scene_error, err.ptr());
    } catch (const CheckpointError& e) {
      PyErr_SetString(checkpoint_error, e.what());
    }
  });
}

}  // namespace qbond::python
