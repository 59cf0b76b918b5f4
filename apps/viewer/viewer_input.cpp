// Input: the mouse (orbit, pan, zoom, pulling a quanta with a spring), the keys, and scripted
// input (script.hpp) played as the same events.
#include "gl.hpp"
#include <GLFW/glfw3.h>
#include <imgui.h>

#include <cmath>
#include <utility>

#include "viewer_app.hpp"

namespace qbond::view {

void Viewer::key(int k) {
  switch (k) {
    case GLFW_KEY_SPACE:
      paused_ = !paused_;
      if (replay_ && !paused_ && replay_->index() + 1 == replay_->size()) show_frame(0);  // play again from the start
      break;
    case GLFW_KEY_PERIOD: single_step_ = true; break;
    case GLFW_KEY_COMMA:
      if (replay_ && replay_->index() > 0) show_frame(replay_->index() - 1);
      break;
    case GLFW_KEY_R: reset(); break;
    case GLFW_KEY_H: help_ = !help_; break;
    case GLFW_KEY_F:
      frame_camera();
      camera_fixed_ = false;
      break;
    default: break;
  }
}

void Viewer::mouse_button(int button, bool press, double mx, double my, bool shift) {
  if (!press) {
    if (button == GLFW_MOUSE_BUTTON_LEFT && drag_) drag_.reset();
    mode_ = Mode::none;
    return;
  }
  last_mx_ = mx, last_my_ = my;
  if (button == GLFW_MOUSE_BUTTON_LEFT && !shift) {
    if (!replay_ && grab(mx, my)) return;  // a recorded run cannot be pulled
    mode_ = Mode::orbit;
  } else {
    mode_ = Mode::pan;
  }
}

void Viewer::mouse_move(double mx, double my) {
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

void Viewer::play(const ScriptEvent& e) {
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

bool Viewer::grab(double mx, double my) {
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

Vec3 Viewer::point_at_depth(double mx, double my) const {
  const Ray ray = cam_.ray(mx, my, viewport_width(), fb_h_);
  const Vec3 forward = (cam_.target - cam_.eye()).normalized().cast<double>();
  return ray.origin + ray.dir * (grab_depth_ / std::max(ray.dir.dot(forward), 1e-6));
}

namespace {
Viewer* viewer_of(GLFWwindow* w) { return static_cast<Viewer*>(glfwGetWindowUserPointer(w)); }

}  // namespace

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

}  // namespace qbond::view
