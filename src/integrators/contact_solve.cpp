#include "integrators/contact_solve.hpp"

#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"
#include "integrators/integrator_common.hpp"

namespace qbond {

namespace {

// A contact starts sliding when the quanta moves along the surface faster than this many times
// the speed gravity gives in a step (below it, a stick trial decides).
constexpr double kSlideSpeed = 0.5;
// The stick spring's stiffness over the normal one's. Anchored at each step's start, a stuck
// quanta under a tangential load F creeps F / k_t a step: 100 k keeps that to 1/100 of its
// normal spring's deflection under the same force.
constexpr double kStickStiffness = 100;
// A sliding contact's damping is settled when a solve changes it by less than this fraction: its
// friction force is then μ_k f_n to that fraction.
constexpr double kSlideSettled = 1e-3;

bool has_friction(const ContactMaterial& m) { return m.friction > 0 || m.static_coefficient() > 0; }

Mat3 tangential(const Vec3& n) { return Mat3::Identity() - n * n.transpose(); }

// A sticking contact's damping h k_t: its force −h k_t P w₁ is the stick spring's −k_t P (x₁ − x₀).
double stick_drag(double k, double h) { return kStickStiffness * k * h; }

// The damping of a contact that slides at tangential speed `speed` under the normal force fn:
// μ_k fn / speed, Coulomb's force at that speed, at most the stick's.
double slide_drag(const ContactMaterial& m, double fn, double speed, double stick) {
  return m.friction * fn < stick * speed ? m.friction * fn / speed : stick;
}

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
      // surface for the rest of the step, and finish() gives a lone quanta its normal velocity.
      c.v_in = v_in;
      const double e = ob.material.restitution;
      const double gap_start = c.gap_ref + n.dot(x0 - c.ref);
      c.target = e * std::max(0.0, h * v_in - gap_start);
      c.v_out = e * v_in;
      if (adj_->offset[i] == adj_->offset[i + 1]) {
        // A lone quanta's flight under its external force, exactly: when it meets the surface
        // (gap_start = v_in t + ½ a t²), and where and how fast it leaves.
        const double a = -n.dot(external_force(model, *f_ext_, i)) * model.inv_mass[i];
        const double disc = v_in * v_in + 2 * a * std::max(0.0, gap_start);
        const double t = disc >= 0 ? 2 * std::max(0.0, gap_start) / (v_in + std::sqrt(disc)) : HUGE_VAL;
        if (t <= h) {
          const double vc = v_in + a * t, tau = h - t;
          const double up = e * vc * tau - 0.5 * a * tau * tau;
          c.target = std::max(0.0, up);
          c.v_out = up > 0 ? e * vc - a * tau : 0.0;
        }
      }
    }
  }
  c.n = n;
  c.k = ob.penalty * model.mass[i] / (spring_h_ * spring_h_);
  // A quanta already sliding along the surface starts sliding, with the force its spring holds
  // now (or that stops its approach within the step): a stick trial would hold it for a solve
  // and tip the body it belongs to.
  const ContactMaterial& mat = ob.material;
  const Vec3 vt = tangential(n) * state.v[i];
  const double speed = vt.norm();
  c.drag = stick_drag(c.k, h);
  if (has_friction(mat) && speed > kSlideSpeed * h * model.gravity.norm() && speed > 0) {
    c.slide = true;
    c.fn = std::max(c.k * std::max(0.0, -c.gap_ref), model.mass[i] * c.v_in / h);
    c.drag = slide_drag(mat, c.fn, speed, c.drag);
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
  if (c.push) return f - c.push_force * c.push_dir;
  return f - c.drag * (tangential(c.n) * (s.v[c.i] + y));
}

double ContactSolve::pair_normal_force(const State& s, double h, const PairContact& p,
                                       const std::vector<Vec3>& y) const {
  const Vec3 d1 = s.x[p.j] - s.x[p.i] + h * (s.v[p.j] + y[p.j] - s.v[p.i] - y[p.i]);
  return p.k * (p.target - p.gap_ref - p.n.dot(d1 - p.d_ref));
}

Vec3 ContactSolve::pair_force(const Model& model, const State& s, double h, const PairContact& p,
                              const std::vector<Vec3>& y) const {
  const ContactMaterial& mat = model.quanta_contact.material;
  Vec3 f = pair_normal_force(s, h, p, y) * p.n;
  if (!has_friction(mat)) return f;
  if (p.push) return f - p.push_force * p.push_dir;
  const Vec3 w1 = s.v[p.j] + y[p.j] - s.v[p.i] - y[p.i];
  return f - p.drag * (tangential(p.n) * w1);
}

bool ContactSolve::make_pair(const Model& model, const State& state, double h, std::uint32_t c,
                             const Vec3& d1, PairContact& p) const {
  const auto [i, j] = candidates_[c];
  const double D = 2 * model.quanta_contact.radius;
  const Vec3 d0 = state.x[j] - state.x[i];
  const double len0 = d0.norm();
  p = {};
  p.candidate = c;
  p.i = i;
  p.j = j;
  const Vec3 w = state.v[j] - state.v[i];
  if (len0 < D) {
    // Starts overlapping: a contact while the step would end inside too (else it is leaving).
    p.n = len0 > 0 ? Vec3(d0 / len0) : Vec3::UnitZ();
    if (len0 - D + p.n.dot(d1 - d0) >= 0) return false;
    p.d_ref = d0;
    p.gap_ref = len0 - D;
  } else {
    // Where the relative path d0 + t (d1 − d0) first reaches |d| = D, t in [0, 1].
    const Vec3 dd = d1 - d0;
    const double A = dd.squaredNorm(), B = d0.dot(dd), C = len0 * len0 - D * D;
    const double disc = B * B - A * C;
    if (!(A > 0) || disc < 0) return false;
    const double t = (-B - std::sqrt(disc)) / A;
    if (t < 0 || t > 1) return false;
    p.d_ref = d0 + t * dd;
    const double len = p.d_ref.norm();
    p.n = p.d_ref / len;
    p.gap_ref = len - D;
    const double v_in = -p.n.dot(w);
    if (v_in > 0) {
      p.v_in = v_in;
      const double gap_start = p.gap_ref + p.n.dot(d0 - p.d_ref);
      p.target = model.quanta_contact.material.restitution * std::max(0.0, h * v_in - gap_start);
    }
  }
  const double wi = model.inv_mass[i], wj = model.inv_mass[j];
  const double mu = 1 / (wi + wj);  // the reduced mass (the free one's with a kinematic end)
  p.k = model.quanta_contact.penalty * mu / (spring_h_ * spring_h_);
  const ContactMaterial& mat = model.quanta_contact.material;
  const Vec3 wt = tangential(p.n) * w;
  const double speed = wt.norm();
  p.drag = stick_drag(p.k, h);
  if (has_friction(mat) && speed > kSlideSpeed * h * model.gravity.norm() && speed > 0) {
    p.slide = true;
    p.fn = std::max(p.k * std::max(0.0, -p.gap_ref), mu * p.v_in / h);
    p.drag = slide_drag(mat, p.fn, speed, p.drag);
  }
  return true;
}

void ContactSolve::find_candidates(const Model& model, const State& state, const Adjacency& adj,
                                   const std::vector<Vec3>& x1) {
  candidates_.clear();
  const QuantaContactRule& rule = model.quanta_contact;
  if (!(rule.radius > 0)) return;
  const std::size_t n = model.num_quanta();
  mid_.resize(n);
  reach_.resize(n);
  double most = 0;
  for (std::size_t q = 0; q < n; ++q) {
    mid_[q] = 0.5 * (state.x[q] + x1[q]);
    reach_[q] = 0.5 * (x1[q] - state.x[q]).norm();
    most = std::max(most, reach_[q]);
  }
  // Two paths within 2R + R of each other have midpoints closer than that plus both reaches.
  const double near = 3 * rule.radius;
  grid_.build(mid_, near + 2 * most);
  grid_.pairs(mid_, [&](Index i, Index j) {
    if (model.is_kinematic(i) && model.is_kinematic(j)) return;
    if (!rule.same_body && model.body[i] == model.body[j]) return;
    if ((mid_[j] - mid_[i]).norm() >= near + reach_[i] + reach_[j]) return;
    // The relative path's closest approach.
    const Vec3 d0 = state.x[j] - state.x[i], dd = (x1[j] - x1[i]) - d0;
    const double A = dd.squaredNorm();
    const double t = A > 0 ? std::clamp(-d0.dot(dd) / A, 0.0, 1.0) : 0.0;
    if ((d0 + t * dd).norm() >= near) return;
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e)
      if (adj.other[e] == j) return;
    candidates_.emplace_back(i, j);
  });
  // The hash visits i in increasing order, each i's partners in scan order: sorted, the order is
  // the pairs' alone.
  std::sort(candidates_.begin(), candidates_.end());
}

void ContactSolve::save_row(Index i, const ImplicitSystem& sys) {
  if (slot_[i] != kNone) return;
  slot_[i] = static_cast<Index>(saved_.size());
  saved_.push_back(i);
  base_diag_.push_back(sys.diag[i]);
  base_rhs_.push_back(sys.rhs[i]);
}

void ContactSolve::write(const Model& model, const State& state, double h, int threads, ImplicitSystem& sys) {
  for (std::size_t k = 0; k < saved_.size(); ++k) {
    sys.diag[saved_[k]] = base_diag_[k];
    sys.rhs[saved_[k]] = base_rhs_[k];
  }
  const double h2 = h * h;
  for (const Contact& c : contacts_) {
    const Index i = c.i;
    save_row(i, sys);
    const Vec3& n = c.n;
    const Vec3& v = state.v[i];
    const double c0 = c.target - c.gap_ref - n.dot(state.x[i] - c.ref) - h * n.dot(v);
    sys.diag[i] += (h2 * c.k) * (n * n.transpose());
    sys.rhs[i] += (h * c.k * c0) * n;
    const ContactMaterial& mat = model.obstacles[c.obstacle].material;
    if (!has_friction(mat)) continue;
    if (c.push) {
      sys.rhs[i] -= (h * c.push_force) * c.push_dir;
      continue;
    }
    const Mat3 P = tangential(n);
    sys.diag[i] += (h * c.drag) * P;
    sys.rhs[i] -= (h * c.drag) * (P * v);
  }
  sys.couplings.clear();
  const ContactMaterial& pmat = model.quanta_contact.material;
  for (const PairContact& p : pairs_) {
    const Index i = p.i, j = p.j;
    const bool free_i = !model.is_kinematic(i), free_j = !model.is_kinematic(j);
    const Vec3 w = state.v[j] - state.v[i];
    const double c0 = p.target - p.gap_ref - p.n.dot(state.x[j] - state.x[i] - p.d_ref) - h * p.n.dot(w);
    // B = a n nᵀ + b I: the normal spring h² k n nᵀ, and the friction's damper h c (I − n nᵀ).
    const double ht = has_friction(pmat) && !p.push ? h * p.drag : 0.0;
    const double a = h2 * p.k - ht, b = ht;
    Vec3 f = (h * p.k * c0) * p.n;  // h × the force on j the step's start gives
    if (has_friction(pmat))
      f -= p.push ? Vec3((h * p.push_force) * p.push_dir) : Vec3(ht * (tangential(p.n) * w));
    const Mat3 B = block_matrix(p.n, a, b);
    if (free_i) {
      save_row(i, sys);
      sys.diag[i] += B;
      sys.rhs[i] -= f;
    }
    if (free_j) {
      save_row(j, sys);
      sys.diag[j] += B;
      sys.rhs[j] += f;
    }
    if (free_i && free_j) sys.couplings.push_back({i, j, p.n, a, b});
  }
  for (Index i : saved_) sys.diag_inv[i] = sys.diag[i].inverse();
  sys.rhs_norm = std::sqrt(deterministic_sum(model.num_quanta(), threads, [&](std::size_t q) {
    return model.is_kinematic(static_cast<Index>(q)) ? 0.0 : sys.rhs[q].squaredNorm();
  }));
  touching_.assign(model.num_quanta(), 0);
  for (const Contact& c : contacts_) touching_[c.i] = 1;
  for (const PairContact& p : pairs_) touching_[p.i] = touching_[p.j] = 1;
}

bool ContactSolve::begin(const Model& model, const State& state, const Adjacency& adj,
                         const std::vector<Vec3>& f_ext, double h, double spring_h, int threads,
                         ImplicitSystem& sys) {
  spring_h_ = spring_h;
  adj_ = &adj;
  f_ext_ = &f_ext;
  contacts_.clear();
  pairs_.clear();
  candidates_.clear();
  saved_.clear();
  base_diag_.clear();
  base_rhs_.clear();
  touching_.clear();
  if (!model.solves_contact()) return false;
  const std::size_t n = model.num_quanta();
  slot_.assign(n, kNone);
  released_.assign(n * model.obstacles.size(), 0);
  // The step's motion predicted from the start velocity and the external force alone.
  x1_.resize(n);
  for (std::size_t q = 0; q < n; ++q) {
    const auto i = static_cast<Index>(q);
    x1_[q] = state.x[i] + h * state.v[i];
    if (!model.is_kinematic(i)) x1_[q] += (h * h * model.inv_mass[i]) * external_force(model, f_ext, i);
  }
  for (std::size_t q = 0; q < n; ++q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i) || !mine(i)) continue;
    for (std::uint32_t o = 0; o < model.obstacles.size(); ++o) {
      Contact c;
      if (make(model, state, h, i, o, x1_[q], c)) contacts_.push_back(c);
    }
  }
  find_candidates(model, state, adj, x1_);
  pair_released_.assign(candidates_.size(), 0);
  for (std::uint32_t c = 0; c < candidates_.size(); ++c) {
    const auto [i, j] = candidates_[c];
    PairContact p;
    if (make_pair(model, state, h, c, x1_[j] - x1_[i], p)) pairs_.push_back(p);
  }
  write(model, state, h, threads, sys);
  return true;
}

namespace {

// Checks a contact's friction against the solve, whose tangential velocity is `vt`. True when it
// changed (the step is solved again).
// - A sticking contact whose force h k_t |vt| passes μ_s f_n starts sliding under the constant
//   force −μ_k f_n vt/|vt|, f_n and the direction taken again from each solve until they settle
//   (a damper started from the stick's creep speed would need many solves to let a body's
//   contacts slide together; a constant force gives their speed at once). It sticks again if its
//   sliding reverses; settled, it becomes the damper c = μ_k f_n / |vt|, which gives the same
//   solution, solved once more. Before the last solve (`last`) every sliding contact becomes a
//   damper, so the step's friction is always one. A contact that stuck again within the step
//   slides again only as a damper: a constant force would flip it between sticking and sliding
//   solve after solve.
// - A sliding damper is settled when its force c |vt| is μ_k f_n to kSlideSettled, sticks when
//   μ_k f_n / |vt| reaches h k_t, else takes a new c: a contact moved by an effective mass m and
//   momentum S answers c with |vt| = S / (m + h c), so the last two solves' (c, |vt|) give m and S
//   and Coulomb's c |vt| = μ_k f_n gives c = μ_k f_n m / (S − h μ_k f_n) (exact for a lone
//   quanta); when that fit is not a positive m and S > h μ_k f_n, c = μ_k f_n / |vt|.
template <class C>
bool update_friction(const ContactMaterial& mat, double stick, double h, bool last, const Vec3& vt, C& c) {
  const double speed = vt.norm();
  const double coulomb = mat.friction * c.fn;
  if (!c.slide) {
    if (stick * speed <= mat.static_coefficient() * c.fn) return false;
    // The last solve, or a contact that already stuck again this step: a damper, whatever its
    // force (a constant force would let it flip between sticking and sliding solve after solve).
    if (last || c.reversals > 0) {
      c.slide = true;
      c.drag = coulomb / speed;
      c.last_drag = stick;
      c.last_speed = speed;
      return true;
    }
    c.slide = c.push = true;
    c.push_force = coulomb;
    c.push_dir = vt / speed;
    return true;
  }
  if (c.push) {
    if (!(vt.dot(c.push_dir) > 0)) {  // the force reversed the sliding: it sticks
      ++c.reversals;
      c.slide = c.push = false;
      c.drag = stick;
      return true;
    }
    const Vec3 dir = vt / speed;
    if (!last && (std::abs(coulomb - c.push_force) > kSlideSettled * coulomb ||
                  (dir - c.push_dir).norm() > kSlideSettled)) {
      c.push_force = coulomb;
      c.push_dir = dir;
      return true;
    }
    // Settled: the damper that gives this force at this speed, solved once more.
    c.push = false;
    c.drag = slide_drag(mat, c.fn, speed, stick);
    c.slide = c.drag < stick;
    c.last_drag = c.push_force / speed;
    c.last_speed = speed;
    return true;
  }
  if (std::abs(c.drag * speed - coulomb) <= kSlideSettled * coulomb) return false;
  double drag = slide_drag(mat, c.fn, speed, stick);
  if (drag >= stick) {  // friction stopped the sliding: it sticks
    ++c.reversals;
    c.slide = false;
    c.drag = stick;
    return true;
  }
  if (c.last_speed != speed) {
    const double m = h * (c.drag * speed - c.last_drag * c.last_speed) / (c.last_speed - speed);
    const double S = speed * (m + h * c.drag);
    if (m > 0 && S > h * coulomb) drag = std::min(stick, coulomb * m / (S - h * coulomb));
  }
  c.last_drag = c.drag;
  c.last_speed = speed;
  c.drag = drag;
  return true;
}

// Turns a contact's friction off: a sliding damper of no drag, which stays so while its normal
// force is zero (update_friction) and takes Coulomb's drag again once it pushes.
template <class C>
void frictionless(C& c) {
  c.slide = true;
  c.push = false;
  c.drag = 0;
  c.unrubbed = true;
}

// A contact whose spring pulls: true when it stays for another solve without its friction (a pull
// holds none: |f_t| ≤ μ f_n), false when it is released (counted in `released`).
template <class C>
bool stays_unrubbed(C& c, bool rubs, std::uint8_t& released) {
  if (rubs && !c.unrubbed) {
    frictionless(c);
    return true;
  }
  ++released;
  return false;
}

// A contact made again after being released twice: true when it returns (admitted, without
// friction), false while it waits (`waiting` set).
template <class C>
bool returns(C& c, std::uint8_t released, bool admit, bool& waiting) {
  if (released < 2) return true;
  waiting = true;
  if (admit) frictionless(c);
  return admit;
}

}  // namespace

bool ContactSolve::update(const Model& model, const State& state, double h, int threads, bool last,
                          const std::vector<Vec3>& y, ImplicitSystem& sys) {
  const bool changed = sweep(model, state, h, last, last, y);
  if (changed) write(model, state, h, threads, sys);
  return changed;
}

bool ContactSolve::admit(const Model& model, const State& state, double h, int threads, bool last,
                         const std::vector<Vec3>& y, ImplicitSystem& sys) {
  const bool changed = waiting_ && sweep(model, state, h, last, true, y);
  if (changed) write(model, state, h, threads, sys);
  return changed;
}

bool ContactSolve::sweep(const Model& model, const State& state, double h, bool last, bool admit,
                         const std::vector<Vec3>& y) {
  bool changed = false;
  waiting_ = false;
  std::vector<Contact>& next = next_;
  next.clear();
  std::size_t k = 0;
  const std::size_t n = model.num_quanta();
  const std::size_t nob = model.obstacles.size();
  for (std::size_t q = 0; q < n && nob > 0; ++q) {
    const auto i = static_cast<Index>(q);
    if (model.is_kinematic(i) || !mine(i)) continue;
    const Vec3 v1 = state.v[i] + y[i];
    const Vec3 x1 = state.x[i] + h * v1;
    for (std::uint32_t o = 0; o < model.obstacles.size(); ++o) {
      std::uint8_t& released = released_[i * nob + o];
      if (k < contacts_.size() && contacts_[k].i == i && contacts_[k].obstacle == o) {
        Contact c = contacts_[k++];
        c.fn = normal_force(state, h, c, y[i]);
        const ContactMaterial& mat = model.obstacles[o].material;
        if (c.fn < 0 && !last && released < 2) {  // the spring pulls: the quanta leaves the surface
          changed = true;
          if (stays_unrubbed(c, has_friction(mat), released)) next.push_back(c);
          continue;
        }
        c.fn = std::max(0.0, c.fn);  // a pull kept holds no friction
        if (has_friction(mat) && update_friction(mat, stick_drag(c.k, h), h, last, tangential(c.n) * v1, c))
          changed = true;
        next.push_back(c);
        continue;
      }
      Contact c;
      if (!make(model, state, h, i, o, x1, c) || !returns(c, released, admit, waiting_)) continue;
      next.push_back(c);
      changed = true;
    }
  }
  // Pairs, the same way over the candidates.
  std::vector<PairContact>& next_pairs = next_pairs_;
  next_pairs.clear();
  const ContactMaterial& pmat = model.quanta_contact.material;
  k = 0;
  for (std::uint32_t c = 0; c < candidates_.size(); ++c) {
    const auto [i, j] = candidates_[c];
    std::uint8_t& released = pair_released_[c];
    const Vec3 w1 = state.v[j] + y[j] - state.v[i] - y[i];
    if (k < pairs_.size() && pairs_[k].candidate == c) {
      PairContact p = pairs_[k++];
      p.fn = pair_normal_force(state, h, p, y);
      if (p.fn < 0 && !last && released < 2) {
        changed = true;
        if (stays_unrubbed(p, has_friction(pmat), released)) next_pairs.push_back(p);
        continue;
      }
      p.fn = std::max(0.0, p.fn);
      if (has_friction(pmat) && update_friction(pmat, stick_drag(p.k, h), h, last, tangential(p.n) * w1, p))
        changed = true;
      next_pairs.push_back(p);
      continue;
    }
    PairContact p;
    const bool entered = make_pair(model, state, h, c, state.x[j] - state.x[i] + h * w1, p);
    if (!entered || !returns(p, released, admit, waiting_)) continue;
    next_pairs.push_back(p);
    changed = true;
  }
  if (changed) {
    contacts_.swap(next);
    pairs_.swap(next_pairs);
  }
  return changed;
}

double ContactSolve::stored(const Model& model, const std::vector<Vec3>& x) const {
  double u = 0;
  for (std::size_t q = 0; q < model.num_quanta() && !model.obstacles.empty(); ++q) {
    if (model.is_kinematic(static_cast<Index>(q)) || !mine(static_cast<Index>(q))) continue;
    for (const Obstacle& ob : model.obstacles) {
      Vec3 n;
      const double g = ob.distance(x[q], n) - ob.margin;
      if (g < 0) u += 0.5 * (ob.penalty * model.mass[q] / (spring_h_ * spring_h_)) * g * g;
    }
  }
  const QuantaContactRule& rule = model.quanta_contact;
  for (const auto& [i, j] : candidates_) {
    if (!mine(model.is_kinematic(i) ? j : i)) continue;  // a pair's energy is its first free end's rank's
    const double g = (x[j] - x[i]).norm() - 2 * rule.radius;
    if (g < 0) u += 0.5 * (rule.penalty / ((model.inv_mass[i] + model.inv_mass[j]) * spring_h_ * spring_h_)) * g * g;
  }
  return u;
}

void ContactSolve::finish(const Model& model, const State& state, const Adjacency& adj, double h,
                          const std::vector<Vec3>& y, Projection& out) {
  if (!model.solves_contact()) return;
  const std::size_t n = model.num_quanta();
  // Each quanta's contact impulse over the step, J = h f (+ an impact's restitution impulse).
  impulse_.assign(n, Vec3::Zero());
  for (const Contact& c : contacts_) {
    const Index i = c.i;
    impulse_[i] += h * contact_force(model, state, h, c, y[i]);
    if (c.v_in > 0 && adj.offset[i] == adj.offset[i + 1] && normal_force(state, h, c, y[i]) > 0) {
      // An impact leaves with e times the normal speed it arrived with. Only a lone quanta: a
      // velocity set after the solve would differ from the one its bonds' dampers were solved
      // with (the ledger would charge them for motion the step never had); a bonded quanta's
      // bounce is its spring's rest gap, solved with its body.
      const double want = c.v_out;
      const double vn = c.n.dot(state.v[i] + out.dv[i]);
      if (want > vn) {
        out.dv[i] += (want - vn) * c.n;
        impulse_[i] += model.mass[i] * (want - vn) * c.n;
      }
    }
  }
  for (const PairContact& p : pairs_) {
    const Vec3 J = h * pair_force(model, state, h, p, y);
    impulse_[p.j] += J;
    impulse_[p.i] -= J;
    // The pair separates at e times the speed it approached with: equal and opposite impulses.
    // Without restitution the spring alone stops it: a velocity set after the solve would differ
    // from the one the bonds' dampers were solved with, and the ledger charges them with it.
    const double e = model.quanta_contact.material.restitution;
    if (e > 0 && p.v_in > 0 && pair_normal_force(state, h, p, y) > 0) {
      const double want = e * p.v_in;
      const double vn = p.n.dot(state.v[p.j] + out.dv[p.j] - state.v[p.i] - out.dv[p.i]);
      if (want > vn) {
        const double wi = model.inv_mass[p.i], wj = model.inv_mass[p.j];
        const Vec3 P = ((want - vn) / (wi + wj)) * p.n;
        out.dv[p.j] += wj * P;
        out.dv[p.i] -= wi * P;
        impulse_[p.j] += P;
        impulse_[p.i] -= P;
      }
    }
  }
  // Σ J·(v + v₁)/2 over the free quanta in contact: the kinetic energy the impulses change. A lone
  // quanta's step is its flight and bounce, exactly: what its contact did is its kinetic energy's
  // change less its external force's work along the step it took.
  double work = 0, impulse_dv = 0;
  for (std::size_t q = 0; q < n; ++q) {
    const auto i = static_cast<Index>(q);
    if (touching_.size() != n || !touching_[q] || model.is_kinematic(i) || !mine(i)) continue;
    if (adj.offset[i] == adj.offset[i + 1])
      work += 0.5 * model.mass[q] * ((state.v[q] + out.dv[q]).squaredNorm() - state.v[q].squaredNorm()) -
              external_force(model, *f_ext_, i).dot(out.dx[q]);
    else {
      work += impulse_[q].dot(state.v[q] + 0.5 * out.dv[q]);
      impulse_dv += impulse_[q].dot(out.dv[q]);
    }
  }
  for (std::size_t q = 0; q < n; ++q) x1_[q] = state.x[q] + out.dx[q];
  const double u0 = stored(model, state.x), u1 = stored(model, x1_);
  // A step whose balance comes out negative (the linearised springs gave energy back, as when a
  // stick spring lets go) charges nothing: that energy is the integrator's, left to `numerical`.
  out.contact.dissipated = std::max(0.0, -work - (u1 - u0));
  out.contact.stored = u1;
  out.contact.stored_start = u0;
  out.contact.work = work;
  out.contact.impulse_dv = impulse_dv;
  out.contact.charged = true;
}

}  // namespace qbond
