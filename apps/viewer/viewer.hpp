#pragma once
/// `qbond view`: the real-time interactive viewer (docs/viewer.md). A window (GLFW, OpenGL 3.3 core,
/// Dear ImGui) that steps a scene at its fixed timestep, as many steps per frame as real time
/// asks and the frame budget allows, draws it, and lets the mouse pull on it.
#include <cstdint>
#include <string>

#include "colors.hpp"
#include "qbond/io/scene.hpp"

namespace qbond::view {

struct ViewOptions {
  std::uint64_t frames = 0;    ///< headless: stop after this many frames (0: until the window closes)
  std::string screenshot;      ///< PNG of the last frame
  std::string record;          ///< directory for a PNG of every frame (frame_00000.png, ...)
  std::string script;          ///< scripted input (script.hpp)
  std::string stats;           ///< JSON of the measured frame and step times, written at the end
  std::string save;            ///< VTK PolyData of the final state
  int width = 1280, height = 720;
  int steps_per_frame = 0;     ///< with `frames`: steps per frame (0: 1/60 s of simulated time)
  bool ui = true;              ///< draw the ImGui panel
  bool follow = false;         ///< keep the camera aimed at the quanta's box
  BondColor bonds = BondColor::strain;
  QuantaColor quanta = QuantaColor::body;
  CameraSpec camera;           ///< from the command line: overrides the scene's `camera`, key by key
  std::string replay;          ///< a finished run to replay (its series.pvd or its directory) instead of a scene
  double replay_time = 0;      ///< replay: start at the last frame at or before this time [s]
};

/// Runs the viewer on a scene, or on the run `options.replay` names (then `scene` is ignored);
/// returns the program's exit code (3 when a headless run blew up). Throws std::runtime_error
/// when no window can be opened, std::invalid_argument on bad options, VtkReadError on a replay's
/// unreadable frame.
int run_viewer(Scene scene, const ViewOptions& options);

}  // namespace qbond::view
