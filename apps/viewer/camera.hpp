#pragma once
/// The viewer's orbit camera: z is up (scenes put gravity along −z), the eye circles a target.
/// Pure math (no OpenGL), so that picking and framing are tested without a window.
#include <Eigen/Dense>

namespace qbond::view {

using Vec3f = Eigen::Vector3f;
using Mat4f = Eigen::Matrix4f;

/// A ray from the eye through a pixel.
struct Ray {
  Eigen::Vector3d origin, dir;  ///< dir is unit length
};

struct OrbitCamera {
  Vec3f target = Vec3f::Zero();
  float distance = 3;   ///< eye to target [m]
  float yaw = 0.6f;     ///< about z [rad]
  float pitch = 0.35f;  ///< above the xy plane [rad], within ±(π/2 − 0.01)
  float fov_y = 0.8f;   ///< vertical field of view [rad]

  Vec3f eye() const;
  Mat4f view() const;
  /// Perspective projection for a viewport of aspect w/h, near and far planes scaled with distance.
  Mat4f projection(float aspect) const;

  /// Puts the eye at `eye` looking at `target` (the field of view unchanged). The pitch is
  /// clamped to ±(π/2 − 0.01): scenes check a camera with camera_problem (qbond/io/scene.hpp).
  void look_at(const Vec3f& eye, const Vec3f& target);
  /// Turns the eye about the target by pixel motion (dx, dy).
  void orbit(float dx, float dy);
  /// Moves target and eye in the view plane by pixel motion on a viewport `height` pixels tall.
  void pan(float dx, float dy, float height);
  /// Moves the eye toward (factor < 1) or away from the target.
  void zoom(float factor);
  /// Aims at the box [lo, hi] from the current direction so that all of it is in view.
  void frame(const Vec3f& lo, const Vec3f& hi, float aspect);
  /// Keeps p in view (a dead zone, as game cameras track a moving subject): when p lies outside
  /// the middle `zone` of the view (that fraction of the half-width and half-height), moves the
  /// target and the eye across the view just far enough to put it on the zone's edge; when p is
  /// behind the eye, aims at it. Returns whether the camera moved.
  bool keep_in_view(const Vec3f& p, float aspect, float zone);

  /// The ray through pixel (px, py) of a w × h viewport (origin top left, as the mouse reports).
  Ray ray(double px, double py, double w, double h) const;
  /// Pixel (origin top left) where the point p lands in a w × h viewport; false when behind the eye.
  bool to_pixel(const Vec3f& p, float w, float h, float& px, float& py) const;
};

/// Distance along the ray to the sphere (centre c, radius r), or a negative value on a miss.
double hit_sphere(const Ray& ray, const Eigen::Vector3d& c, double r);

}  // namespace qbond::view
