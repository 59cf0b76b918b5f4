#pragma once
/// The viewer's OpenGL 3.3 core renderer: spheres drawn as instanced, ray-cast impostors (one quad
/// each, exact sphere shading and depth, so 10⁵ quanta cost 10⁵ quads, not 10⁷ triangles), lines
/// with per-vertex colour, and solid boxes and planes for obstacles. Needs a current context.
#include <span>

#include "camera.hpp"

namespace qbond::view {

struct SphereInstance {
  Vec3f center;
  float radius;
  Vec3f color;
};

struct LineVertex {
  Vec3f p;
  Vec3f color;
};

class Renderer {
 public:
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Clears the viewport (pixels, origin bottom left) and sets the camera for what follows.
  void begin(int x, int y, int w, int h, const OrbitCamera& camera);
  void spheres(std::span<const SphereInstance> s);
  /// Pairs of vertices, one line each.
  void lines(std::span<const LineVertex> v, float width = 1);
  /// A unit cube [−1, 1]³ mapped by `model` (boxes), shaded.
  void box(const Mat4f& model, const Vec3f& color);
  /// A square [−1, 1]² × {0} mapped by `model` (planes), shaded with a faint checker of `cell` m.
  void plane(const Mat4f& model, const Vec3f& color, float cell);

 private:
  unsigned sphere_prog_ = 0, line_prog_ = 0, solid_prog_ = 0;
  unsigned quad_vao_ = 0, quad_vbo_ = 0, inst_vbo_ = 0;
  unsigned line_vao_ = 0, line_vbo_ = 0;
  unsigned solid_vao_ = 0, solid_vbo_ = 0;
  Mat4f view_ = Mat4f::Identity(), proj_ = Mat4f::Identity();
  float line_width_max_ = 1;
};

}  // namespace qbond::view
