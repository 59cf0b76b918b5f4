#pragma once
/// Built-in scenes: the files of scenes/ compiled into the library (one source of truth for
/// `qbond run`, the viewer, the benchmarks and the tests), and the performance workload.
#include <span>
#include <string_view>

#include "qbond/io/scene.hpp"

namespace qbond {

/// A scene file compiled into the library.
struct BuiltinScene {
  std::string_view name;         ///< file name without .json
  std::string_view description;  ///< the scene's "description"
  std::string_view json;         ///< the file's text
};

/// Every scene of scenes/, sorted by name (generated at build time by cmake/embed_scenes.cmake).
std::span<const BuiltinScene> builtin_scenes();

/// A file in a subdirectory of scenes/ (the meshes of scenes/meshes/) compiled into the library,
/// so that built-in scenes find the files they name.
struct BuiltinFile {
  std::string_view path;  ///< relative to scenes/, e.g. "meshes/torus.obj"
  std::string_view data;  ///< the file's bytes
};

/// Every file in a subdirectory of scenes/, sorted by path (generated with builtin_scenes()).
std::span<const BuiltinFile> builtin_files();

/// The scene `qbond run` and `qbond view` use when given none: the paper's Figure 10 pendulum.
inline constexpr std::string_view kDefaultScene = "pendulum";

/// Parses a built-in scene (its relative file paths name builtin_files()). Throws
/// std::invalid_argument listing the names when unknown. `max_memory` as in SceneFiles.
Scene builtin_scene(std::string_view name, std::uint64_t max_memory = 0);

/// The canonical performance workload (docs/performance.md): n×n×n simple-cubic lattice, spacing 0.01 m,
/// 1 g quanta, linear bonds to nearest and face-diagonal neighbours (k = 1000 N/m, axial damping
/// 0.01 N·s/m), x = 0 face anchored, gravity -9.81 m/s² along z, h = 1e-4 s, 1000 steps.
Scene canonical_lattice(int n);

}  // namespace qbond
