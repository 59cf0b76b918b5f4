#include "viewer.hpp"

#include "gl.hpp"
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>
#include <stb_image_write.h>

#include <algorithm>
#include <array>
#include <cfloat>
#include <cstring>
#include <numbers>
#include <limits>
#include <numeric>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <vector>

#include "camera.hpp"
#include "colors.hpp"
#include "qbond/integrators/adaptive.hpp"
#include "qbond/analysis/analysis.hpp"
#include "qbond/io/files.hpp"
#include "qbond/simulation/interaction.hpp"
#include "qbond/model/ordering.hpp"
#include "qbond/analysis/stress.hpp"
#include "qbond/io/vtk.hpp"
#include "renderer.hpp"
#include "script.hpp"

namespace qbond::view {

namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr int kPanelWidth = 330;       // [px] the ImGui panel on the right
constexpr double kFrameRate = 60;      // frames per second the viewer aims at
constexpr double kPhysicsBudget = 0.7; // share of a frame the physics may take before it falls behind
constexpr std::size_t kHistory = 300;  // samples kept for the panel's plots

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

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

/// Radius to draw quanta with: the scene's contact radius when it has one, else 0.15 of a short
/// bond's length (the 10th percentile: nearest neighbours, so that bonds stay visible between
/// the spheres), else a fiftieth of the scene's size.
double draw_radius(const Scene& scene, double size) {
  for (const HeuristicSpec& h : scene.heuristics)
    if (const auto* c = std::get_if<QuantaContactRule>(&h)) return c->radius;
  const World& w = scene.world;
  if (w.num_bonds() > 0) {
    std::vector<double> r(w.num_bonds());
    for (std::size_t b = 0; b < r.size(); ++b) r[b] = (w.state.x[w.model.bond_j[b]] - w.state.x[w.model.bond_i[b]]).norm();
    const auto k = static_cast<std::ptrdiff_t>(r.size() / 10);
    std::nth_element(r.begin(), r.begin() + k, r.end());
    if (r[static_cast<std::size_t>(k)] > 0) return 0.15 * r[static_cast<std::size_t>(k)];
  }
  return std::max(0.02 * size, 1e-3);
}

struct Timing {
  std::vector<double> frame_ms, physics_ms, render_ms;
  std::uint64_t steps = 0;
  double simulated = 0;  ///< [s]
};

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

void push_history(std::deque<float>& d, double x) {
  d.push_back(static_cast<float>(x));
  if (d.size() > kHistory) d.pop_front();
}

void plot(const char* label, const std::deque<float>& d, const char* overlay) {
  const std::vector<float> v(d.begin(), d.end());
  ImGui::PlotLines(label, v.data(), static_cast<int>(v.size()), 0, overlay, FLT_MAX, FLT_MAX, ImVec2(0, 50));
}

class Viewer {
 public:
  Viewer(Scene scene, std::vector<ScriptEvent> script, const ViewOptions& o, int fb_w, int fb_h)
      : scene_(std::move(scene)), opt_(o), fb_w_(fb_w), fb_h_(fb_h), initial_(scene_.world), config_(scene_.integrator),
        h_(scene_.timestep), script_(std::move(script)) {
    for (const HeuristicSpec& hs : scene_.heuristics)
      if (const auto* ob = std::get_if<Obstacle>(&hs)) obstacles_.push_back(*ob);
    bounds(initial_.state.x, lo_, hi_);
    size_ = std::max((hi_ - lo_).norm(), 1e-3);
    radius_ = draw_radius(scene_, size_);
    gravity_ = initial_.model.gravity;
    reset();
    frame_camera();
  }

  /// One frame f: scripted input, physics, drawing.
  void frame(std::uint64_t f, Timing& timing) {
    for (; next_event_ < script_.size() && script_[next_event_].frame <= f; ++next_event_) play(script_[next_event_]);
    timing.physics_ms.push_back(1e3 * advance(timing));
    const auto t0 = Clock::now();
    draw();
    timing.render_ms.push_back(1e3 * seconds_since(t0));
  }

  int viewport_width() const { return std::max(1, fb_w_ - (opt_.ui ? kPanelWidth : 0)); }
  void resize(int w, int h) { fb_w_ = w, fb_h_ = h; }
  const std::string& blowup() const { return blowup_; }
  /// The user id of the quanta the mouse last grabbed (-1: none).
  long long last_grab() const { return last_grab_; }
  const World& world() const { return sim_->world(); }

  /// Pixel box [x0, y0, x1, y1] (origin top left of the window) of the free and kinematic quanta.
  std::array<float, 4> quanta_box() const {
    std::array<float, 4> box = {1e9f, 1e9f, -1e9f, -1e9f};
    const float w = static_cast<float>(viewport_width()), h = static_cast<float>(fb_h_);
    for (const Vec3& x : world().state.x) {
      float px = 0, py = 0;
      if (!cam_.to_pixel(x.cast<float>(), w, h, px, py)) continue;
      box = {std::min(box[0], px), std::min(box[1], py), std::max(box[2], px), std::max(box[3], py)};
    }
    return box;
  }

  // Input from GLFW callbacks (not called when ImGui wants the mouse or the keyboard).
  void key(int k) {
    switch (k) {
      case GLFW_KEY_SPACE: paused_ = !paused_; break;
      case GLFW_KEY_PERIOD: single_step_ = true; break;
      case GLFW_KEY_R: reset(); break;
      case GLFW_KEY_H: help_ = !help_; break;
      case GLFW_KEY_F: frame_camera(); break;
      default: break;
    }
  }
  void mouse_button(int button, bool press, double mx, double my, bool shift) {
    if (!press) {
      if (button == GLFW_MOUSE_BUTTON_LEFT && drag_) drag_.reset();
      mode_ = Mode::none;
      return;
    }
    last_mx_ = mx, last_my_ = my;
    if (button == GLFW_MOUSE_BUTTON_LEFT && !shift) {
      if (grab(mx, my)) return;
      mode_ = Mode::orbit;
    } else {
      mode_ = Mode::pan;
    }
  }
  void mouse_move(double mx, double my) {
    const double dx = mx - last_mx_, dy = my - last_my_;
    last_mx_ = mx, last_my_ = my;
    if (drag_) {
      drag_->target = point_at_depth(mx, my);
    } else if (mode_ == Mode::orbit) {
      cam_.orbit(static_cast<float>(dx), static_cast<float>(dy));
    } else if (mode_ == Mode::pan) {
      cam_.pan(static_cast<float>(dx), static_cast<float>(dy), static_cast<float>(fb_h_));
    }
  }
  void scroll(double dy) { cam_.zoom(std::pow(0.9f, static_cast<float>(dy))); }

 private:
  enum class Mode { none, orbit, pan };

  static void bounds(const std::vector<Vec3>& x, Vec3& lo, Vec3& hi) {
    lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
    for (const Vec3& p : x) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    if (x.empty()) lo = hi = Vec3::Zero();
  }

  /// Aims at the quanta and, below them, the ground planes they will land on.
  void frame_camera() {
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

  /// Rebuilds the simulation from the scene's initial world with the panel's settings.
  void reset() {
    World w = initial_;
    for (std::size_t b = 0; b < w.num_bonds(); ++b) {
      w.model.stiffness[b] *= stiffness_scale_;
      w.model.damping[b] *= damping_scale_;
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

  /// Scales the alive model's bonds to the panel's factors (the initial world keeps the originals).
  void rescale() {
    Model& m = sim_->world().model;
    for (std::size_t b = 0; b < std::min(m.num_bonds(), initial_.num_bonds()); ++b) {
      m.stiffness[b] = initial_.model.stiffness[b] * stiffness_scale_;
      m.damping[b] = initial_.model.damping[b] * damping_scale_;
    }
    drop_after_bond_edit(sim_->world().state.carry);  // velocity_verlet's forces were for the old ones
  }

  void play(const ScriptEvent& e) {
    const State& s = world().state;
    switch (e.kind) {
      case ScriptEvent::Kind::drag: {
        const Vec3 target = e.to ? *e.to : s.x[e.quanta] + *e.by;
        drag_ = make_pull_spring(world().model, e.quanta, target, body_mass(world().model, e.quanta), h_, pull_hz_);
        break;
      }
      case ScriptEvent::Kind::push: push_ = std::make_pair(e.quanta, e.force); break;
      case ScriptEvent::Kind::release: drag_.reset(), push_.reset(); break;
      case ScriptEvent::Kind::mouse_press: {
        float px = 0, py = 0;
        cam_.to_pixel(s.x[e.quanta].cast<float>(), static_cast<float>(viewport_width()), static_cast<float>(fb_h_), px, py);
        mouse_button(GLFW_MOUSE_BUTTON_LEFT, true, px, py, false);
        break;
      }
      case ScriptEvent::Kind::mouse_move: mouse_move(last_mx_ + e.pixels.x(), last_my_ + e.pixels.y()); break;
      case ScriptEvent::Kind::mouse_release: mouse_button(GLFW_MOUSE_BUTTON_LEFT, false, last_mx_, last_my_, false); break;
      case ScriptEvent::Kind::key:
        key(e.key == ' ' ? GLFW_KEY_SPACE : e.key == '.' ? GLFW_KEY_PERIOD : GLFW_KEY_A + (e.key - 'a'));
        break;
    }
  }

  bool grab(double mx, double my) {
    const Ray ray = cam_.ray(mx, my, viewport_width(), fb_h_);
    const Model& m = world().model;
    double best = 1e300;
    Index who = 0;
    for (std::size_t i = 0; i < m.num_quanta(); ++i) {
      if (m.is_kinematic(static_cast<Index>(i))) continue;
      const double t = hit_sphere(ray, world().state.x[i], 1.5 * radius_);
      if (t >= 0 && t < best) best = t, who = static_cast<Index>(i);
    }
    if (best == 1e300) return false;
    const Vec3 p = world().state.x[who];
    grab_depth_ = (p - ray.origin).dot((cam_.target - cam_.eye()).normalized().cast<double>());
    drag_ = make_pull_spring(m, who, p, body_mass(m, who), h_, pull_hz_);
    last_grab_ = static_cast<long long>(m.quanta_id[who]);  // reported as the user id
    return true;
  }

  Vec3 point_at_depth(double mx, double my) const {
    const Ray ray = cam_.ray(mx, my, viewport_width(), fb_h_);
    const Vec3 forward = (cam_.target - cam_.eye()).normalized().cast<double>();
    return ray.origin + ray.dir * (grab_depth_ / std::max(ray.dir.dot(forward), 1e-6));
  }

  /// Steps the simulation for one frame; returns the wall time spent [s].
  double advance(Timing& timing) {
    const auto t0 = Clock::now();
    int steps = 0;
    if (opt_.frames > 0) {  // headless: a fixed number of steps, the same for every run
      steps = opt_.steps_per_frame > 0 ? opt_.steps_per_frame
                                       : std::max(1, static_cast<int>(std::lround(1 / (kFrameRate * h_))));
      if (paused_ && !single_step_) steps = 0;
      if (single_step_) steps = 1;
      for (int k = 0; k < steps && blowup_.empty(); ++k) step();
    } else {  // interactive: keep up with the wall clock while the budget lasts
      const double wall = last_frame_ ? std::min(seconds_since(*last_frame_), 0.1) : 1 / kFrameRate;
      last_frame_ = Clock::now();
      if (single_step_) {
        step(), steps = 1;
      } else if (!paused_ && blowup_.empty()) {
        debt_ += wall;
        while (debt_ >= h_ && blowup_.empty()) {
          if (seconds_since(t0) > kPhysicsBudget / kFrameRate) {
            debt_ = 0;  // fall behind rather than stutter: the panel shows the real-time factor
            break;
          }
          step(), ++steps, debt_ -= h_;
        }
      }
      rt_samples_.push_back({wall, steps * h_});
      if (rt_samples_.size() > 60) rt_samples_.pop_front();
    }
    single_step_ = false;
    const double spent = seconds_since(t0);
    timing.steps += static_cast<std::uint64_t>(steps);
    timing.simulated += steps * h_;
    steps_last_frame_ = steps;
    if (steps > 0) push_history(step_ms_, 1e3 * spent / steps);
    const Energies e = energies(world().model, world().state);
    push_history(energy_, e.total());
    push_history(kinetic_, e.kinetic);
    return spent;
  }

  /// One step of the scene's timestep h; with the scene's `adaptive` section, as many
  /// error-controlled steps as it takes to advance by h (they never grow past it).
  void step() {
    auto forces = [&] {
      if (drag_) sim_->add_force(drag_->quanta, drag_->force(world().state));
      if (push_) sim_->add_force(push_->first, push_->second);
    };
    StepReport r;
    if (scene_.adaptive.enabled) {
      const double t1 = world().state.time + h_;
      while (world().state.time < t1 && r.status == StepReport::Status::ok) r = adaptive_step(*sim_, scene_.adaptive, t1, forces).step;
    } else {
      forces();
      r = sim_->step();
    }
    if (r.status == StepReport::Status::blowup) {
      blowup_ = r.message;
      paused_ = true;
    }
  }

  double real_time_factor() const {
    double wall = 0, sim = 0;
    for (const auto& [w, s] : rt_samples_) wall += w, sim += s;
    return wall > 0 ? sim / wall : 0;
  }

  void draw() {
    const int vw = viewport_width();
    {
      // The camera aims at the quanta's box with "camera follows"; otherwise, while the bodies
      // move, it keeps them in the middle of the view (a thrown body does not leave the window),
      // and a view the user moved away from bodies at rest stays where it is.
      Vec3 lo, hi;
      bounds(world().state.x, lo, hi);
      const Vec3f centre = ((lo + hi) / 2).cast<float>();
      if (follow_)
        cam_.target = centre;
      else if (centre != last_centre_)
        cam_.keep_in_view(centre, static_cast<float>(vw) / static_cast<float>(std::max(fb_h_, 1)), 0.6f);
      last_centre_ = centre;
    }
    renderer_.begin(0, 0, vw, fb_h_, cam_);
    const Model& m = world().model;
    const State& s = world().state;
    draw_ground();

    // Bonds.
    lines_.clear();
    if (bond_color_ != BondColor::none) bond_tension_strain(m, s, tension_, strain_);
    const std::vector<double>& value = bond_color_ == BondColor::tension ? tension_ : strain_;
    magnitudes_.clear();
    if (bond_color_ != BondColor::none)
      for (std::size_t b = 0; b < m.num_bonds(); ++b)
        if (s.alive[b]) magnitudes_.push_back(std::abs(value[b]));
    bond_range_.see(magnitudes_);
    for (std::size_t b = 0; b < m.num_bonds(); ++b) {
      if (!s.alive[b]) continue;
      const Vec3f c = bond_color_ == BondColor::none || bond_range_.hi <= 0 ? Vec3f(0.75f, 0.75f, 0.75f)
                                                                             : diverging(value[b] / bond_range_.hi);
      lines_.push_back({s.x[m.bond_i[b]].cast<float>(), c});
      lines_.push_back({s.x[m.bond_j[b]].cast<float>(), c});
    }
    renderer_.lines(lines_, 2);

    // Quanta.
    spheres_.clear();
    const bool stress = quanta_color_ == QuantaColor::von_mises;
    if (stress) {
      virial_stress(m, s, sigma_);
      mises_.resize(sigma_.size());
      for (std::size_t i = 0; i < sigma_.size(); ++i) mises_[i] = von_mises(sigma_[i]);
    }
    magnitudes_.clear();
    if (quanta_color_ != QuantaColor::body)
      for (std::size_t i = 0; i < m.num_quanta(); ++i)
        if (!m.is_kinematic(static_cast<Index>(i))) magnitudes_.push_back(stress ? mises_[i] : s.v[i].norm());
    quanta_range_.see(magnitudes_);
    for (std::size_t i = 0; i < m.num_quanta(); ++i) {
      const bool kin = m.is_kinematic(static_cast<Index>(i));
      Vec3f c = body_color(m.body[i]);
      if (kin) c = anchored_color();
      else if (quanta_color_ != QuantaColor::body && quanta_range_.hi > 0)
        c = sequential((stress ? mises_[i] : s.v[i].norm()) / quanta_range_.hi);
      spheres_.push_back({s.x[i].cast<float>(), static_cast<float>(radius_ * (kin ? 1.3 : 1.0)), c});
    }
    for (const Obstacle& ob : obstacles_)
      if (ob.shape == Obstacle::Shape::sphere && !ob.inside)
        spheres_.push_back({ob.center.cast<float>(), static_cast<float>(ob.radius), Vec3f(0.5f, 0.5f, 0.52f)});

    // The user's forces: the mouse spring and scripted pushes, as lines from the quanta.
    lines_.clear();
    if (drag_) {
      const Vec3f a = s.x[drag_->quanta].cast<float>(), b = drag_->target.cast<float>();
      lines_.push_back({a, Vec3f(1, 0.9f, 0.1f)});
      lines_.push_back({b, Vec3f(1, 0.9f, 0.1f)});
      spheres_.push_back({b, static_cast<float>(std::max(radius_, 0.01 * size_)), Vec3f(1, 0.9f, 0.1f)});
    }
    if (push_ && push_->second.norm() > 0) {
      const Vec3f a = s.x[push_->first].cast<float>();
      const Vec3f b = a + (0.25 * size_ * push_->second.normalized()).cast<float>();
      lines_.push_back({a, Vec3f(1, 0.3f, 0.9f)});
      lines_.push_back({b, Vec3f(1, 0.3f, 0.9f)});
    }
    renderer_.spheres(spheres_);
    renderer_.lines(lines_, 3);

    glViewport(0, 0, fb_w_, fb_h_);
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    if (opt_.ui) panel();
    else legend();
    if (help_) help();
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  }

  /// Obstacles, and the ground under the structure wherever it has gone: planes as a checkered
  /// square of three scene sizes, or without one a reference grid at the scene's starting floor.
  /// Both are patterned in world coordinates, so that motion over them shows. A plane seen from
  /// its solid side is left out: a tank's near walls would hide what is inside it (liquid_blob).
  void draw_ground() {
    bool plane = false;
    Vec3 lo, hi;
    bounds(world().state.x, lo, hi);
    const double cell = cell_size();
    const Vec3 centre = (((lo + hi) / 2) / cell).array().round().matrix() * cell;
    for (const Obstacle& ob : obstacles_) {
      if (ob.inside) {
        container(ob);
        continue;
      }
      if (ob.shape == Obstacle::Shape::box) {
        Mat4f model = Mat4f::Identity();
        model.block<3, 3>(0, 0) = (ob.rotation * ob.half_extents.asDiagonal()).cast<float>();
        model.block<3, 1>(0, 3) = ob.center.cast<float>();
        renderer_.box(model, Vec3f(0.5f, 0.5f, 0.52f));
      } else if (ob.shape == Obstacle::Shape::plane) {
        plane = true;
        // A square of three scene sizes under the scene, in the plane's own axes.
        const Vec3 n = ob.normal.normalized();
        const Vec3 a = n.unitOrthogonal(), b = n.cross(a);
        const Vec3 c = centre - (centre - ob.center).dot(n) * n;
        if (n.dot(cam_.eye().cast<double>() - c) < 0) continue;
        Mat4f model = Mat4f::Identity();
        model.block<3, 1>(0, 0) = (1.5 * size_ * a).cast<float>();
        model.block<3, 1>(0, 1) = (1.5 * size_ * b).cast<float>();
        model.block<3, 1>(0, 2) = n.cast<float>();
        model.block<3, 1>(0, 3) = c.cast<float>();
        renderer_.plane(model, Vec3f(0.42f, 0.44f, 0.40f), static_cast<float>(cell));
      }
    }
    if (plane) return;
    lines_.clear();
    const double half = 1.5 * size_;
    const int n = static_cast<int>(std::ceil(half / cell));
    const Vec3f grey(0.32f, 0.33f, 0.36f);
    for (int k = -n; k <= n; ++k) {
      const double o = k * cell;
      lines_.push_back({Vec3(centre.x() + o, centre.y() - half, lo_.z()).cast<float>(), grey});
      lines_.push_back({Vec3(centre.x() + o, centre.y() + half, lo_.z()).cast<float>(), grey});
      lines_.push_back({Vec3(centre.x() - half, centre.y() + o, lo_.z()).cast<float>(), grey});
      lines_.push_back({Vec3(centre.x() + half, centre.y() + o, lo_.z()).cast<float>(), grey});
    }
    renderer_.lines(lines_, 1);
  }

  /// A container (a gas's box or sphere) as its edges, so that what it holds stays visible:
  /// a box's twelve edges, a sphere's three great circles.
  void container(const Obstacle& ob) {
    lines_.clear();
    const Vec3f c(0.6f, 0.65f, 0.75f);
    if (ob.shape == Obstacle::Shape::box) {
      std::array<Vec3f, 3> axis;  // half edges in the world
      for (int a = 0; a < 3; ++a) axis[a] = (ob.half_extents[a] * ob.rotation.col(a)).cast<float>();
      const Vec3f centre = ob.center.cast<float>();
      auto corner = [&](int k) -> Vec3f {
        return centre + ((k & 1) ? 1.0f : -1.0f) * axis[0] + ((k & 2) ? 1.0f : -1.0f) * axis[1] +
               ((k & 4) ? 1.0f : -1.0f) * axis[2];
      };
      for (int k = 0; k < 8; ++k)
        for (int bit : {1, 2, 4})
          if (!(k & bit)) lines_.push_back({corner(k), c}), lines_.push_back({corner(k | bit), c});
    } else if (ob.shape == Obstacle::Shape::sphere) {
      constexpr int kSegments = 64;
      for (int axis = 0; axis < 3; ++axis)
        for (int k = 0; k < kSegments; ++k)
          for (int e : {k, k + 1}) {
            const double a = 2 * std::numbers::pi * e / kSegments;
            Vec3 p = Vec3::Zero();
            p[(axis + 1) % 3] = std::cos(a), p[(axis + 2) % 3] = std::sin(a);
            lines_.push_back({(ob.center + ob.radius * p).cast<float>(), c});
          }
    }
    renderer_.lines(lines_, 1.5f);
  }

  /// A power of ten near a tenth of the scene size, the grid's and checker's cell [m].
  double cell_size() const { return std::pow(10.0, std::floor(std::log10(0.3 * size_))); }

  void panel() {
    ImGui::SetNextWindowPos(ImVec2(static_cast<float>(fb_w_ - kPanelWidth), 0));
    ImGui::SetNextWindowSize(ImVec2(kPanelWidth, static_cast<float>(fb_h_)));
    ImGui::Begin("qbond", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
    const World& w = world();
    ImGui::Text("%s", scene_.name.c_str());
    ImGui::Text("t = %.3f s   step %llu", w.state.time, static_cast<unsigned long long>(w.state.step));
    const std::size_t alive = w.num_alive_bonds();
    ImGui::Text("quanta %zu  bonds %zu  broken %zu", w.num_quanta(), alive, w.num_bonds() - alive);
    if (!blowup_.empty()) ImGui::TextColored(ImVec4(1, 0.3f, 0.3f, 1), "BLOW-UP (r resets):\n%s", blowup_.c_str());
    else if (paused_) ImGui::TextColored(ImVec4(1, 0.8f, 0.2f, 1), "paused (space)");
    if (opt_.frames == 0) {
      const double rt = real_time_factor();
      if (rt < 0.95 && !paused_) ImGui::TextColored(ImVec4(1, 0.5f, 0.2f, 1), "behind: %.2fx real time", rt);
      else ImGui::Text("%.2fx real time", rt);
    }
    ImGui::Text("%.1f fps, %d steps/frame", static_cast<double>(ImGui::GetIO().Framerate), steps_last_frame_);
    ImGui::Separator();

    int type = static_cast<int>(config_.type);
    static constexpr const char* kTypes[] = {"explicit_euler", "symplectic_euler", "velocity_verlet", "rk4",
                                             "hybrid_implicit", "coupled_implicit"};
    bool changed = ImGui::Combo("integrator", &type, kTypes, IM_ARRAYSIZE(kTypes));
    config_.type = static_cast<IntegratorType>(type);
    if (config_.type == IntegratorType::hybrid_implicit) {
      int nm = static_cast<int>(config_.neighbours);
      static constexpr const char* kModels[] = {"frozen", "sweep", "jacobi"};
      changed |= ImGui::Combo("neighbours", &nm, kModels, IM_ARRAYSIZE(kModels));
      config_.neighbours = static_cast<NeighbourModel>(nm);
      changed |= ImGui::SliderInt("sweeps", &config_.iterations, 1, 50);
    } else if (config_.type == IntegratorType::coupled_implicit) {
      int sv = static_cast<int>(config_.solver);
      static constexpr const char* kSolvers[] = {"dense", "ldlt", "cg"};
      changed |= ImGui::Combo("solver", &sv, kSolvers, IM_ARRAYSIZE(kSolvers));
      config_.solver = static_cast<CoupledSolver>(sv);
      changed |= ImGui::SliderInt("max CG iter.", &config_.max_iterations, 0, 500);
    }
    if (changed) sim_->set_integrator(config_);
    float h = static_cast<float>(h_);
    if (ImGui::SliderFloat("timestep [s]", &h, 1e-6f, 0.05f, "%.2e", ImGuiSliderFlags_Logarithmic)) {
      h_ = h;
      sim_->set_timestep(h_);
    }
    if (ImGui::SliderFloat("stiffness x", &stiffness_scale_, 0.01f, 100, "%.2f", ImGuiSliderFlags_Logarithmic) |
        ImGui::SliderFloat("damping x", &damping_scale_, 0.0f, 100, "%.2f", ImGuiSliderFlags_Logarithmic))
      rescale();
    ImGui::SliderFloat("pull [Hz]", &pull_hz_, 0.5f, 20, "%.1f", ImGuiSliderFlags_Logarithmic);
    Vec3f g = gravity_.cast<float>();
    if (ImGui::InputFloat3("gravity", g.data(), "%.2f")) sim_->world().model.gravity = gravity_ = g.cast<double>();
    if (ImGui::Checkbox("heuristics", &heuristics_on_)) {
      sim_->clear_heuristics();
      if (heuristics_on_)
        for (const HeuristicSpec& hs : scene_.heuristics) sim_->add_heuristic(make_heuristic(hs));
    }
    ImGui::SameLine();
    ImGui::TextDisabled("(%zu)", scene_.heuristics.size());
    ImGui::SameLine();
    ImGui::Checkbox("camera follows", &follow_);
    ImGui::Separator();
    int bc = static_cast<int>(bond_color_), qc = static_cast<int>(quanta_color_);
    if (ImGui::Combo("bonds", &bc, kBondColorNames, IM_ARRAYSIZE(kBondColorNames))) {
      bond_color_ = static_cast<BondColor>(bc);
      bond_range_.reset();
    }
    const bool volumes = std::any_of(w.model.volume.begin(), w.model.volume.end(), [](double v) { return v > 0; });
    if (ImGui::Combo("quanta", &qc, kQuantaColorNames, IM_ARRAYSIZE(kQuantaColorNames))) {
      quanta_color_ = static_cast<QuantaColor>(qc);
      if (quanta_color_ == QuantaColor::von_mises && !volumes) quanta_color_ = QuantaColor::body;
      quanta_range_.reset();
    }
    if (!volumes) ImGui::TextDisabled("no quanta volumes: no stress colouring");
    legend();
    ImGui::Separator();
    char label[64];
    std::snprintf(label, sizeof label, "%.4g J", energy_.empty() ? 0.0 : static_cast<double>(energy_.back()));
    plot("total energy", energy_, label);
    std::snprintf(label, sizeof label, "%.4g J", kinetic_.empty() ? 0.0 : static_cast<double>(kinetic_.back()));
    plot("kinetic", kinetic_, label);
    std::snprintf(label, sizeof label, "%.3g ms", step_ms_.empty() ? 0.0 : static_cast<double>(step_ms_.back()));
    plot("step time", step_ms_, label);
    ImGui::Separator();
    ImGui::TextDisabled("h: help   space: pause   .: step   r: reset   f: frame");
    ImGui::End();
  }

  /// Colour bars of what the bonds and quanta show: in the panel, or over the view without one.
  void legend() {
    const bool in_panel = opt_.ui;
    if (!in_panel) {
      ImGui::SetNextWindowPos(ImVec2(10, static_cast<float>(fb_h_) - 10), ImGuiCond_Always, ImVec2(0, 1));
      ImGui::SetNextWindowBgAlpha(0.6f);
      ImGui::Begin("legend", nullptr, ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoInputs);
    }
    auto bar = [](const char* title, double lo, double hi, bool div) {
      ImGui::TextUnformatted(title);
      ImDrawList* dl = ImGui::GetWindowDrawList();
      const ImVec2 p = ImGui::GetCursorScreenPos();
      const float w = 220, h = 14;
      constexpr int kSteps = 32;
      for (int k = 0; k < kSteps; ++k) {
        const double t = (k + 0.5) / kSteps;
        const Vec3f c = div ? diverging(2 * t - 1) : sequential(t);
        const ImU32 col = IM_COL32(static_cast<int>(255 * c.x()), static_cast<int>(255 * c.y()), static_cast<int>(255 * c.z()), 255);
        dl->AddRectFilled(ImVec2(p.x + w * static_cast<float>(k) / kSteps, p.y), ImVec2(p.x + w * static_cast<float>(k + 1) / kSteps, p.y + h), col);
      }
      ImGui::Dummy(ImVec2(w, h));
      ImGui::Text("%-12.3g%*s%.3g", lo, 14, "", hi);
    };
    if (bond_color_ != BondColor::none) bar(kBondColorNames[static_cast<int>(bond_color_)], -bond_range_.hi, bond_range_.hi, true);
    if (quanta_color_ != QuantaColor::body) bar(kQuantaColorNames[static_cast<int>(quanta_color_)], 0, quanta_range_.hi, false);
    ImGui::TextColored(ImVec4(0.95f, 0.45f, 0.05f, 1), "o");
    ImGui::SameLine();
    ImGui::TextUnformatted("anchored or prescribed quanta");
    if (!in_panel) ImGui::End();
  }

  void help() {
    ImGui::SetNextWindowPos(ImVec2(static_cast<float>(viewport_width()) / 2, static_cast<float>(fb_h_) / 2),
                            ImGuiCond_Always, ImVec2(0.5f, 0.5f));
    ImGui::Begin("help", &help_, ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoCollapse);
    ImGui::Text(
        "left-drag a quanta    pull it with a spring (drawn in yellow)\n"
        "left-drag elsewhere   orbit\n"
        "right/shift-drag      pan\n"
        "wheel                 zoom\n"
        "f                     frame the scene\n"
        "space                 pause / run\n"
        ".                     one step\n"
        "r                     reset the scene\n"
        "h                     this help\n\n"
        "orange spheres are anchored or prescribed quanta");
    ImGui::End();
  }

  Scene scene_;
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
};

Viewer* viewer_of(GLFWwindow* w) { return static_cast<Viewer*>(glfwGetWindowUserPointer(w)); }

void install_callbacks(GLFWwindow* window) {
  glfwSetKeyCallback(window, [](GLFWwindow* w, int key, int, int action, int) {
    if (action == GLFW_PRESS && !ImGui::GetIO().WantCaptureKeyboard) viewer_of(w)->key(key);
  });
  glfwSetMouseButtonCallback(window, [](GLFWwindow* w, int button, int action, int mods) {
    if (action == GLFW_PRESS && ImGui::GetIO().WantCaptureMouse) return;
    double x = 0, y = 0;
    glfwGetCursorPos(w, &x, &y);
    viewer_of(w)->mouse_button(button, action == GLFW_PRESS, x, y, (mods & GLFW_MOD_SHIFT) != 0);
  });
  glfwSetCursorPosCallback(window, [](GLFWwindow* w, double x, double y) { viewer_of(w)->mouse_move(x, y); });
  glfwSetScrollCallback(window, [](GLFWwindow* w, double, double dy) {
    if (!ImGui::GetIO().WantCaptureMouse) viewer_of(w)->scroll(dy);
  });
}

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
  };
}

}  // namespace

int run_viewer(Scene scene, const ViewOptions& o) {
  if (o.width < 64 || o.height < 64) throw std::invalid_argument("window size must be at least 64 x 64");
  // Bad input is refused before a window opens.
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
    Viewer viewer(std::move(scene), std::move(script), o, std::max(fb_w, 1), std::max(fb_h, 1));
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
