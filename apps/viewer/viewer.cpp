// `qbond view`'s window and frame loop; the viewer's concerns are in viewer_pacing.cpp,
// viewer_input.cpp, viewer_draw.cpp and viewer_panel.cpp (viewer_app.hpp declares the class).
#include "viewer.hpp"

#include "gl.hpp"
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>
#include <stb_image_write.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include "qbond/io/files.hpp"
#include "qbond/io/vtk.hpp"
#include "qbond/model/ordering.hpp"
#include "viewer_app.hpp"

namespace qbond::view {

namespace {
namespace fs = std::filesystem;

std::string glfw_error() {
  const char* what = nullptr;
  glfwGetError(&what);
  return what ? what : "unknown GLFW error";
}

/// Writes the current framebuffer (w × h, bottom-up) as a PNG, atomically.
void save_png(const fs::path& path, int w, int h) {
  std::vector<unsigned char> rgb(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, w, h, GL_RGB, GL_UNSIGNED_BYTE, rgb.data());
  std::string png;
  // OpenGL's rows run bottom-up; PNG's top-down: start at the last row, negative stride.
  const unsigned char* top = rgb.data() + static_cast<std::ptrdiff_t>(h - 1) * w * 3;
  stbi_write_png_to_func(
      [](void* ctx, void* data, int size) { static_cast<std::string*>(ctx)->append(static_cast<char*>(data), static_cast<std::size_t>(size)); },
      &png, w, h, 3, top, -w * 3);
  if (png.empty()) throw std::runtime_error("could not encode " + path.string());
  write_file_atomic(path, png);
}

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::ptrdiff_t>(std::min<double>(static_cast<double>(v.size() - 1), p * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

}  // namespace

Viewer::Viewer(Scene scene, std::unique_ptr<Replay> replay, std::vector<ScriptEvent> script, const ViewOptions& o,
               int fb_w, int fb_h)
    : scene_(std::move(scene)), replay_(std::move(replay)), opt_(o), fb_w_(fb_w), fb_h_(fb_h), initial_(scene_.world),
      config_(scene_.integrator), h_(scene_.timestep), script_(std::move(script)) {
  // Every obstacle is drawn, whichever way it is held: heuristics (projection) and the model's
  // (implicit, inside the step's solve).
  for (const HeuristicSpec& hs : scene_.heuristics)
    if (const auto* ob = std::get_if<Obstacle>(&hs)) obstacles_.push_back(*ob);
  for (const Obstacle& ob : initial_.model.obstacles) obstacles_.push_back(ob);
  bounds(initial_.state.x, lo_, hi_);
  size_ = std::max((hi_ - lo_).norm(), 1e-3);
  radius_ = draw_radius(scene_, size_);
  size_ = std::max(size_, 20 * radius_);  // a lone quanta still gets a ground to stand over
  gravity_ = initial_.model.gravity;
  if (replay_) show_frame(replay_->at_time(opt_.replay_time));
  else reset();
  apply_camera();
}

void Viewer::apply_camera() {
  // The command line's keys win over the scene's.
  const CameraSpec& placed = opt_.camera.position ? opt_.camera : scene_.camera;
  const std::optional<double>& fov = opt_.camera.fov ? opt_.camera.fov : scene_.camera.fov;
  if (fov) cam_.fov_y = static_cast<float>(*fov * std::numbers::pi / 180);
  frame_camera();  // with the field of view chosen
  if (placed.position && placed.target) {
    cam_.look_at(placed.position->cast<float>(), placed.target->cast<float>());
    camera_fixed_ = true;
  }
}

void Viewer::show_frame(std::size_t k) {
  k = std::min(k, replay_->size() - 1);
  replay_->load(k);
  replay_clock_ = replay_->time(k);
}

void Viewer::frame(std::uint64_t f, Timing& timing) {
  for (; next_event_ < script_.size() && script_[next_event_].frame <= f; ++next_event_) play(script_[next_event_]);
  timing.physics_ms.push_back(1e3 * advance(timing));
  const auto t0 = Clock::now();
  draw();
  timing.render_ms.push_back(1e3 * seconds_since(t0));
}

std::array<float, 4> Viewer::quanta_box() const {
  std::array<float, 4> box = {1e9f, 1e9f, -1e9f, -1e9f};
  const float w = static_cast<float>(viewport_width()), h = static_cast<float>(fb_h_);
  for (const Vec3& x : world().state.x) {
    float px = 0, py = 0;
    if (!cam_.to_pixel(x.cast<float>(), w, h, px, py)) continue;
    box = {std::min(box[0], px), std::min(box[1], py), std::max(box[2], px), std::max(box[3], py)};
  }
  return box;
}

void Viewer::bounds(const std::vector<Vec3>& x, Vec3& lo, Vec3& hi) {
  lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (const Vec3& p : x) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  if (x.empty()) lo = hi = Vec3::Zero();
}

void Viewer::frame_camera() {
  Vec3 lo, hi;
  bounds(world().state.x, lo, hi);
  const Vec3 c = (lo + hi) / 2;
  for (const Obstacle& ob : obstacles_) {
    if (ob.shape != Obstacle::Shape::plane) continue;
    const Vec3 n = ob.normal.normalized();
    const Vec3 below = c - (c - ob.center).dot(n) * n;
    lo = lo.cwiseMin(below), hi = hi.cwiseMax(below);
  }
  lo.array() -= radius_, hi.array() += radius_;
  cam_.frame(lo.cast<float>(), hi.cast<float>(), static_cast<float>(viewport_width()) / static_cast<float>(std::max(fb_h_, 1)));
}

void Viewer::reset() {
  if (replay_) {
    show_frame(0);
    return;
  }
  World w = initial_;
  for (std::size_t b = 0; b < w.num_bonds(); ++b) {
    w.state.bonds.strength[b] *= stiffness_scale_;
    w.state.bonds.damping[b] *= damping_scale_;
  }
  w.model.gravity = gravity_;
  sim_ = std::make_unique<Simulation>(std::move(w), config_, h_);
  sim_->limits() = scene_.limits;
  if (heuristics_on_)
    for (const HeuristicSpec& hs : scene_.heuristics) sim_->add_heuristic(make_heuristic(hs));
  drag_.reset();
  push_.reset();
  blowup_.clear();
  debt_ = 0;
  bond_range_.reset(), quanta_range_.reset();
  energy_.clear(), kinetic_.clear(), step_ms_.clear();
}

void Viewer::rescale() {
  State& s = sim_->world().state;  // strengths and dampings: read every step, no topology change
  for (std::size_t b = 0; b < std::min(s.bonds.size(), initial_.num_bonds()); ++b) {
    s.bonds.strength[b] = initial_.state.bonds.strength[b] * stiffness_scale_;
    s.bonds.damping[b] = initial_.state.bonds.damping[b] * damping_scale_;
  }
  drop_after_bond_edit(sim_->world().state.carry);  // velocity_verlet's forces were for the old ones
}

namespace {

nlohmann::json stats_json(const Timing& t, const Viewer& v, int fb_w, int fb_h) {
  const double frame = mean(t.frame_ms);
  const double wall = 1e-3 * std::accumulate(t.frame_ms.begin(), t.frame_ms.end(), 0.0);
  const auto box = v.quanta_box();
  return {
      {"frames", t.frame_ms.size()},
      {"steps", t.steps},
      {"simulated_seconds", t.simulated},
      {"frame_ms", {{"mean", frame}, {"median", percentile(t.frame_ms, 0.5)}, {"p95", percentile(t.frame_ms, 0.95)}}},
      {"physics_ms_per_frame", mean(t.physics_ms)},
      {"render_ms_per_frame", mean(t.render_ms)},
      {"fps", frame > 0 ? 1e3 / frame : 0.0},
      {"real_time_factor", wall > 0 ? t.simulated / wall : 0.0},
      {"framebuffer", {fb_w, fb_h}},
      {"viewport", {0, 0, v.viewport_width(), fb_h}},
      {"quanta_px", {box[0], box[1], box[2], box[3]}},
      {"gl_renderer", reinterpret_cast<const char*>(glGetString(GL_RENDERER))},
      {"blowup", v.blowup()},
      {"last_grab", v.last_grab()},
      {"camera",
       {{"eye", {v.camera().eye().x(), v.camera().eye().y(), v.camera().eye().z()}},
        {"target", {v.camera().target.x(), v.camera().target.y(), v.camera().target.z()}},
        {"fov", v.camera().fov_y * 180 / std::numbers::pi}}},
      {"replay", v.replay() ? nlohmann::json{{"frame", v.replay()->index()},
                                             {"frames", v.replay()->size()},
                                             {"time", v.replay()->time(v.replay()->index())}}
                            : nlohmann::json(nullptr)},
  };
}

}  // namespace

int run_viewer(Scene scene, const ViewOptions& o) {
  if (o.width < 64 || o.height < 64) throw std::invalid_argument("window size must be at least 64 x 64");
  // Bad input is refused before a window opens.
  if (o.camera.position.has_value() != o.camera.target.has_value())
    throw std::invalid_argument("--camera-position and --camera-target go together: give both or neither");
  if (o.camera.position)
    if (const std::string p = camera_problem(*o.camera.position, *o.camera.target); !p.empty())
      throw std::invalid_argument("--camera-position, --camera-target: " + p);
  if (o.camera.fov && !(*o.camera.fov > 0 && *o.camera.fov < 180)) {
    char got[32];
    std::snprintf(got, sizeof got, "%g", *o.camera.fov);
    throw std::invalid_argument(std::string("--camera-fov must be in (0, 180) degrees, got ") + got);
  }
  std::unique_ptr<Replay> replay;
  if (!o.replay.empty()) {
    // A recorded run cannot be pushed, pulled or changed: only watched.
    for (const auto& [set, name] : {std::pair{!o.script.empty(), "--script"}, std::pair{!o.save.empty(), "--save"},
                                    std::pair{o.steps_per_frame > 0, "--steps-per-frame"}})
      if (set) throw std::invalid_argument(std::string(name) + " does not apply to a replay (" + o.replay + ")");
    replay = std::make_unique<Replay>(o.replay);
    std::string note;
    scene = replay_scene(*replay, note);
    if (!note.empty()) std::fprintf(stderr, "qbond view: %s\n", note.c_str());
  } else if (o.replay_time != 0) {
    throw std::invalid_argument("--time applies to a replay (a run directory or its series.pvd)");
  }
  std::vector<ScriptEvent> script;
  if (!o.script.empty()) {
    if (!fs::is_regular_file(o.script)) throw std::invalid_argument("script " + o.script + ": no such file");
    script = parse_script(read_file(o.script), o.script, scene.world.num_quanta());
    // Scripts name quanta by user id, the world may be renumbered (ordering.hpp).
    const std::vector<Index> at = quanta_by_id(scene.world.model);
    if (!at.empty())
      for (ScriptEvent& e : script) e.quanta = at[e.quanta];  // 0 (unused) in events without a quanta
  }
  if (!o.record.empty()) fs::create_directories(o.record);
  if (!glfwInit())
    throw std::runtime_error("cannot open a window (" + glfw_error() +
                             "); set DISPLAY, or run headless under Xvfb: xvfb-run -a qbond view ...");
  struct GlfwGuard {
    ~GlfwGuard() { glfwTerminate(); }
  } glfw_guard;
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  const std::string title = "qbond view: " + scene.name;
  GLFWwindow* window = glfwCreateWindow(o.width, o.height, title.c_str(), nullptr, nullptr);
  if (!window) throw std::runtime_error("cannot create an OpenGL 3.3 core window: " + glfw_error());
  glfwMakeContextCurrent(window);
  glfwSwapInterval(o.frames > 0 ? 0 : 1);  // headless runs measure what the machine can do

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the user's directory
  ImGui::StyleColorsDark();
  int exit_code = 0;
  {
    int fb_w = 0, fb_h = 0;
    glfwGetFramebufferSize(window, &fb_w, &fb_h);
    Viewer viewer(std::move(scene), std::move(replay), std::move(script), o, std::max(fb_w, 1), std::max(fb_h, 1));
    glfwSetWindowUserPointer(window, &viewer);
    install_callbacks(window);
    ImGui_ImplGlfw_InitForOpenGL(window, true);  // chains to the callbacks above
    ImGui_ImplOpenGL3_Init("#version 330 core");

    Timing timing;
    auto last = Clock::now();
    for (std::uint64_t f = 0; (o.frames == 0 || f < o.frames) && !glfwWindowShouldClose(window); ++f) {
      glfwPollEvents();
      glfwGetFramebufferSize(window, &fb_w, &fb_h);
      viewer.resize(std::max(fb_w, 1), std::max(fb_h, 1));
      viewer.frame(f, timing);
      if (!o.record.empty()) save_png(fs::path(o.record) / ("frame_" + std::to_string(100000 + f).substr(1) + ".png"), fb_w, fb_h);
      if (o.frames > 0 && f + 1 == o.frames && !o.screenshot.empty()) save_png(o.screenshot, fb_w, fb_h);
      glfwSwapBuffers(window);
      const auto now = Clock::now();
      timing.frame_ms.push_back(1e3 * std::chrono::duration<double>(now - last).count());
      last = now;
    }
    const nlohmann::json stats = stats_json(timing, viewer, fb_w, fb_h);
    std::fprintf(stderr, "qbond view: %zu frames, %.2f ms/frame (%.0f fps; physics %.2f ms, drawing %.2f ms), %.2fx real time, on %s\n",
                 timing.frame_ms.size(), stats["frame_ms"]["mean"].get<double>(), stats["fps"].get<double>(),
                 stats["physics_ms_per_frame"].get<double>(), stats["render_ms_per_frame"].get<double>(),
                 stats["real_time_factor"].get<double>(), stats["gl_renderer"].get<std::string>().c_str());
    if (!o.stats.empty()) write_file_atomic(o.stats, stats.dump(2) + "\n");
    if (!o.save.empty()) write_vtp(o.save, viewer.world().model, viewer.world().state);
    if (!viewer.blowup().empty()) {
      std::fprintf(stderr, "qbond view: %s\n", viewer.blowup().c_str());
      if (o.frames > 0) exit_code = 3;
    }
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
  }
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
  return exit_code;
}

}  // namespace qbond::view
