// Drawing the scene: bonds, quanta, obstacles, the ground, and the user's forces; then the
// ImGui windows over it.
#include "gl.hpp"
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "qbond/analysis/analysis.hpp"
#include "qbond/analysis/stress.hpp"
#include "viewer_app.hpp"

namespace qbond::view {

/// Radius to draw quanta with: the scene's contact radius when it has one, else 0.15 of a short
/// bond's length (the 10th percentile: nearest neighbours, so that bonds stay visible between
/// the spheres), else the obstacles' largest margin (unbonded quanta touch them at it), else a
/// fiftieth of the scene's size.
double draw_radius(const Scene& scene, double size) {
  for (const HeuristicSpec& h : scene.heuristics)
    if (const auto* c = std::get_if<QuantaContactRule>(&h)) return c->radius;
  const World& w = scene.world;
  if (w.model.quanta_contact.radius > 0) return w.model.quanta_contact.radius;
  if (w.num_bonds() > 0) {
    std::vector<double> r(w.num_bonds());
    for (std::size_t b = 0; b < r.size(); ++b)
      r[b] = (w.state.x[w.state.bonds.j[b]] - w.state.x[w.state.bonds.i[b]]).norm();
    const auto k = static_cast<std::ptrdiff_t>(r.size() / 10);
    std::nth_element(r.begin(), r.begin() + k, r.end());
    if (r[static_cast<std::size_t>(k)] > 0) return 0.15 * r[static_cast<std::size_t>(k)];
  }
  double margin = 0;
  for (const Obstacle& ob : w.model.obstacles) margin = std::max(margin, ob.margin);
  for (const HeuristicSpec& h : scene.heuristics)
    if (const auto* ob = std::get_if<Obstacle>(&h)) margin = std::max(margin, ob->margin);
  if (margin > 0) return margin;
  return std::max(0.02 * size, 1e-3);
}

void Viewer::draw() {
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
    else if (centre != last_centre_ && !camera_fixed_)
      cam_.keep_in_view(centre, static_cast<float>(vw) / static_cast<float>(std::max(fb_h_, 1)), 0.6f);
    last_centre_ = centre;
  }
  renderer_.begin(0, 0, vw, fb_h_, cam_);
  const Model& m = world().model;
  const State& s = world().state;
  draw_ground();

  // Bonds.
  lines_.clear();
  if (replay_) {  // the run's own values: a replayed world's bonds hold only the frame's ends, in its order
    const VtpFrame& f = replay_->frame();
    tension_ = f.tension.size() == s.bonds.size() ? f.tension : std::vector<double>(s.bonds.size(), 0.0);
    strain_ = f.strain.size() == s.bonds.size() ? f.strain : std::vector<double>(s.bonds.size(), 0.0);
  } else if (bond_color_ != BondColor::none) {
    bond_tension_strain(m, s, tension_, strain_);
  }
  const std::vector<double>& value = bond_color_ == BondColor::tension ? tension_ : strain_;
  magnitudes_.clear();
  if (bond_color_ != BondColor::none)
    for (std::size_t b = 0; b < s.bonds.size(); ++b)
      if (s.bonds.alive[b]) magnitudes_.push_back(std::abs(value[b]));
  bond_range_.see(magnitudes_);
  for (std::size_t b = 0; b < s.bonds.size(); ++b) {
    if (!s.bonds.alive[b]) continue;
    const Vec3f c = bond_color_ == BondColor::none || bond_range_.hi <= 0 ? Vec3f(0.75f, 0.75f, 0.75f)
                                                                           : diverging(value[b] / bond_range_.hi);
    lines_.push_back({s.x[s.bonds.i[b]].cast<float>(), c});
    lines_.push_back({s.x[s.bonds.j[b]].cast<float>(), c});
  }
  renderer_.lines(lines_, 2);

  // Quanta.
  spheres_.clear();
  const bool stress = quanta_color_ == QuantaColor::von_mises;
  if (stress && replay_) {
    mises_ = replay_->frame().von_mises;
    mises_.resize(m.num_quanta(), 0.0);
  } else if (stress) {
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

void Viewer::draw_ground() {
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

void Viewer::container(const Obstacle& ob) {
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

}  // namespace qbond::view
