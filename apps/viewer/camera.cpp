#include "camera.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace qbond::view {

namespace {
constexpr float kMaxPitch = std::numbers::pi_v<float> / 2 - 0.01f;

Vec3f forward(float yaw, float pitch) {  // from the eye toward the target
  return -Vec3f(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch));
}

// The view's axes: forward (eye to target), side (to the right on screen) and up.
struct Axes {
  Vec3f f, s, u;
};
Axes axes(float yaw, float pitch) {
  const Vec3f f = forward(yaw, pitch);
  const Vec3f s = f.cross(Vec3f::UnitZ()).normalized();
  return {f, s, s.cross(f)};
}
}  // namespace

Vec3f OrbitCamera::eye() const { return target - distance * forward(yaw, pitch); }

Mat4f OrbitCamera::view() const {
  const auto [f, s, u] = axes(yaw, pitch);
  const Vec3f e = eye();
  Mat4f m = Mat4f::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(e);
  m(1, 3) = -u.dot(e);
  m(2, 3) = f.dot(e);
  return m;
}

Mat4f OrbitCamera::projection(float aspect) const {
  const float n = 0.01f * distance, f = 100.0f * distance;
  const float t = 1.0f / std::tan(fov_y / 2);
  Mat4f p = Mat4f::Zero();
  p(0, 0) = t / aspect;
  p(1, 1) = t;
  p(2, 2) = (f + n) / (n - f);
  p(2, 3) = 2 * f * n / (n - f);
  p(3, 2) = -1;
  return p;
}

void OrbitCamera::look_at(const Vec3f& e, const Vec3f& t) {
  const Vec3f d = e - t;  // eye() = target + distance (cos p cos y, cos p sin y, sin p)
  target = t;
  distance = std::max(d.norm(), 1e-6f);
  yaw = std::atan2(d.y(), d.x());
  pitch = std::clamp(std::asin(std::clamp(d.z() / distance, -1.0f, 1.0f)), -kMaxPitch, kMaxPitch);
}

void OrbitCamera::orbit(float dx, float dy) {
  yaw -= 0.01f * dx;
  pitch = std::clamp(pitch + 0.01f * dy, -kMaxPitch, kMaxPitch);
}

void OrbitCamera::pan(float dx, float dy, float height) {
  const auto [f, s, u] = axes(yaw, pitch);
  const float per_pixel = 2 * distance * std::tan(fov_y / 2) / height;
  target += per_pixel * (-dx * s + dy * u);
}

void OrbitCamera::zoom(float factor) { distance = std::max(1e-4f, distance * factor); }

void OrbitCamera::frame(const Vec3f& lo, const Vec3f& hi, float aspect) {
  target = (lo + hi) / 2;
  const float radius = std::max(0.5f * (hi - lo).norm(), 1e-3f);
  const float half = std::min(fov_y / 2, std::atan(std::tan(fov_y / 2) * aspect));
  distance = 1.1f * radius / std::sin(half);
}

bool OrbitCamera::keep_in_view(const Vec3f& p, float aspect, float zone) {
  const auto [f, s, u] = axes(yaw, pitch);
  const Vec3f d = p - eye();
  const float depth = d.dot(f);
  if (depth <= 0.01f * distance) {  // behind the eye or at the near plane
    target = p;
    return true;
  }
  // Moving the target (and the eye) by a s + b u moves p's view coordinates by (−a, −b) at the
  // same depth, where the view's half-width is depth tan(fov/2) aspect.
  const float half_y = zone * depth * std::tan(fov_y / 2), half_x = half_y * aspect;
  const float x = d.dot(s), y = d.dot(u);
  const float a = x - std::clamp(x, -half_x, half_x), b = y - std::clamp(y, -half_y, half_y);
  if (std::max(std::abs(a), std::abs(b)) <= 1e-3f * half_y) return false;  // on the edge, to round-off
  target += a * s + b * u;
  return true;
}

Ray OrbitCamera::ray(double px, double py, double w, double h) const {
  const auto [f, s, u] = axes(yaw, pitch);
  const double t = std::tan(fov_y / 2);
  const double nx = (2 * px / w - 1) * t * w / h, ny = (1 - 2 * py / h) * t;
  const Eigen::Vector3d d = (f.cast<double>() + nx * s.cast<double>() + ny * u.cast<double>()).normalized();
  return {eye().cast<double>(), d};
}

bool OrbitCamera::to_pixel(const Vec3f& p, float w, float h, float& px, float& py) const {
  const Eigen::Vector4f c = projection(w / h) * view() * p.homogeneous();
  if (c.w() <= 0) return false;
  px = (c.x() / c.w() + 1) / 2 * w;
  py = (1 - c.y() / c.w()) / 2 * h;
  return true;
}

double hit_sphere(const Ray& ray, const Eigen::Vector3d& c, double r) {
  const Eigen::Vector3d oc = ray.origin - c;
  const double b = oc.dot(ray.dir), q = oc.squaredNorm() - r * r;
  const double disc = b * b - q;
  if (disc < 0) return -1;
  const double s = std::sqrt(disc);
  return -b - s >= 0 ? -b - s : -b + s;
}

}  // namespace qbond::view
