#include "renderer.hpp"

#include "gl.hpp"

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace qbond::view {

namespace {

// Lighting shared by spheres and solids: a key light from the upper left of the eye plus a
// headlight, so that shapes read on any side the camera orbits to.
constexpr const char* kLighting = R"(
vec3 shade(vec3 n, vec3 base) {
  vec3 key = normalize(vec3(-0.4, 0.7, 0.6));
  float d = max(dot(n, key), 0.0) * 0.65 + max(n.z, 0.0) * 0.25;
  float s = pow(max(dot(reflect(-key, n), vec3(0, 0, 1)), 0.0), 32.0) * 0.25;
  return base * (0.28 + d) + vec3(s);
}
)";

constexpr const char* kSphereVs = R"(#version 330 core
layout(location = 0) in vec2 corner;
layout(location = 1) in vec3 center;
layout(location = 2) in float radius;
layout(location = 3) in vec3 color;
uniform mat4 view;
uniform mat4 proj;
out vec3 v_pos;
flat out vec3 v_center;
flat out float v_radius;
flat out vec3 v_color;
void main() {
  vec3 c = (view * vec4(center, 1.0)).xyz;
  // The quad sits in front of the sphere and is wide enough for its perspective silhouette.
  vec3 p = c + vec3(corner * radius * 1.6, radius);
  v_pos = p;
  v_center = c;
  v_radius = radius;
  v_color = color;
  gl_Position = proj * vec4(p, 1.0);
}
)";

constexpr const char* kSphereFsHead = R"(#version 330 core
in vec3 v_pos;
flat in vec3 v_center;
flat in float v_radius;
flat in vec3 v_color;
uniform mat4 proj;
out vec4 frag;
)";

constexpr const char* kSphereFsMain = R"(
void main() {
  vec3 d = normalize(v_pos);
  float b = dot(d, v_center);
  float disc = b * b - dot(v_center, v_center) + v_radius * v_radius;
  if (disc < 0.0) discard;
  vec3 hit = (b - sqrt(disc)) * d;
  vec3 n = (hit - v_center) / v_radius;
  vec4 clip = proj * vec4(hit, 1.0);
  gl_FragDepth = 0.5 * clip.z / clip.w + 0.5;
  frag = vec4(shade(n, v_color), 1.0);
}
)";

constexpr const char* kLineVs = R"(#version 330 core
layout(location = 0) in vec3 p;
layout(location = 1) in vec3 color;
uniform mat4 view;
uniform mat4 proj;
out vec3 v_color;
void main() { v_color = color; gl_Position = proj * view * vec4(p, 1.0); }
)";

constexpr const char* kLineFs = R"(#version 330 core
in vec3 v_color;
out vec4 frag;
void main() { frag = vec4(v_color, 1.0); }
)";

constexpr const char* kSolidVs = R"(#version 330 core
layout(location = 0) in vec3 p;
layout(location = 1) in vec3 n;
uniform mat4 model;
uniform mat4 view;
uniform mat4 proj;
out vec3 v_n;
out vec3 v_world;
void main() {
  vec4 w = model * vec4(p, 1.0);
  v_world = w.xyz;
  v_n = mat3(view) * normalize(transpose(inverse(mat3(model))) * n);
  gl_Position = proj * view * w;
}
)";

constexpr const char* kSolidFsHead = R"(#version 330 core
in vec3 v_n;
in vec3 v_world;
uniform vec3 color;
uniform float cell;
out vec4 frag;
)";

constexpr const char* kSolidFsMain = R"(
void main() {
  vec3 base = color;
  if (cell > 0.0) {
    ivec3 k = ivec3(floor(v_world / cell));
    if (((k.x + k.y + k.z) & 1) == 1) base *= 0.88;
  }
  vec3 n = normalize(v_n);
  if (!gl_FrontFacing) n = -n;
  frag = vec4(shade(n, base), 1.0);
}
)";

unsigned compile(GLenum type, const std::string& src) {
  const GLuint s = glCreateShader(type);
  const char* p = src.c_str();
  glShaderSource(s, 1, &p, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    std::array<char, 2048> log{};
    glGetShaderInfoLog(s, static_cast<GLsizei>(log.size()), nullptr, log.data());
    throw std::runtime_error(std::string("viewer: shader does not compile: ") + log.data());
  }
  return s;
}

unsigned program(const std::string& vs, const std::string& fs) {
  const GLuint p = glCreateProgram();
  const GLuint v = compile(GL_VERTEX_SHADER, vs), f = compile(GL_FRAGMENT_SHADER, fs);
  glAttachShader(p, v);
  glAttachShader(p, f);
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    std::array<char, 2048> log{};
    glGetProgramInfoLog(p, static_cast<GLsizei>(log.size()), nullptr, log.data());
    throw std::runtime_error(std::string("viewer: shaders do not link: ") + log.data());
  }
  return p;
}

void uniform(unsigned prog, const char* name, const Mat4f& m) {
  glUniformMatrix4fv(glGetUniformLocation(prog, name), 1, GL_FALSE, m.data());  // Eigen is column-major, as GL
}

void attribute(GLuint index, GLint size, GLsizei stride, std::size_t offset, GLuint divisor = 0) {
  glEnableVertexAttribArray(index);
  glVertexAttribPointer(index, size, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offset));
  glVertexAttribDivisor(index, divisor);
}

// 36 vertices of the cube [−1, 1]³ followed by 6 of the square [−1, 1]² × {0}: position, normal.
std::vector<float> solid_vertices() {
  std::vector<float> v;
  auto quad = [&](Vec3f c, Vec3f a, Vec3f b) {  // centre, two half-edges; normal a × b
    const Vec3f n = a.cross(b).normalized();
    const Vec3f corners[6] = {c - a - b, c + a - b, c + a + b, c - a - b, c + a + b, c - a + b};
    for (const Vec3f& p : corners) v.insert(v.end(), {p.x(), p.y(), p.z(), n.x(), n.y(), n.z()});
  };
  const Vec3f X = Vec3f::UnitX(), Y = Vec3f::UnitY(), Z = Vec3f::UnitZ();
  quad(X, Y, Z), quad(-X, Z, Y), quad(Y, Z, X), quad(-Y, X, Z), quad(Z, X, Y), quad(-Z, Y, X);
  quad(Vec3f::Zero(), X, Y);
  return v;
}

}  // namespace

Renderer::Renderer() {
  sphere_prog_ = program(kSphereVs, std::string(kSphereFsHead) + kLighting + kSphereFsMain);
  line_prog_ = program(kLineVs, kLineFs);
  solid_prog_ = program(kSolidVs, std::string(kSolidFsHead) + kLighting + kSolidFsMain);

  const float corners[8] = {-1, -1, 1, -1, -1, 1, 1, 1};
  glGenVertexArrays(1, &quad_vao_);
  glBindVertexArray(quad_vao_);
  glGenBuffers(1, &quad_vbo_);
  glBindBuffer(GL_ARRAY_BUFFER, quad_vbo_);
  glBufferData(GL_ARRAY_BUFFER, sizeof corners, corners, GL_STATIC_DRAW);
  attribute(0, 2, 2 * sizeof(float), 0);
  glGenBuffers(1, &inst_vbo_);
  glBindBuffer(GL_ARRAY_BUFFER, inst_vbo_);
  static_assert(sizeof(SphereInstance) == 7 * sizeof(float));
  attribute(1, 3, sizeof(SphereInstance), offsetof(SphereInstance, center), 1);
  attribute(2, 1, sizeof(SphereInstance), offsetof(SphereInstance, radius), 1);
  attribute(3, 3, sizeof(SphereInstance), offsetof(SphereInstance, color), 1);

  glGenVertexArrays(1, &line_vao_);
  glBindVertexArray(line_vao_);
  glGenBuffers(1, &line_vbo_);
  glBindBuffer(GL_ARRAY_BUFFER, line_vbo_);
  static_assert(sizeof(LineVertex) == 6 * sizeof(float));
  attribute(0, 3, sizeof(LineVertex), offsetof(LineVertex, p));
  attribute(1, 3, sizeof(LineVertex), offsetof(LineVertex, color));

  const std::vector<float> solid = solid_vertices();
  glGenVertexArrays(1, &solid_vao_);
  glBindVertexArray(solid_vao_);
  glGenBuffers(1, &solid_vbo_);
  glBindBuffer(GL_ARRAY_BUFFER, solid_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(solid.size() * sizeof(float)), solid.data(), GL_STATIC_DRAW);
  attribute(0, 3, 6 * sizeof(float), 0);
  attribute(1, 3, 6 * sizeof(float), 3 * sizeof(float));
  glBindVertexArray(0);

  GLfloat range[2] = {1, 1};
  glGetFloatv(GL_ALIASED_LINE_WIDTH_RANGE, range);
  line_width_max_ = range[1];
}

Renderer::~Renderer() {
  const GLuint buffers[] = {quad_vbo_, inst_vbo_, line_vbo_, solid_vbo_};
  glDeleteBuffers(4, buffers);
  const GLuint arrays[] = {quad_vao_, line_vao_, solid_vao_};
  glDeleteVertexArrays(3, arrays);
  glDeleteProgram(sphere_prog_);
  glDeleteProgram(line_prog_);
  glDeleteProgram(solid_prog_);
}

void Renderer::begin(int x, int y, int w, int h, const OrbitCamera& camera) {
  glViewport(x, y, w, h);
  glEnable(GL_SCISSOR_TEST);
  glScissor(x, y, w, h);
  glClearColor(0.16f, 0.17f, 0.19f, 1);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glDisable(GL_SCISSOR_TEST);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  view_ = camera.view();
  proj_ = camera.projection(static_cast<float>(w) / static_cast<float>(std::max(h, 1)));
}

void Renderer::spheres(std::span<const SphereInstance> s) {
  if (s.empty()) return;
  glUseProgram(sphere_prog_);
  uniform(sphere_prog_, "view", view_);
  uniform(sphere_prog_, "proj", proj_);
  glBindVertexArray(quad_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, inst_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(s.size_bytes()), s.data(), GL_STREAM_DRAW);
  glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, static_cast<GLsizei>(s.size()));
}

void Renderer::lines(std::span<const LineVertex> v, float width) {
  if (v.empty()) return;
  glUseProgram(line_prog_);
  uniform(line_prog_, "view", view_);
  uniform(line_prog_, "proj", proj_);
  glLineWidth(std::min(width, line_width_max_));
  glBindVertexArray(line_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, line_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size_bytes()), v.data(), GL_STREAM_DRAW);
  glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(v.size()));
  glLineWidth(1);
}

void Renderer::box(const Mat4f& model, const Vec3f& color) {
  glUseProgram(solid_prog_);
  uniform(solid_prog_, "model", model);
  uniform(solid_prog_, "view", view_);
  uniform(solid_prog_, "proj", proj_);
  glUniform3f(glGetUniformLocation(solid_prog_, "color"), color.x(), color.y(), color.z());
  glUniform1f(glGetUniformLocation(solid_prog_, "cell"), 0);
  glBindVertexArray(solid_vao_);
  glDrawArrays(GL_TRIANGLES, 0, 36);
}

void Renderer::plane(const Mat4f& model, const Vec3f& color, float cell) {
  glUseProgram(solid_prog_);
  uniform(solid_prog_, "model", model);
  uniform(solid_prog_, "view", view_);
  uniform(solid_prog_, "proj", proj_);
  glUniform3f(glGetUniformLocation(solid_prog_, "color"), color.x(), color.y(), color.z());
  glUniform1f(glGetUniformLocation(solid_prog_, "cell"), cell);
  glBindVertexArray(solid_vao_);
  glDrawArrays(GL_TRIANGLES, 36, 6);
}

}  // namespace qbond::view
