#pragma once
/// Scene files (every key in docs/scene-format.md): one JSON document describing a
/// world, how to step it and what to output. Loading is strict: every error names the JSON path
/// and the rule it breaks, and nothing is built from a scene that has one.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "qbond/integrators/adaptive.hpp"
#include "qbond/heuristics/registry.hpp"
#include "qbond/integrators/integrators.hpp"
#include "qbond/simulation/simulation.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

/// A scene error: what() is "SOURCE: PATH: RULE", e.g.
/// "beam.json: bodies[2].spacing: must be > 0, got -0.01".
class SceneError : public std::runtime_error {
 public:
  SceneError(const std::string& source, std::string path, std::string rule);
  std::string path;  ///< JSON path ("bodies[2].spacing"); empty for the document itself
  std::string rule;  ///< the rule broken
};

/// A probe of the scene's output: a named selection (probes.hpp measures it).
struct ProbeSpec {
  std::string name;
  std::vector<Index> quanta;
  std::optional<Vec3> about;  ///< torque reference point
};

/// The scene's `output` section.
struct OutputSpec {
  std::string dir = "out";             ///< relative to the current directory
  std::uint64_t every = 1;             ///< steps between rows and frames
  bool vtk = true;                     ///< write ParaView frames
  std::uint64_t checkpoint_every = 0;  ///< steps between checkpoints (0: end and stops only)
  std::vector<ProbeSpec> probes;
};

/// The scene's `camera`: how `qbond view` looks at it (runs ignore it). Position and target come
/// together or not at all; without them the viewer frames the scene itself.
struct CameraSpec {
  std::optional<Vec3> position, target;  ///< the eye and the point it looks at [m]
  std::optional<double> fov;             ///< vertical field of view [degrees], in (0, 180)
};

/// Why a camera at `position` looking at `target` cannot be used, or "" when it can: the two
/// points must differ, and the view must not be within kCameraVerticalLimit of straight up or
/// down (z is the picture's up, which a vertical view leaves undefined).
std::string camera_problem(const Vec3& position, const Vec3& target);
/// Closest a camera's view may come to vertical [rad].
inline constexpr double kCameraVerticalLimit = 0.01;

/// A loaded scene: the world built, the run's parameters, and the scene with every default
/// filled in (`resolved`: what run.json and checkpoints record; it rebuilds the same world).
struct Scene {
  std::string name, description;
  std::uint64_t seed = 1;
  double timestep = 0;      ///< [s]
  std::uint64_t steps = 0;  ///< from `steps`, or ceil(duration / timestep)
  IntegratorConfig integrator;
  AdaptiveConfig adaptive;  ///< `adaptive`: error-controlled steps; the run then ends at time
                            ///< steps × timestep (its horizon) rather than after `steps` steps
  BlowupLimits limits;
  World world;
  std::vector<HeuristicSpec> heuristics;  ///< in the order the step applies them
  OutputSpec output;
  CameraSpec camera;
  nlohmann::json resolved;
};

/// How a scene is loaded: where the files it names (a mesh body's `file`) are read from, and the
/// memory its run may take.
struct SceneFiles {
  std::filesystem::path dir{};  ///< relative paths are relative to it (empty: to the current directory)
  bool builtin = false;       ///< relative paths name the files of scenes/ compiled in (built-in scenes)
  /// Bytes the run may take (estimated_run_memory, memory.hpp), checked body by body before each
  /// is built and for the whole world once built; 0: default_memory_limit().
  std::uint64_t max_memory = 0;
};

/// The most steps a run may count: 2^53, the last count whose time t = step · h a double still
/// tells apart from the next.
inline constexpr std::uint64_t kMaxSteps = std::uint64_t{1} << 53;

/// The steps a run of `duration` at `timestep` takes: ceil(duration / timestep), a length within
/// 1e-9 of a step over a whole count of steps counted as that count. Throws std::invalid_argument
/// when that is not a count from 1 to kMaxSteps (a duration shorter than one step, or a count
/// that overflows: 1e308 s at 1 ms, 1 s at 5e-324 s).
std::uint64_t steps_for_duration(double duration, double timestep);

/// Parses a scene from JSON text; `source` names it in errors. Throws SceneError.
Scene parse_scene(std::string_view json_text, const std::string& source = "<string>", const SceneFiles& files = {});
/// Loads a scene file; its name defaults to the file's stem, and the files it names are relative
/// to its directory. Throws SceneError (naming the file: also when it is missing, not a regular
/// file, or larger than kMaxInputBytes).
Scene load_scene(const std::filesystem::path& file, std::uint64_t max_memory = 0);

/// Largest stable step of symplectic Euler for the scene's bonds: 2/ω_max, with ω_max² bounded
/// by Gershgorin's theorem, max over free quanta of 2 Σ k_b / m_i (k_b the bond's stiffness at
/// rest: k for linear bonds, F/ε² for inverse ones; damping ignored). Infinite without bonds.
double explicit_step_hint(const World& world);

/// What `qbond validate` prints: counts, mass, bounding box, step and stability hint.
std::string scene_summary(const Scene& scene);

/// A `type` a scene section accepts: its name, one line on what it makes, and every key an entry
/// of that type may hold (`type` included), as the scene reader checks them.
struct SceneType {
  std::string_view type;
  std::string_view doc;
  std::vector<std::string_view> keys;
};
/// The `heuristics` section's types, in the reader's order (its table: src/io/scene/heuristics.cpp).
const std::vector<SceneType>& heuristic_types();
/// The `bodies` section's types, in the reader's order (its table: src/io/scene/bodies.cpp); the
/// keys include the placement keys every body takes.
const std::vector<SceneType>& body_types();

}  // namespace qbond
