#include "integrators/contact_solve.hpp"

#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"
#include "integrators/integrator_common.hpp"

namespace qbond {

namespace {

constexpr Index kNone = ~Index{0};

// A contact starts sliding when the quanta moves along the surface faster than this many times
// the speed gravity gives in a step (below it, a stick trial decides).
constexpr double kSlideSpeed = 0.5;
// The stick spring's stiffness over the normal one's. Anchored at each step's start, a stuck
// quanta under a tangential load F creeps F / k_t a step: 100 k keeps that to 1/100 of its
// normal spring's deflection under the same force.
constexpr double kStickStiffness = 100;
// A sliding contact's f_n and direction are settled when a solve changes them by less than this
// fraction: its friction force is then right to that fraction.
constexpr double kSlideSettled = 1e-3;

bool has_friction(const ContactMaterial& m) { return m.friction > 0 || m.static_coefficient() > 0; }

Mat3 tangential(const Vec3& n) { return Mat3::Identity() - n * n.transpose(); }

}  // namespace

bool ContactSolve::make(const Model& model, const State& state, double h, Index i, std::uint32_t o,
                        const Vec3& x1, Contact& c) const {
  const Obstacle& ob = model.obstacles[o];
  const Vec3& x0 = state.x[i];
  Vec3 n;
  const double g0 = ob.distance(x0, n) - ob.margin;
  c = {};
  c.i = i;
  c.obstacle = o;
  if (g0 < 0) {
    // Starts inside: a contact while the step would end inside too (else it is leaving).
    if (g0 + n.dot(x1 - x0) >= 0) return false;
    c.ref = x0;
    c.gap_ref = g0;
  } else {
    const double t = ob.entry(x0, x1);
    if (t < 0) return false;
    c.ref = x0 + t * (x1 - x0);
    c.gap_ref = ob.distance(c.ref, n) - ob.margin;
    const double v_in = -n.dot(state.v[i]);
    if (v_in > 0) {
      // An impact: the spring's rest gap is where the quanta would be after bouncing off the
      // surface for the rest of the step, and finish() gives it the normal velocity e v_in.
      c.v_in = v_in;
      const double gap_start = c.gap_ref + n.dot(x0 - c.ref);
      c.target = ob.material.restitution * std::max(0.0, h * v_in - gap_start);
    }
  }
  c.n = n;
  c.k = ob.penalty * model.mass[i] / (h * h);
  // A quanta already sliding along the surface starts sliding, with the force its spring holds
  // now (or that stops its approach within the step): a stick trial would hold it for a solve
  // and tip the body it belongs to.
  const ContactMaterial& mat = ob.material;
  const Vec3 vt = tangential(n) * state.v[i];
  const double speed = vt.norm();
  if (has_friction(mat) && speed > kSlideSpeed * h * model.gravity.norm() && speed > 0) {
    c.slide = true;
    c.slide_dir = vt / speed;
    c.slide_fn = std::max(c.k * std::max(0.0, -c.gap_ref), model.mass[i] * c.v_in / h);
    c.fn = c.slide_fn;
  }
  return true;
}

double ContactSolve::normal_force(const State& s, double h, const Contact& c, const Vec3& y) const {
  const Vec3 x1 = s.x[c.i] + h * (s.v[c.i] + y);
  return c.k * (c.target - c.gap_ref - c.n.dot(x1 - c.ref));
}

Vec3 ContactSolve::contact_force(const Model& model, const State& s, double h, const Contact& c,
                                 const Vec3& y) const {
  const ContactMaterial& mat = model.obstacles[c.obstacle].material;
  Vec3 f = normal_force(s, h, c, y) * c.n;
  if (!has_friction(mat)) return f;
  if (c.slide) return f - mat.friction * c.slide_fn * c.slide_dir;
  return f - kStickStiffness * c.k * h * (tangential(c.n) * (s.v[c.i] + y));
}

void ContactSolve::write(const Model& model, const State& state, double h, int threads, ImplicitSystem& sys) {
  for (std::size_t k = 0; k < saved_.size(); ++k) {
    sys.diag[saved_[k]] = base_diag_[k];
    sys.rhs[saved_[k]] = base_rhs_[k];
  }
  const double h2 = h * h;
  for (const Contact& c : contacts_) {
    const Index i = c.i;
    if (slot_[i] == kNone) {
      slot_[i] = static_cast<Index>(saved_.size());
      saved_.push_back(i);
      base_diag_.push_back(sys.diag[i]);
      base_rhs_.push_back(sys.rhs[i]);
    }
    const Vec3& n = c.n;
    const Vec3& v = state.v[i];
    const double c0 = c.target - c.gap_ref - n.dot(state.x[i] - c.ref) - h * n.dot(v);
    sys.diag[i] += (h2 * c.k) * (n * n.transpose());
    sys.rhs[i] += (h * c.k * c0) * n;
    const ContactMaterial& mat = model.obstacles[c.obstacle].material;
    if (!has_friction(mat)) continue;
    if (c.slide) {
      sys.rhs[i] -= (h * mat.friction * c.slide_fn) * c.slide_dir;
    } else {
      const Mat3 P = tangential(n);
      sys.diag[i] += (h2 * kStickStiffness * c.k) * P;
      sys.rhs[i] -= (h2 * kStickStiffness * c.k) * (P * v);
    }
  }
  for (Index i : saved_) sys.diag_inv[i] = sys.diag[i].inverse();
  sys.rhs_norm = std::sqrt(deterministic_sum(model.num_quanta(), threads, [&](std::size_t q) {
    return model.is_kinematic(static_cast<Index>(q)) ? 0.0 : sys.rhs[q].squaredNorm();
  }));
  touching_.assign(model.num_quanta(), 0);
  for (const Contact& c : contacts_) touching_[c.i] = 1;
}

bool ContactSolve::begin(const Model& model, const State& state, const std::vector<Vec3>& f_ext, double h,
                         int threads, ImplicitSystem& sys) {
  contacts_.clear();
  saved_.clear();
  base_diag_.clear();
  base_rhs_.clear();
  touching_.clear();
  if (model.obstacles.empty()) return false;
  const std::size_t n = model.num_quanta();
  slot_.assign(n, kNone);
  released_.assign(n * model.obstacles.size(), 0);
  for (std::size_t q = 0; q < n; ++q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i)) continue;
    // The step's motion predicted from the start velocity and the external force alone.
    const Vec3 x1 =
        state.x[i] + h * state.v[i] + (h * h * model.inv_mass[i]) * external_force(model, f_ext, i);
    for (std::uint32_t o = 0; o < model.obstacles.size(); ++o) {
      Contact c;
      if (make(model, state, h, i, o, x1, c)) contacts_.push_back(c);
    }
  }
  write(model, state, h, threads, sys);
  return true;
}

bool ContactSolve::update(const Model& model, const State& state, double h, int threads,
                          const std::vector<Vec3>& y, ImplicitSystem& sys) {
  bool changed = false;
  std::vector<Contact>& next = next_;
  next.clear();
  std::size_t k = 0;
  const std::size_t n = model.num_quanta();
  const std::size_t nob = model.obstacles.size();
  // A contact released twice in a step stays released: the active set cannot cycle.
  auto released = [&](Index i, std::uint32_t o) { return released_[i * nob + o] >= 2; };
  for (std::size_t q = 0; q < n; ++q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i)) continue;
    const Vec3 v1 = state.v[i] + y[i];
    const Vec3 x1 = state.x[i] + h * v1;
    for (std::uint32_t o = 0; o < model.obstacles.size(); ++o) {
      if (k < contacts_.size() && contacts_[k].i == i && contacts_[k].obstacle == o) {
        Contact c = contacts_[k++];
        c.fn = normal_force(state, h, c, y[i]);
        if (c.fn < 0) {  // the spring pulls: the quanta leaves the surface
          ++released_[i * nob + o];
          changed = true;
          continue;
        }
        const ContactMaterial& mat = model.obstacles[o].material;
        if (has_friction(mat)) {
          const Vec3 vt = tangential(c.n) * v1;
          if (!c.slide) {
            const Vec3 ft = -kStickStiffness * c.k * h * vt;
            const double limit = mat.static_coefficient() * c.fn;
            if (ft.norm() > limit) {  // past static friction: it slides where the spring held it
              c.slide = true;
              c.slide_dir = -ft.normalized();
              c.slide_fn = c.fn;
              changed = true;
            }
          } else if (vt.dot(c.slide_dir) < 0) {  // friction reversed the sliding: it sticks
            c.slide = false;
            changed = true;
          } else {
            const double speed = vt.norm();
            const Vec3 dir = speed > 0 ? Vec3(vt / speed) : c.slide_dir;
            // The sliding force takes f_n and the direction of the last solve until they settle.
            if (std::abs(c.fn - c.slide_fn) > kSlideSettled * c.fn ||
                (dir - c.slide_dir).norm() > kSlideSettled)
              changed = true;
            c.slide_fn = c.fn;
            c.slide_dir = dir;
          }
        }
        next.push_back(c);
        continue;
      }
      if (released(i, o)) continue;
      Contact c;
      if (make(model, state, h, i, o, x1, c)) {
        next.push_back(c);
        changed = true;
      }
    }
  }
  contacts_.swap(next);
  if (changed) write(model, state, h, threads, sys);
  return changed;
}

double ContactSolve::stored(const Model& model, const std::vector<Vec3>& x, double h) const {
  double u = 0;
  for (std::size_t q = 0; q < model.num_quanta(); ++q) {
    if (model.is_kinematic(static_cast<Index>(q))) continue;
    for (const Obstacle& ob : model.obstacles) {
      Vec3 n;
      const double g = ob.distance(x[q], n) - ob.margin;
      if (g < 0) u += 0.5 * (ob.penalty * model.mass[q] / (h * h)) * g * g;
    }
  }
  return u;
}

void ContactSolve::finish(const Model& model, const State& state, double h, const std::vector<Vec3>& y,
                          Projection& out) {
  if (model.obstacles.empty()) return;
  const std::size_t n = model.num_quanta();
  double work = 0;  // Σ J·(v + v₁)/2 over the quanta in contact
  for (std::size_t k = 0; k < contacts_.size();) {
    const Index i = contacts_[k].i;
    Vec3 J = Vec3::Zero();
    for (; k < contacts_.size() && contacts_[k].i == i; ++k) {
      const Contact& c = contacts_[k];
      J += h * contact_force(model, state, h, c, y[i]);
      if (c.v_in > 0 && normal_force(state, h, c, y[i]) > 0) {
        // An impact leaves with e times the normal speed it arrived with.
        const double want = model.obstacles[c.obstacle].material.restitution * c.v_in;
        const double vn = c.n.dot(state.v[i] + out.dv[i]);
        if (want > vn) {
          out.dv[i] += (want - vn) * c.n;
          J += model.mass[i] * (want - vn) * c.n;
        }
      }
    }
    work += J.dot(state.v[i] + 0.5 * out.dv[i]);
  }
  x1_.resize(n);
  for (std::size_t q = 0; q < n; ++q) x1_[q] = state.x[q] + out.dx[q];
  const double u0 = stored(model, state.x, h), u1 = stored(model, x1_, h);
  // A step whose balance comes out negative (the linearised springs gave energy back, as when a
  // stick spring lets go) charges nothing: that energy is the integrator's, left to `numerical`.
  out.contact.dissipated = std::max(0.0, -work - (u1 - u0));
  out.contact.stored = u1;
  out.contact.charged = true;
}

}  // namespace qbond
