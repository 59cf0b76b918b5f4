#pragma once
// The viewer's class, shared by the files that implement it by concern: viewer.cpp (the window
// and the frame loop), viewer_pacing.cpp (stepping in real time), viewer_input.cpp (mouse, keys
// and scripted input), viewer_draw.cpp (the scene) and viewer_panel.cpp (the ImGui panel).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "camera.hpp"
#include "colors.hpp"
#include "menus.hpp"
#include "qbond/io/scene.hpp"
#include "qbond/simulation/interaction.hpp"
#include "qbond/simulation/simulation.hpp"
#include "renderer.hpp"
#include "replay.hpp"
#include "script.hpp"
#include "viewer.hpp"

struct GLFWwindow;

namespace qbond::view {

using Clock = std::chrono::steady_clock;

inline constexpr int kPanelWidth = 330;       // [px] the ImGui panel on the right
inline constexpr double kFrameRate = 60;      // frames per second the viewer aims at
inline constexpr double kPhysicsBudget = 0.7; // share of a frame the physics may take before it falls behind
inline constexpr std::size_t kHistory = 300;  // samples kept for the panel's plots

/// Wall time since t0 [s].
inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// The measured frame, physics and drawing times of a run, and what it simulated.
struct Timing {
  std::vector<double> frame_ms, physics_ms, render_ms;
  std::uint64_t steps = 0;
  double simulated = 0;  ///< [s]
};

/// Radius to draw quanta with (viewer_draw.cpp).
double draw_radius(const Scene& scene, double size);
/// Appends a sample to a plot's history, keeping the last kHistory (viewer_panel.cpp).
void push_history(std::deque<float>& d, double x);
/// Sends the window's mouse, key and scroll events to the Viewer in its user pointer, unless ImGui
/// wants them (viewer_input.cpp).
void install_callbacks(GLFWwindow* window);

/// The viewer: a scene stepped in real time, drawn, and pulled on with the mouse.
class Viewer {
 public:
  /// Starts the scene, or with `replay` shows that run's frames instead of stepping (the scene
  /// then gives the ground, obstacles and camera); the framebuffer is fb_w × fb_h pixels.
  Viewer(Scene scene, std::unique_ptr<Replay> replay, std::vector<ScriptEvent> script, const ViewOptions& o, int fb_w,
         int fb_h);

  /// One frame f: scripted input, physics, drawing.
  void frame(std::uint64_t f, Timing& timing);
  /// The width left of the panel [px].
  int viewport_width() const { return std::max(1, fb_w_ - (opt_.ui ? kPanelWidth : 0)); }
  /// The framebuffer's new size [px].
  void resize(int w, int h) { fb_w_ = w, fb_h_ = h; }
  /// The blow-up message of the last step that blew up ("": none since the last reset).
  const std::string& blowup() const { return blowup_; }
  /// The user id of the quanta the mouse last grabbed (-1: none).
  long long last_grab() const { return last_grab_; }
  /// The world as stepped so far, or the replay's frame shown.
  const World& world() const { return replay_ ? replay_->world() : sim_->world(); }
  /// The replay, or null for a live scene.
  const Replay* replay() const { return replay_.get(); }
  /// The camera.
  const OrbitCamera& camera() const { return cam_; }
  /// Pixel box [x0, y0, x1, y1] (origin top left of the window) of the free and kinematic quanta.
  std::array<float, 4> quanta_box() const;
  // Input from GLFW callbacks (not called when ImGui wants the mouse or the keyboard).
  /// A key press (GLFW key code).
  void key(int k);
  /// A mouse button pressed or released at (mx, my) [px]: grabs a quanta, or orbits or pans.
  void mouse_button(int button, bool press, double mx, double my, bool shift);
  /// The mouse moved to (mx, my) [px]: moves the pull spring's target, or the camera.
  void mouse_move(double mx, double my);
  /// The wheel turned by dy: zooms.
  void scroll(double dy) { cam_.zoom(std::pow(0.9f, static_cast<float>(dy))); }

 private:
  enum class Mode { none, orbit, pan };

  // The scene and the frame (viewer.cpp)
  /// The box [lo, hi] of points x (0 for none).
  static void bounds(const std::vector<Vec3>& x, Vec3& lo, Vec3& hi);
  /// Aims at the quanta and, below them, the ground planes they will land on.
  void frame_camera();
  /// Rebuilds the simulation from the scene's initial world with the panel's settings; a replay
  /// goes back to its first frame.
  void reset();
  /// Puts the camera where the scene's `camera` and the command line's say (they win key by key).
  void apply_camera();
  /// Shows replay frame k (clamped to the last) and sets the playback clock to its time.
  void show_frame(std::size_t k);
  /// Scales the alive model's bonds to the panel's factors (the initial world keeps the originals).
  void rescale();

  // Stepping in real time (viewer_pacing.cpp)
  /// Steps the simulation for one frame; returns the wall time spent [s].
  double advance(Timing& timing);
  /// One step of the scene's timestep h; with the scene's `adaptive` section, as many
  /// error-controlled steps as it takes to advance by h (they never grow past it).
  void step();
  /// Simulated over wall time of the recent frames.
  double real_time_factor() const;
  /// A replay's frame: the next one headless, the one the playback clock has reached otherwise.
  double advance_replay(Timing& timing);

  // Mouse, keys and scripted input (viewer_input.cpp)
  /// Plays one scripted event as the input it stands for.
  void play(const ScriptEvent& e);
  /// Grabs the free quanta under pixel (mx, my) with the pull spring; whether one was there.
  bool grab(double mx, double my);
  /// The point under pixel (mx, my) at the grabbed quanta's depth.
  Vec3 point_at_depth(double mx, double my) const;

  // Drawing (viewer_draw.cpp)
  /// Draws the scene and the ImGui windows.
  void draw();
  /// Obstacles, and the ground under the structure wherever it has gone: planes as a checkered
  /// square of three scene sizes, or without one a reference grid at the scene's starting floor.
  /// Both are patterned in world coordinates, so that motion over them shows. A plane seen from
  /// its solid side is left out: a tank's near walls would hide what is inside it (liquid_blob).
  void draw_ground();
  /// A container (a gas's box or sphere) as its edges, so that what it holds stays visible:
  /// a box's twelve edges, a sphere's three great circles.
  void container(const Obstacle& ob);
  /// A power of ten near a tenth of the scene size, the grid's and checker's cell [m].
  double cell_size() const { return std::pow(10.0, std::floor(std::log10(0.3 * size_))); }

  // The ImGui panel (viewer_panel.cpp)
  /// The panel on the right.
  void panel();
  /// The panel's physics settings (live scenes).
  void physics_controls();
  /// The panel's time slider, play/pause and step buttons, and playback speed (replays).
  void replay_controls();
  /// Colour bars of what the bonds and quanta show: in the panel, or over the view without one.
  void legend();
  /// The help window (h).
  void help();

  Scene scene_;
  std::unique_ptr<Replay> replay_;
  ViewOptions opt_;
  int fb_w_, fb_h_;
  World initial_;
  IntegratorConfig config_;
  double h_;
  std::vector<ScriptEvent> script_;
  std::unique_ptr<Simulation> sim_;
  Renderer renderer_;
  OrbitCamera cam_;
  std::vector<Obstacle> obstacles_;
  Vec3 lo_, hi_;
  Vec3f last_centre_ = Vec3f::Constant(std::numeric_limits<float>::quiet_NaN());  // the box's centre at the last frame
  double size_ = 1, radius_ = 0.01;
  bool camera_fixed_ = false;  ///< a camera the scene or the command line placed: not moved to keep bodies in view
  double replay_clock_ = 0;    ///< [s] the replay's playback time
  float replay_speed_ = 1;     ///< replay: simulated seconds per wall second
  std::uint64_t replay_frames_ = 0;  ///< headless replay: viewer frames drawn so far

  std::size_t next_event_ = 0;
  std::optional<PullSpring> drag_;
  std::optional<std::pair<Index, Vec3>> push_;
  double grab_depth_ = 0;
  long long last_grab_ = -1;
  Mode mode_ = Mode::none;
  double last_mx_ = 0, last_my_ = 0;

  bool paused_ = false, single_step_ = false, help_ = false, heuristics_on_ = true, follow_ = opt_.follow;
  float stiffness_scale_ = 1, damping_scale_ = 1;
  float pull_hz_ = 4;  ///< the mouse spring's frequency for the pulled body (interaction.hpp)
  Vec3 gravity_;
  std::string blowup_;
  double debt_ = 0;
  std::optional<Clock::time_point> last_frame_;
  std::deque<std::pair<double, double>> rt_samples_;  ///< (wall, simulated) seconds of recent frames
  int steps_last_frame_ = 0;

  BondColor bond_color_ = opt_.bonds;
  QuantaColor quanta_color_ = opt_.quanta;
  AutoRange bond_range_, quanta_range_;
  std::deque<float> energy_, kinetic_, step_ms_;

  std::vector<double> tension_, strain_, mises_, magnitudes_;
  std::vector<Mat3> sigma_;
  std::vector<SphereInstance> spheres_;
  std::vector<LineVertex> lines_;

  const Menu<IntegratorType> integrator_menu_ = integrator_menu();
  const Menu<NeighbourModel> neighbour_menu_ = neighbour_menu();
  const Menu<Preconditioner> preconditioner_menu_ = preconditioner_menu();
};

}  // namespace qbond::view
