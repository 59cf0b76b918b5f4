// Simulation: steps a world, with the integrator, heuristics and limits of a scene or of the
// caller's choice; arrays of its state without copies.
#include <cmath>
#include <memory>

#include "bindings.hpp"
#include "bonds.hpp"
#include "errors.hpp"

#include "qbond/analysis/analysis.hpp"
#include "qbond/integrators/adaptive.hpp"
#include "qbond/io/probes.hpp"
#include "qbond/io/checkpoint.hpp"
#include "qbond/io/scene.hpp"
#include "qbond/simulation/simulation.hpp"
#include "qbond/version.hpp"

namespace qbond::python {

namespace {

class PyHeuristic;

/// A Simulation and what the module adds to it: forces that stay applied until changed, and a
/// Python force callback.
struct PySimulation {
  std::unique_ptr<Simulation> sim;
  std::vector<Vec3> external;  ///< [N] (n) added to every step (external_forces)
  std::vector<Vec3> user;      ///< [N] (n) the callback's buffer
  py::object force_callback = py::none();  ///< None, or f(x, v, f) filling f
  bool track_energy = true;    ///< mirrors Simulation::set_track_energy (which has no getter)
  bool keep_last_good = true;  ///< mirrors Simulation::set_keep_last_good
  std::vector<PyHeuristic*> py_heuristics;  ///< the Python heuristics among the simulation's
  AdaptiveConfig adaptive;     ///< enabled: each step is adaptive_step's (error and energy controlled)
  double end_time = HUGE_VAL;  ///< [s] where adaptive steps end (a scene's horizon: steps × timestep)
  double last_h = 0;           ///< [s] the step that led to the current state
  std::uint64_t rejected = 0;  ///< adaptive tries undone so far
  std::vector<Probe> probes;   ///< named selections probes() measures

  PySimulation(World world, const IntegratorConfig& config, double h)
      : sim(std::make_unique<Simulation>(std::move(world), config, h)),
        external(sim->world().num_quanta(), Vec3::Zero()),
        user(sim->world().num_quanta(), Vec3::Zero()) {}
};

IntegratorConfig configure(IntegratorConfig c, const py::kwargs& options) {
  for (const auto& [key_handle, value] : options) {
    const std::string key = key_handle.cast<std::string>();
    const auto options = integrator_options();
    const auto opt = std::find_if(options.begin(), options.end(), [&](const IntegratorOptionInfo& o) { return o.key == key; });
    if (opt != options.end()) {
      switch (opt->holds) {
        case IntegratorOptionInfo::Holds::integer: c.*opt->integer = value.cast<int>(); break;
        case IntegratorOptionInfo::Holds::number: c.*opt->number = value.cast<double>(); break;
        case IntegratorOptionInfo::Holds::boolean: c.*opt->boolean = value.cast<bool>(); break;
        case IntegratorOptionInfo::Holds::name: opt->set_name(c, value.cast<std::string>()); break;
      }
    } else {
      std::string names;
      for (const IntegratorOptionInfo& o : integrator_options()) names += (names.empty() ? "" : ", ") + std::string(o.key);
      throw py::value_error("unknown integrator option '" + key + "' (options: " + names + ")");
    }
  }
  make_integrator(c);  // checks the options (std::invalid_argument → ValueError)
  return c;
}

py::dict config_dict(const IntegratorConfig& c) {
  py::dict d;
  d["type"] = std::string(to_string(c.type));
  for (const IntegratorOptionInfo& opt : integrator_options()) {
    const std::string key(opt.key);
    switch (opt.holds) {
      case IntegratorOptionInfo::Holds::integer: d[key.c_str()] = c.*opt.integer; break;
      case IntegratorOptionInfo::Holds::number: d[key.c_str()] = c.*opt.number; break;
      case IntegratorOptionInfo::Holds::boolean: d[key.c_str()] = c.*opt.boolean; break;
      case IntegratorOptionInfo::Holds::name: d[key.c_str()] = std::string(opt.name_of(c)); break;
    }
  }
  return d;
}

/// A heuristic written in Python: fn(x, dx, dv) between projection and application, with a
/// read-only view of the positions and writable views of the step's projected changes. The step
/// runs without the GIL, so apply takes it; an exception is kept and raised once the step returns
/// (that step applies without the heuristic's edits past the point it raised).
class PyHeuristic final : public Heuristic {
 public:
  /// `owner` is the Python Simulation that owns this heuristic, borrowed (a reference would
  /// make a cycle no collector sees): it outlives the heuristic, and the views keep it alive.
  PyHeuristic(py::object fn, py::handle owner) : fn_(std::move(fn)), owner_(owner) {}
  ~PyHeuristic() override {
    py::gil_scoped_acquire acquire;  // the Python objects are released with the GIL held
    fn_ = py::object();
    error_.reset();
  }
  std::string_view name() const override { return "python"; }
  void apply(const Model&, State& state, Projection& p, const HeuristicContext&) override {
    py::gil_scoped_acquire acquire;
    if (error_) return;
    try {
      fn_(vec3_view(state.x, owner_, false), vec3_view(p.dx, owner_, true), vec3_view(p.dv, owner_, true));
    } catch (py::error_already_set& e) {
      error_ = std::make_unique<py::error_already_set>(std::move(e));
    }
  }
  /// Raises the exception the callback raised during the last step, if any.
  void rethrow() {
    if (!error_) return;
    std::unique_ptr<py::error_already_set> e = std::move(error_);
    e->restore();
    throw py::error_already_set();
  }

 private:
  py::object fn_;
  py::handle owner_;
  std::unique_ptr<py::error_already_set> error_;
};

bool any_nonzero(const std::vector<Vec3>& f) {
  for (const Vec3& v : f)
    if (v.x() != 0 || v.y() != 0 || v.z() != 0) return true;
  return false;
}

void queue(Simulation& sim, const std::vector<Vec3>& f) {
  for (std::size_t i = 0; i < f.size(); ++i)
    if (f[i].x() != 0 || f[i].y() != 0 || f[i].z() != 0) sim.add_force(static_cast<Index>(i), f[i]);
}

/// Steps n times with the GIL released (taken back only to call a Python force callback); or,
/// with `until` (adaptive steps only), until the time reaches it. An adaptive step ends at
/// min(until, end_time).
void step_n(py::object self_obj, std::uint64_t n, std::optional<double> until = std::nullopt) {
  PySimulation& self = self_obj.cast<PySimulation&>();
  Simulation& sim = *self.sim;
  const bool callback = !self.force_callback.is_none();
  // The forces of one try; an adaptive step retried needs them again.
  auto forces = [&] {
    if (callback) {
      py::gil_scoped_acquire acquire;
      std::fill(self.user.begin(), self.user.end(), Vec3::Zero());
      State& s = sim.world().state;
      self.force_callback(vec3_view(s.x, self_obj, false), vec3_view(s.v, self_obj, false), vec3_view(self.user, self_obj, true));
      queue(sim, self.user);
    }
    if (any_nonzero(self.external)) queue(sim, self.external);
  };
  const double t_end = until ? std::min(*until, self.end_time) : self.end_time;
  py::gil_scoped_release release;
  for (std::uint64_t k = 0; until ? sim.world().state.time < t_end : k < n; ++k) {
    StepReport r;
    if (self.adaptive.enabled) {
      if (!(sim.world().state.time < t_end)) break;  // at the scene's end: nothing left to step
      // Without forces the controller gets none, as `qbond run` calls it (the same bits).
      const AdaptiveReport a = callback || any_nonzero(self.external)
                                   ? adaptive_step(sim, self.adaptive, t_end, forces)
                                   : adaptive_step(sim, self.adaptive, t_end);
      self.last_h = a.h;
      self.rejected += static_cast<std::uint64_t>(a.rejected);
      r = a.step;
    } else {
      forces();
      self.last_h = sim.timestep();
      r = sim.step();
    }
    if (!self.py_heuristics.empty()) {
      py::gil_scoped_acquire acquire;
      for (PyHeuristic* h : self.py_heuristics) h->rethrow();
    }
    if (r.status == StepReport::Status::blowup) {
      py::gil_scoped_acquire acquire;
      raise_blowup(r.message);
    }
  }
}

PySimulation& of(py::object& o) { return o.cast<PySimulation&>(); }

py::array_t<double> vec3_array(const Vec3& v) {
  py::array_t<double> a(3);
  for (int k = 0; k < 3; ++k) a.mutable_at(k) = v[k];
  return a;
}

/// A probe's measurement as a dict: mean, and force and torque (kinematic quanta only), stress
/// and von_mises_max (quanta with volumes only).
py::dict probe_dict(const World& w, const Probe& probe) {
  const ProbeValue v = measure_probe(w.model, w.state, probe);
  py::dict d;
  d["mean"] = vec3_array(v.mean);
  if (v.has_reaction) {
    d["force"] = vec3_array(v.force);
    d["torque"] = vec3_array(v.torque);
  }
  if (v.has_stress) {
    py::array_t<double> s({3, 3});
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) s.mutable_at(i, j) = v.stress(i, j);
    d["stress"] = s;
    d["von_mises_max"] = v.von_mises_max;
  }
  return d;
}

Probe probe_of(const World& w, std::string name, const py::object& ids, const py::object& about) {
  Probe p{std::move(name), to_indices(ids), std::nullopt};
  check_quanta(w, p.quanta);
  if (p.quanta.empty()) throw py::value_error("a probe needs at least one quanta");
  if (!about.is_none()) p.about = to_vec3(about);
  return p;
}

py::dict adaptive_dict(const AdaptiveConfig& a) {
  py::dict d;
  d["enabled"] = a.enabled;
  d["error"] = a.error;
  d["energy"] = a.energy;
  d["min_step"] = a.min_step;
  d["max_step"] = a.max_step;
  d["safety"] = a.safety;
  d["horizon"] = a.horizon;
  return d;
}

/// Puts a saved state in the world after checking it is one of this world (its quanta and scene
/// bonds); `where` prefixes the error. A copy assignment: the arrays keep their storage, and so
/// the views of them stay valid. The next step depends on the state alone (forget_history).
void put_state(Simulation& sim, const State& s, const std::string& where) {
  World& w = sim.world();
  const std::size_t bonds = w.state.bonds.first_formed, saved = s.bonds.first_formed;
  if (s.x.size() != w.num_quanta() || saved != bonds)
    throw CheckpointError(where + "the state holds " + std::to_string(s.x.size()) + " quanta and " + std::to_string(saved) +
                          " bonds, the simulation has " + std::to_string(w.num_quanta()) + " and " + std::to_string(bonds));
  for (const std::uint32_t row : s.bonds.shape)
    if (row >= w.model.shapes.size())
      throw CheckpointError(where + "a bond's law parameters are not among the simulation's materials");
  w.state = s;
  sim.forget_history();
}

}  // namespace

void bind_simulation(py::module_& m) {
  py::class_<PySimulation>(m, "Simulation",
      "A world stepped by an integrator, with heuristics and blow-up limits. Array properties are views of the "
      "current state, valid until the next step (a step writes into a second buffer and swaps): read them again "
      "after stepping, or copy them.")
      .def(py::init([](const Scene& scene) {
             auto s = std::make_unique<PySimulation>(scene.world, scene.integrator, scene.timestep);
             s->sim->limits() = scene.limits;
             s->sim->set_keep_last_good(true);
             for (const HeuristicSpec& h : scene.heuristics) s->sim->add_heuristic(make_heuristic(h));
             s->adaptive = scene.adaptive;
             if (scene.adaptive.enabled) s->end_time = static_cast<double>(scene.steps) * scene.timestep;
             for (const ProbeSpec& p : scene.output.probes) s->probes.push_back({p.name, p.quanta, p.about});
             s->last_h = scene.timestep;
             return s;
           }),
           py::arg("scene"),
           "Steps a scene as `qbond run` does: its world, step, integrator, heuristics, limits, probes and "
           "adaptive step control (which then ends at the scene's horizon, steps × timestep: end_time).")
      .def(py::init([](const World& world, double timestep, const std::optional<std::string>& integrator, const py::kwargs& options) {
             if (!(timestep > 0) || !std::isfinite(timestep)) throw py::value_error("timestep: must be > 0, got " + std::to_string(timestep));
             IntegratorConfig c = default_integrator();
             if (integrator) c.type = parse_integrator_type(*integrator);
             c = configure(c, options);
             auto s = std::make_unique<PySimulation>(world, c, timestep);
             s->sim->set_keep_last_good(true);
             s->last_h = timestep;
             return s;
           }),
           py::arg("world"), py::arg("timestep"), py::arg("integrator") = py::none(),
           "Steps a copy of `world` with steps of `timestep` [s] and the named integrator (None: qbond's default), "
           "options as keywords (neighbours, solver, iterations, tolerance, threads, ...).")
      .def("step", [](py::object self, std::uint64_t n) { step_n(std::move(self), n); }, py::arg("n") = 1,
           "Takes n steps (adaptive: n accepted ones, none past end_time), without the GIL. Raises BlowupError (the "
           "world keeps its last good state).")
      .def(
          "run",
          [](py::object self, double duration) {
            PySimulation& s = of(self);
            if (!(duration >= 0) || !std::isfinite(duration)) throw py::value_error("duration: must be >= 0");
            if (s.adaptive.enabled) return step_n(self, 0, s.sim->world().state.time + duration);
            step_n(self, static_cast<std::uint64_t>(std::ceil(duration / s.sim->timestep() - 1e-9)));
          },
          py::arg("duration"),
          "Steps for `duration` seconds: ceil(duration / timestep) steps, as a scene's `duration`; adaptive, until "
          "the time has advanced by `duration` (the last step ends exactly there, or at end_time if sooner).")
      .def_property_readonly("time", [](py::object self) { return of(self).sim->world().state.time; }, "Simulated time [s].")
      .def_property_readonly("step_count", [](py::object self) { return of(self).sim->world().state.step; }, "Steps taken.")
      .def_property(
          "timestep", [](py::object self) { return of(self).sim->timestep(); },
          [](py::object self, double h) {
            if (!(h > 0) || !std::isfinite(h)) throw py::value_error("timestep: must be > 0, got " + std::to_string(h));
            of(self).sim->set_timestep(h);
          },
          "Step length [s].")
      .def(
          "set_adaptive",
          [](py::object self, bool enabled, const py::kwargs& options) {
            AdaptiveConfig a = of(self).adaptive;
            a.enabled = enabled;
            for (const auto& [key_handle, value] : options) {
              const std::string key = key_handle.cast<std::string>();
              const double x = value.cast<double>();
              if (key == "error") a.error = x;
              else if (key == "energy") a.energy = x;
              else if (key == "min_step") a.min_step = x;
              else if (key == "max_step") a.max_step = x;
              else if (key == "safety") a.safety = x;
              else if (key == "horizon") a.horizon = x;
              else
                throw py::value_error("unknown adaptive option '" + key +
                                      "' (options: error, energy, min_step, max_step, safety, horizon)");
            }
            auto positive = [](double v, const char* name) {
              if (!(v > 0) || !std::isfinite(v)) throw py::value_error(std::string(name) + ": must be > 0, got " + std::to_string(v));
            };
            positive(a.error, "error");
            positive(a.energy, "energy");
            positive(a.min_step, "min_step");
            positive(a.safety, "safety");
            positive(a.horizon, "horizon");
            if (!(a.max_step >= 0) || !std::isfinite(a.max_step)) throw py::value_error("max_step: must be >= 0 (0: no limit)");
            if (a.max_step > 0 && a.max_step < a.min_step) throw py::value_error("max_step: must be >= min_step");
            of(self).adaptive = a;
          },
          py::arg("enabled") = true,
          "Turns adaptive step control (docs/integrators.md) on or off; options as keywords (error [m], energy, "
          "min_step [s], max_step [s], safety, horizon [s]); unnamed options are kept. Each step then takes the "
          "longest step its error estimate and energy drift allow, starting from `timestep`, and leaves the next "
          "proposal there.")
      .def_property_readonly("adaptive", [](py::object self) { return adaptive_dict(of(self).adaptive); },
                             "The adaptive step control's settings, as a dict (enabled: whether steps adapt).")
      .def_property(
          "end_time", [](py::object self) { return of(self).end_time; },
          [](py::object self, double t) {
            if (std::isnan(t)) throw py::value_error("end_time: must be a number");
            of(self).end_time = t;
          },
          "[s] where adaptive steps stop (the last one ends exactly there): a scene's horizon, steps × timestep, "
          "else infinity.")
      .def_property_readonly("last_step_size", [](py::object self) { return of(self).last_h; },
                             "[s] the length of the step that led to the current state.")
      .def_property_readonly("rejected_steps", [](py::object self) { return of(self).rejected; },
                             "Adaptive tries undone (and retried shorter) so far.")
      .def_property_readonly("num_quanta", [](py::object self) { return of(self).sim->world().num_quanta(); })
      .def_property_readonly("num_bonds", [](py::object self) { return of(self).sim->world().num_bonds(); })
      .def_property_readonly("world", [](py::object self) { return of(self).sim->world(); }, "A copy of the world.")
      .def(
          "set_integrator",
          [](py::object self, const std::optional<std::string>& type, const py::kwargs& options) {
            IntegratorConfig c = of(self).sim->integrator().config();
            if (type) c.type = parse_integrator_type(*type);
            of(self).sim->set_integrator(configure(c, options));
          },
          py::arg("type") = py::none(), "Changes the integrator and/or its options (keywords); unnamed options are kept.")
      .def_property_readonly("integrator", [](py::object self) { return config_dict(of(self).sim->integrator().config()); },
                             "The integrator and its options, as a dict.")
      // Arrays: views of the state (valid until the next step) and of the model.
      .def_property_readonly("positions", [](py::object self) { return vec3_view(of(self).sim->world().state.x, self, false); },
                             "(n, 3) positions [m], a read-only view.")
      .def_property_readonly("velocities", [](py::object self) { return vec3_view(of(self).sim->world().state.v, self, true); },
                             "(n, 3) velocities [m/s], a writable view: writes take effect at the next step.")
      .def_property_readonly(
          "masses", [](py::object self) { return view(of(self).sim->world().model.mass, self, false); }, "(n,) masses [kg], read-only.")
      .def_property_readonly(
          "inverse_masses", [](py::object self) { return view(of(self).sim->world().model.inv_mass, self, false); },
          "(n,) inverse masses [1/kg], read-only; 0 for kinematic quanta.")
      .def_property_readonly(
          "quanta_id", [](py::object self) { return view(of(self).sim->world().model.quanta_id, self, false); },
          "(n,) the user's id of each quanta (its creation order), read-only.")
      .def_property_readonly(
          "external_forces", [](py::object self) { return vec3_view(of(self).external, self, true); },
          "(n, 3) forces [N] added at every step until changed, a writable view.")
      .def_property_readonly("bond_forces", [](py::object self) { return bond_forces(of(self).sim->world()); },
                             "(n, 3) net bond force on each quanta [N] at the current state (a copy).")
      .def_property_readonly("bond_ends", [](py::object self) { return bond_ends(of(self).sim->world()); },
                             "(nb, 2) end quanta of every bond (a copy).")
      .def_property_readonly("bond_alive", [](py::object self) { return bond_alive(of(self).sim->world()); },
                             "(nb,) whether each bond holds (a copy).")
      .def_property_readonly("bond_rest_lengths", [](py::object self) { return bond_rest_length(of(self).sim->world()); },
                             "(nb,) current rest lengths [m] (a copy).")
      .def("bond_tension_strain", [](py::object self) { return bond_tension_strain(of(self).sim->world()); },
           "(tension [N], strain (r − L)/L) of every bond as two (nb,) arrays; 0 for broken bonds.")
      .def(
          "set_force_callback",
          [](py::object self, py::object fn) { of(self).force_callback = std::move(fn); }, py::arg("fn"),
          "Calls fn(x, v, f) before every step with read-only views of positions and velocities and a zeroed (n, 3) "
          "array f to fill with forces [N] for that step; None removes it.")
      .def_property(
          "track_energy", [](py::object self) { return of(self).track_energy; },
          [](py::object self, bool on) {
            of(self).track_energy = on;
            of(self).sim->set_track_energy(on);
          },
          "Whether each step updates the energy ledger and checks it for a runaway (one pass over the bonds).")
      .def_property(
          "keep_last_good", [](py::object self) { return of(self).keep_last_good; },
          [](py::object self, bool on) {
            of(self).keep_last_good = on;
            of(self).sim->set_keep_last_good(on);
          },
          "Whether each step keeps a copy of the state to roll an energy runaway back to (a copy per step).")
      .def(
          "add_heuristic",
          [](py::object self, py::object fn) {
            auto h = std::make_unique<PyHeuristic>(std::move(fn), self.ptr());
            of(self).py_heuristics.push_back(h.get());
            of(self).sim->add_heuristic(std::move(h));
          },
          py::arg("fn"),
          "Adds a heuristic after the others: fn(x, dx, dv) is called every step between the projection and its "
          "application, with a read-only view of the positions and writable (n, 3) views of the step's projected "
          "position and velocity changes to edit. Energy it removes shows in the ledger's dissipated_numerical. "
          "An exception it raises is raised by step() after that step.")
      .def(
          "add_break_rule",
          [](py::object self, double max_strain, double max_compression, double max_tension, double probability,
             const py::object& ids) {
            const World& w = of(self).sim->world();
            BreakRule r;
            auto limit = [](double v, const char* name) {
              if (!(v > 0)) throw py::value_error(std::string(name) + ": must be > 0, got " + std::to_string(v));
              return v;
            };
            r.max_strain = limit(max_strain, "max_strain");
            r.max_compression = limit(max_compression, "max_compression");
            r.max_tension = limit(max_tension, "max_tension");
            if (!(probability > 0 && probability <= 1))
              throw py::value_error("probability: must be in (0, 1], got " + std::to_string(probability));
            r.probability = probability;
            if (!ids.is_none()) {
              const std::vector<Index> q = to_indices(ids);
              check_quanta(w, q);
              r.quanta.assign(w.num_quanta(), 0);
              for (Index i : q) r.quanta[i] = 1;
            }
            of(self).sim->add_heuristic(make_heuristic(HeuristicSpec(r)));
          },
          py::arg("max_strain") = HUGE_VAL, py::arg("max_compression") = HUGE_VAL, py::arg("max_tension") = HUGE_VAL,
          py::arg("probability") = 1.0, py::arg("quanta") = py::none(),
          "Adds a fracture rule after the heuristics there are, as a scene's {\"type\": \"break\"}: a bond past "
          "max_strain, max_compression (strains) or max_tension [N] breaks, with `probability` per step (drawn "
          "from the state's seeded generator); `quanta`: only bonds with both ends among them (None: all).")
      .def(
          "clear_heuristics",
          [](py::object self) {
            of(self).py_heuristics.clear();
            of(self).sim->clear_heuristics();
          },
          "Removes every heuristic (the scene's and the Python ones).")
      // Prescribed motion and probes.
      .def(
          "prescribe",
          [](py::object self, const py::object& ids, const std::string& motion, const py::object& velocity,
             const py::object& axis, const py::object& center, double rate, const py::object& keyframes,
             const std::string& interpolation) {
            Simulation& sim = *of(self).sim;
            World& w = sim.world();
            // The quanta leave the energy the ledger counts (kinematic quanta carry none of it):
            // what they held is charged as the anchors' work, so the budget still balances.
            const double before = energies(w.model, w.state).total();
            prescribe_checked(w, to_indices(ids), make_motion(motion, velocity, axis, center, rate, keyframes, interpolation));
            w.state.energy.work_anchors += energies(w.model, w.state).total() - before;
            // The integrator's structures (a preconditioner, a kept hierarchy) were built for
            // the old masses: a fresh one of the same configuration.
            sim.set_integrator(sim.integrator().config());
          },
          py::arg("quanta"), py::arg("motion") = "fixed", py::arg("velocity") = py::make_tuple(0, 0, 0),
          py::arg("axis") = py::make_tuple(0, 0, 1), py::arg("center") = py::make_tuple(0, 0, 0), py::arg("rate") = 0.0,
          py::arg("keyframes") = py::list(), py::arg("interpolation") = "linear",
          "World.prescribe between steps: the motion starts now, from the quanta's current positions. The energy "
          "they held leaves the ledger's total as work of the anchors (the budget still balances).")
      .def(
          "add_probe",
          [](py::object self, const std::string& name, const py::object& ids, const py::object& about) {
            PySimulation& s = of(self);
            for (const Probe& p : s.probes)
              if (p.name == name) throw py::value_error("a probe named '" + name + "' exists already");
            s.probes.push_back(probe_of(s.sim->world(), name, ids, about));
          },
          py::arg("name"), py::arg("quanta"), py::arg("about") = py::none(),
          "Adds a named probe of the quanta, measured by probes(); `about`: the torque's reference point (None: "
          "the quanta's mean position).")
      .def(
          "probes",
          [](py::object self) {
            py::dict d;
            for (const Probe& p : of(self).probes) d[py::str(p.name)] = probe_dict(of(self).sim->world(), p);
            return d;
          },
          "Measures every probe (the scene's output.probes and add_probe's) as `qbond run`'s diagnostics.csv: "
          "name → dict of mean [m]; force [N] and torque [N·m], the reaction of the support, when every quanta is "
          "kinematic; stress [Pa] (3×3, virial) and von_mises_max [Pa] when they have volumes.")
      .def(
          "probe",
          [](py::object self, const py::object& ids, const py::object& about) {
            return probe_dict(of(self).sim->world(), probe_of(of(self).sim->world(), "", ids, about));
          },
          py::arg("quanta"), py::arg("about") = py::none(), "Measures the quanta once, as probes() measures a probe.")
      // Energies.
      .def(
          "energies",
          [](py::object self) {
            const World& w = of(self).sim->world();
            const Energies e = energies(w.model, w.state);
            py::dict d;
            d["kinetic"] = e.kinetic;
            d["bonds"] = e.bonds;
            d["gravity"] = e.gravity;
            d["total"] = e.total();
            return d;
          },
          "Kinetic, bond and gravity energy [J] and their total.")
      .def(
          "ledger",
          [](py::object self) {
            const World& w = of(self).sim->world();
            const EnergyBudget b = energy_budget(w.model, w.state);
            py::dict d;
            d["total"] = b.now.total();
            d["initial_total"] = b.initial_total;
            d["work_loads"] = b.work_loads;
            d["work_anchors"] = b.work_anchors;
            d["dissipated_damping"] = b.dissipated_damping;
            d["dissipated_heuristics"] = b.dissipated_heuristics;
            d["dissipated_contact"] = b.dissipated_contact;
            d["contact_stored"] = b.contact_stored;
            d["numerical_damping"] = b.numerical_damping;
            d["dissipated_numerical"] = b.dissipated_numerical;
            return d;
          },
          "The energy budget [J]: E + contact_stored − E(0) = work_loads + work_anchors − dissipated_damping − "
          "dissipated_heuristics − dissipated_contact − numerical_damping − dissipated_numerical "
          "(numerical_damping: backward Euler's own, in closed form; dissipated_numerical: the rest the "
          "integrator lost).")
      // Checkpoints.
      .def(
          "save_checkpoint",
          [](py::object self, const std::string& path) {
            save_checkpoint(path, std::string("{\"format\": \"qbond-python\", \"qbond_version\": \"") + QBOND_VERSION + "\"}",
                            of(self).sim->world().state);
            of(self).sim->forget_history();  // as a run restored from it starts
          },
          py::arg("path"),
          "Writes the exact state to a checkpoint file; restore_checkpoint continues bit for bit. Drops a kept "
          "multigrid hierarchy (not in the file), built again on the next step as a restored run builds it.")
      .def(
          "restore_checkpoint",
          [](py::object self, const std::string& path) {
            put_state(*of(self).sim, load_checkpoint(path).state, path + ": ");
          },
          py::arg("path"), "Puts the simulation back in a checkpoint's state. Raises CheckpointError.")
      .def(
          "state_bytes",
          [](py::object self) {
            of(self).sim->forget_history();  // as a run set from these bytes starts
            return py::bytes(serialize_state(of(self).sim->world().state));
          },
          "The exact state as bytes (what a checkpoint holds); set_state_bytes continues bit for bit. Drops a kept "
          "multigrid hierarchy, built again on the next step, as save_checkpoint does.")
      .def(
          "set_state_bytes",
          [](py::object self, const py::bytes& b) {
            put_state(*of(self).sim, deserialize_state(std::string(b)), "");
          },
          py::arg("state"), "Puts back a state state_bytes returned. Raises CheckpointError.")
      .def("__repr__", [](py::object self) {
        const World& w = of(self).sim->world();
        return "<qbond.Simulation " + std::to_string(w.num_quanta()) + " quanta, step " + std::to_string(w.state.step) + ">";
      });
}

}  // namespace qbond::python
