#include "qbond/heuristics/contacts.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <unordered_set>
#include <vector>

#include "heuristics/contact_ranks.hpp"
#include "heuristics/spatial_hash.hpp"
#include "integrators/penalty_contact.hpp"
#include "io/scene/heuristic_entry.hpp"

namespace qbond {
namespace {

// Snapshots the projection rows of the quanta a contact edits, to charge the energy the edits
// remove: kinetic, gravity and bond energy of the projected end-of-step state, before minus after.
class EditLedger {
 public:
  void begin(std::size_t n) {
    if (touched_.size() != n) {
      touched_.assign(n, 0);
      slot_.resize(n);
    }
    list_.clear();
    old_dx_.clear();
    old_dv_.clear();
  }
  void touch(Index i, const Projection& p) {
    if (touched_[i]) return;
    touched_[i] = 1;
    slot_[i] = static_cast<Index>(list_.size());
    list_.push_back(i);
    old_dx_.push_back(p.dx[i]);
    old_dv_.push_back(p.dv[i]);
  }
  // Energy the edits removed [J] from the `counted` quanta and the bonds whose first end is
  // counted (HeuristicContext::counted; empty: all); clears the marks.
  double released(const Model& m, const State& s, const Projection& p, const Adjacency& adj,
                  std::span<const std::uint8_t> counted) {
    auto charged = [&](Index i) { return counted.empty() || counted[i] != 0; };
    double e = 0;
    for (std::size_t k = 0; k < list_.size(); ++k) {
      const Index i = list_[k];
      if (!charged(i)) continue;
      const Vec3 v_old = s.v[i] + old_dv_[k], v_new = s.v[i] + p.dv[i];
      e += 0.5 * m.mass[i] * (v_old.squaredNorm() - v_new.squaredNorm());
      e -= m.mass[i] * m.gravity.dot(old_dx_[k] - p.dx[i]);
    }
    // Old end-of-step position of any quanta (touched ones from the snapshot).
    auto old_pos = [&](Index j) -> Vec3 { return touched_[j] ? Vec3(s.x[j] + old_dx_[slot_[j]]) : projected(s, p, j); };
    for (std::size_t k = 0; k < list_.size(); ++k) {
      const Index i = list_[k];
      for (Index a = adj.offset[i]; a < adj.offset[i + 1]; ++a) {
        const Index b = adj.bond[a], j = adj.other[a];
        if (!s.bonds.alive[b] || (touched_[j] && j < i) || !charged(s.bonds.i[b])) continue;  // each bond once
        const double r_old = (old_pos(j) - (s.x[i] + old_dx_[k])).norm();
        const double r_new = (projected(s, p, j) - projected(s, p, i)).norm();
        e += s.bonds.law_at(m.shapes, b, r_old, s.bonds.rest[b]).U -
             s.bonds.law_at(m.shapes, b, r_new, s.bonds.rest[b]).U;
      }
    }
    for (Index i : list_) touched_[i] = 0;
    return e;
  }
  /// The quanta touched so far, in the order they were first touched.
  const std::vector<Index>& touched() const { return list_; }

 private:
  std::vector<std::uint8_t> touched_;
  std::vector<Index> list_;
  std::vector<Index> slot_;  // per quanta: its index in list_ while touched
  std::vector<Vec3> old_dx_, old_dv_;
};

// Velocity change of a contact with unit normal n (pointing at the body receiving it), for the
// relative velocity w1 at the end of the step and w0 at its start (of the body, relative to the
// other side). Restitution applies to the approach speed the body brought into the step (with what
// earlier contacts of the step gave it: brought()), never
// to the speed the step's own forces pressed it in with (a resting contact must not bounce, or it
// would pump energy); Coulomb friction is bounded by μ times the normal change. Zero unless w1
// approaches (w1·n < 0).
Vec3 contact_velocity_change(const Vec3& w1, const Vec3& w0, const Vec3& n, const ContactMaterial& mat) {
  const double vn = w1.dot(n);
  if (!(vn < 0)) return Vec3::Zero();
  const double dvn = mat.restitution * std::max(0.0, -w0.dot(n)) - vn;
  const Vec3 vt = w1 - vn * n;
  const double slide = vt.norm();
  Vec3 dv = dvn * n;
  if (slide > 0) dv -= std::min(slide, mat.friction * dvn) / slide * vt;
  return dv;
}

// The velocity quanta i brought into the step plus what earlier contacts of the step gave it, for
// its current projected velocity `now`: `now` less the integrator's velocity change (the step's
// forces). Restitution returns this approach speed; without the integrator's change, the start
// velocity.
Vec3 brought(const State& s, const HeuristicContext& ctx, Index i, const Vec3& now) {
  return ctx.dv_forces.empty() ? s.v[i] : Vec3(now - ctx.dv_forces[i]);
}

// Smallest t in [0, 1] at which a + t (b - a) leaves a container shrunk by its margin, given that
// a is inside it; negative when the segment stays inside.
double container_exit(const Obstacle& o, const Vec3& a, const Vec3& b) {
  const Vec3 d = b - a;
  if (o.shape == Obstacle::Shape::sphere) {
    const double R = o.radius - o.margin;
    const Vec3 q = a - o.center;
    const double A = d.squaredNorm(), B = q.dot(d), C = q.squaredNorm() - R * R;
    if (C >= 0) return 0.0;
    if (A == 0) return -1.0;
    // C < 0: the roots straddle 0; the larger one is where the path crosses the sphere.
    const double t = (-B + std::sqrt(B * B - A * C)) / A;
    return t <= 1 ? t : -1.0;
  }
  // Box: the first slab face the path reaches in the direction it moves.
  const Vec3 qa = o.rotation.transpose() * (a - o.center), qd = o.rotation.transpose() * d;
  double t = INFINITY;
  for (int k = 0; k < 3; ++k) {
    if (qd[k] == 0) continue;
    const double face = (qd[k] > 0 ? 1.0 : -1.0) * (o.half_extents[k] - o.margin);
    t = std::min(t, std::max(0.0, (face - qa[k]) / qd[k]));
  }
  return t <= 1 ? t : -1.0;
}

// Obstacle::entry.
double entry(const Obstacle& o, const Vec3& a, const Vec3& b) {
  if (o.inside) return container_exit(o, a, b);
  const Vec3 d = b - a;
  switch (o.shape) {
    case Obstacle::Shape::plane: {
      const double da = o.normal.dot(a - o.center) - o.margin, db = o.normal.dot(b - o.center) - o.margin;
      return db < 0 ? std::clamp(da / (da - db), 0.0, 1.0) : -1.0;
    }
    case Obstacle::Shape::sphere: {
      const double R = o.radius + o.margin;
      const Vec3 q = a - o.center;
      const double A = d.squaredNorm(), B = q.dot(d), C = q.squaredNorm() - R * R;
      if (C <= 0) return 0.0;
      if (A == 0) return -1.0;
      const double disc = B * B - A * C;
      if (disc < 0) return -1.0;
      const double t = (-B - std::sqrt(disc)) / A;
      return t >= 0 && t <= 1 ? t : -1.0;
    }
    case Obstacle::Shape::box: {
      // Slabs of the box grown by the margin, in the box's axes.
      const Vec3 qa = o.rotation.transpose() * (a - o.center), qd = o.rotation.transpose() * d;
      double t0 = 0, t1 = 1;
      for (int k = 0; k < 3; ++k) {
        const double h = o.half_extents[k] + o.margin;
        if (qd[k] == 0) {
          if (std::abs(qa[k]) > h) return -1.0;
          continue;
        }
        double ta = (-h - qa[k]) / qd[k], tb = (h - qa[k]) / qd[k];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        if (t0 > t1) return -1.0;
      }
      return t0;
    }
  }
  return -1.0;
}

// Which obstacles clear_of can decide.
enum class ClearTest : std::uint8_t { none, plane, axis_box_container };

ClearTest clear_test(const Obstacle& o) {
  if (o.shape == Obstacle::Shape::plane && !o.inside) return ClearTest::plane;
  if (o.shape == Obstacle::Shape::box && o.inside && o.rotation == Mat3::Identity()) return ClearTest::axis_box_container;
  return ClearTest::none;
}

// True when ObstacleHeuristic::apply's general test of the path x0 → x1 finds no contact with o
// (most quanta, most steps), decided with the same arithmetic; false when it may find one. A
// plane: its distances at both ends. An axis-aligned container box: a start inside it shrunk by
// the margin and container_exit's exit time, its rotation left out (the identity's products
// give the same coordinates up to the sign of a zero, which neither test reads, for finite
// positions; others go the general way).
bool clear_of(const Obstacle& o, ClearTest test, const Vec3& x0, const Vec3& x1) {
  if (test == ClearTest::plane) {
    const double d1 = o.normal.dot(x1 - o.center) - o.margin;
    return o.normal.dot(x0 - o.center) >= o.margin ? !(d1 < 0) : d1 >= 0;
  }
  if (test != ClearTest::axis_box_container) return false;
  double q[3], d[3];
  for (int k = 0; k < 3; ++k) {
    q[k] = x0[k] - o.center[k];
    d[k] = x1[k] - x0[k];
    // Starts inside: solid_distance's |q| − half_extents all <= 0, and its largest, negated, >= margin.
    const double in = std::abs(q[k]) - o.half_extents[k];
    if (!(std::abs(d[k]) < INFINITY) || !(in <= 0) || !(-in >= o.margin)) return false;  // q finite too
  }
  double t = INFINITY;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0) continue;
    const double face = (d[k] > 0 ? 1.0 : -1.0) * (o.half_extents[k] - o.margin);
    t = std::min(t, std::max(0.0, (face - q[k]) / d[k]));
  }
  return !(t <= 1);
}

class ObstacleHeuristic final : public Heuristic {
 public:
  explicit ObstacleHeuristic(std::vector<Obstacle> o) : obstacles_(std::move(o)) {
    for (const Obstacle& ob : obstacles_) tests_.push_back(clear_test(ob));
  }
  std::string_view name() const override { return "obstacles"; }

  void apply(const Model& m, State& state, Projection& p, const HeuristicContext& ctx) override {
    const State& s = state;
    ledger_.begin(m.num_quanta());
    for (std::size_t q = 0; q < m.num_quanta(); ++q) {
      const auto i = static_cast<Index>(q);
      if (m.is_kinematic(i)) continue;
      for (std::size_t k = 0; k < obstacles_.size(); ++k) {
        const Obstacle& o = obstacles_[k];
        Vec3 n;
        const Vec3 x1 = s.x[i] + p.dx[i];
        if (clear_of(o, tests_[k], s.x[i], x1)) continue;
        const bool start_outside = o.distance(s.x[i], n) >= o.margin;
        Vec3 target;
        if (start_outside) {
          // Swept: stop where the path enters; keep the motion along the surface there.
          const double t = entry(o, s.x[i], x1);
          if (t < 0) continue;
          const Vec3 at = s.x[i] + t * p.dx[i];
          o.distance(at, n);
          target = x1 + std::max(0.0, n.dot(at - x1)) * n;
        } else {
          const double d = o.distance(x1, n) - o.margin;
          if (d >= 0) continue;
          target = x1 - d * n;
        }
        // A curved surface can leave the target slightly inside: finish along the local normal.
        Vec3 n2;
        const double left = o.distance(target, n2) - o.margin;
        if (left < 0) target -= left * n2;
        ledger_.touch(i, p);
        p.dx[i] = target - s.x[i];
        const Vec3 v1 = s.v[i] + p.dv[i];
        const Vec3 dv = contact_velocity_change(v1, brought(s, ctx, i, v1), n, o.material);
        p.dv[i] += dv;
        if (o.record >= 0 && (ctx.counted.empty() || ctx.counted[i])) {
          // The obstacle's impulse on the quanta is its momentum change; its normal part
          // (toward the free side) is what pushes on the wall: pressure × area × time.
          auto& rec = state.obstacle_impulse;
          const auto slot = static_cast<std::size_t>(o.record);
          if (rec.size() <= slot) rec.resize(slot + 1);
          const Vec3 J = m.mass[i] * dv;
          rec[slot].total += J;
          rec[slot].normal += J.dot(n);
        }
      }
    }
    if (!ledger_.touched().empty()) state.energy.dissipated_heuristics += ledger_.released(m, s, p, ctx.adj, ctx.counted);
  }

 private:
  std::vector<Obstacle> obstacles_;
  std::vector<ClearTest> tests_;  // by obstacle
  EditLedger ledger_;
};

class QuantaContactHeuristic final : public Heuristic {
 public:
  explicit QuantaContactHeuristic(QuantaContactRule r, ContactRanks* ranks = nullptr) : rule_(r), ranks_(ranks) {}
  std::string_view name() const override { return "contact"; }

  void apply(const Model& m, State& state, Projection& p, const HeuristicContext& ctx) override {
    const State& s = state;
    const std::size_t n = m.num_quanta();
    pos_.resize(n);
    vel_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      pos_[i] = s.x[i] + p.dx[i];
      vel_[i] = s.v[i] + p.dv[i];
    }
    find_pairs(m, ctx.adj, pos_, [](Index i) { return i; }, pairs_);
    ledger_.begin(n);
    if (ranks_) {
      project_over_ranks(p, ctx);
    } else {
      if (pairs_.empty()) return;
      project(
          pairs_, pos_, vel_, [&](Index i) { return m.inv_mass[i]; },
          [&](Index i, const Vec3& now) { return brought(s, ctx, i, now); }, [&](Index i) { ledger_.touch(i, p); });
    }
    if (ledger_.touched().empty()) return;
    for (Index i : ledger_.touched()) {
      if (m.is_kinematic(i)) continue;
      p.dx[i] = pos_[i] - s.x[i];
      p.dv[i] = vel_[i] - s.v[i];
    }
    state.energy.dissipated_heuristics += ledger_.released(m, s, p, ctx.adj, ctx.counted);
  }

 private:
  // Pairs (a < b) closer than 2 radius at positions `pos` that share no bond, in increasing a
  // then scan order; quanta a is quanta id(a) of `m` and `adj`.
  template <class Id>
  void find_pairs(const Model& m, const Adjacency& adj, const std::vector<Vec3>& pos, Id id,
                  std::vector<std::pair<Index, Index>>& pairs) {
    pairs.clear();
    grid_.build(pos, 2 * rule_.radius);
    grid_.pairs(pos, [&](Index a, Index b) {
      const Index i = id(a), j = id(b);
      if (m.is_kinematic(i) && m.is_kinematic(j)) return;
      if (!rule_.same_body && m.body[i] == m.body[j]) return;
      for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e)
        if (adj.other[e] == j) return;
      pairs.emplace_back(a, b);
    });
  }

  // The rule's passes over `pairs` on positions `pos` and velocities `vel`: each touching pair
  // pushed apart along its line by inverse mass, its impulse (restitution on the approach speed
  // `brought(i, vel_i)` gave, friction) applied once; touch(i) before quanta i first moves.
  template <class InvMass, class Brought, class Touch>
  void project(const std::vector<std::pair<Index, Index>>& pairs, std::vector<Vec3>& pos, std::vector<Vec3>& vel,
               InvMass inv_mass, Brought brought, Touch touch) {
    impulse_done_.assign(pairs.size(), 0);
    const double contact = 2 * rule_.radius;
    for (int it = 0; it < rule_.iterations; ++it) {
      for (std::size_t k = 0; k < pairs.size(); ++k) {
        const auto [i, j] = pairs[k];
        const Vec3 d = pos[j] - pos[i];
        const double dist = d.norm();
        if (dist >= contact) continue;
        const double wi = inv_mass(i), wj = inv_mass(j), wsum = wi + wj;
        // Coincident centres have no line between them: separate along z, deterministically.
        const Vec3 nrm = dist > 0 ? Vec3(d / dist) : Vec3::UnitZ();
        const double depth = contact - dist;
        touch(i);
        touch(j);
        pos[i] -= (wi / wsum * depth) * nrm;
        pos[j] += (wj / wsum * depth) * nrm;
        if (impulse_done_[k]) continue;
        impulse_done_[k] = 1;
        // Velocity change of j relative to i, split as equal and opposite impulses.
        const Vec3 dw = contact_velocity_change(vel[j] - vel[i], brought(j, vel[j]) - brought(i, vel[i]), nrm,
                                                rule_.material);
        const Vec3 impulse = dw / wsum;
        vel[i] -= wi * impulse;
        vel[j] += wj * impulse;
      }
    }
  }

  // A piece's share of the whole world's projection (contact_ranks.hpp): its owned quanta that
  // touch something (pairs_, from the piece's quanta) gathered with every rank's as rows
  // [whole index, position, velocity, the integrator's Δv], the whole world's pairs among them
  // projected as the run alone projects them, and the results taken into pos_ and vel_.
  void project_over_ranks(const Projection& p, const HeuristicContext& ctx) {
    constexpr std::size_t kRow = 10;
    const std::span<const Index> whole = ranks_->whole_index();
    mine_.assign(whole.size(), 0);
    for (const auto& [i, j] : pairs_) {
      if (ctx.counted[i]) mine_[i] = 1;
      if (ctx.counted[j]) mine_[j] = 1;
    }
    std::vector<double> rows;
    for (std::size_t i = 0; i < whole.size(); ++i) {
      if (!mine_[i]) continue;
      rows.push_back(static_cast<double>(whole[i]));
      for (const Vec3& v : {pos_[i], vel_[i], ctx.dv_forces[i]}) rows.insert(rows.end(), v.data(), v.data() + 3);
    }
    const std::vector<double> all = ranks_->gather(rows);
    // In the whole world's order (each quanta sent by its owner alone).
    const std::size_t count = all.size() / kRow;
    order_.resize(count);
    for (std::size_t r = 0; r < count; ++r) order_[r] = static_cast<Index>(r);
    std::sort(order_.begin(), order_.end(), [&](Index a, Index b) { return all[kRow * a] < all[kRow * b]; });
    ids_.resize(count);
    gpos_.resize(count);
    gvel_.resize(count);
    gdv_.resize(count);
    for (std::size_t g = 0; g < count; ++g) {
      const double* row = &all[kRow * order_[g]];
      ids_[g] = static_cast<Index>(row[0]);
      gpos_[g] = Vec3(row[1], row[2], row[3]);
      gvel_[g] = Vec3(row[4], row[5], row[6]);
      gdv_[g] = Vec3(row[7], row[8], row[9]);
    }
    const Model& wm = ranks_->whole_model();
    find_pairs(wm, ranks_->whole_adjacency(), gpos_, [&](Index g) { return ids_[g]; }, gpairs_);
    if (gpairs_.empty()) return;
    gtouched_.clear();
    gmark_.assign(count, 0);
    project(
        gpairs_, gpos_, gvel_, [&](Index g) { return wm.inv_mass[ids_[g]]; },
        [&](Index g, const Vec3& now) { return Vec3(now - gdv_[g]); },
        [&](Index g) {
          if (!gmark_[g]) gmark_[g] = 1, gtouched_.push_back(g);
        });
    for (Index g : gtouched_) {
      const Index i = ranks_->local_index(ids_[g]);
      if (i == kNone) continue;
      ledger_.touch(i, p);
      pos_[i] = gpos_[g];
      vel_[i] = gvel_[g];
    }
  }

  QuantaContactRule rule_;
  ContactRanks* ranks_;  // a piece's link to the other ranks, or null
  EditLedger ledger_;
  std::vector<Vec3> pos_, vel_;
  SpatialHash grid_;
  std::vector<std::pair<Index, Index>> pairs_;
  std::vector<std::uint8_t> impulse_done_;
  // Over ranks: the piece's quanta it sends; the gathered quanta (their whole indices, rows and
  // pairs, by increasing whole index), those the passes moved, in the order they first moved.
  std::vector<std::uint8_t> mine_, gmark_;
  std::vector<Index> order_, ids_, gtouched_;
  std::vector<Vec3> gpos_, gvel_, gdv_;
  std::vector<std::pair<Index, Index>> gpairs_;
};

// The signed distance of p from the solid shape o describes, positive outside it, and the unit
// normal pointing out of it (Obstacle::distance for a solid).
double solid_distance(const Obstacle& o, const Vec3& p, Vec3& n) {
  using Shape = Obstacle::Shape;
  const Vec3& center = o.center;
  switch (o.shape) {
    case Shape::plane: n = o.normal; return o.normal.dot(p - center);
    case Shape::sphere: {
      const Vec3 q = p - center;
      const double len = q.norm();
      n = len > 0 ? Vec3(q / len) : Vec3::UnitZ();
      return len - o.radius;
    }
    case Shape::box: {
      const Vec3 q = o.rotation.transpose() * (p - center);
      const Vec3 d = q.cwiseAbs() - o.half_extents;
      const Vec3 sign(q.x() < 0 ? -1 : 1, q.y() < 0 ? -1 : 1, q.z() < 0 ? -1 : 1);
      const Vec3 out = d.cwiseMax(0.0);
      const double outside = out.norm();
      Vec3 local;
      if (outside > 0) {
        local = sign.cwiseProduct(out) / outside;
      } else {
        Eigen::Index k;
        d.maxCoeff(&k);
        local = Vec3::Zero();
        local[k] = sign[k];
      }
      n = o.rotation * local;
      return outside > 0 ? outside : d.maxCoeff();
    }
  }
  n = Vec3::UnitZ();
  return 0;
}

}  // namespace

double Obstacle::distance(const Vec3& p, Vec3& n) const {
  const double d = solid_distance(*this, p, n);
  if (!inside || shape == Shape::plane) return d;
  // A container's free side is its inside: the solid's distance and normal, turned over.
  n = -n;
  return -d;
}

double Obstacle::contact_area() const {
  constexpr double pi = 3.14159265358979323846;
  switch (shape) {
    case Shape::plane: return INFINITY;
    case Shape::sphere: {
      const double R = inside ? radius - margin : radius + margin;
      return 4 * pi * R * R;
    }
    case Shape::box: {
      if (inside) {
        const Vec3 e = 2 * (half_extents - Vec3::Constant(margin));
        return 2 * (e.x() * e.y() + e.y() * e.z() + e.z() * e.x());
      }
      // The box grown by the margin: faces, quarter cylinders along the 12 edges, a sphere at the corners.
      const Vec3 e = 2 * half_extents;
      return 2 * (e.x() * e.y() + e.y() * e.z() + e.z() * e.x()) + 2 * pi * margin * e.sum() + 4 * pi * margin * margin;
    }
  }
  return 0;
}

double Obstacle::contact_volume() const {
  if (!inside || shape == Shape::plane) return 0;
  if (shape == Shape::sphere) {
    const double R = radius - margin;
    return 4.0 / 3.0 * 3.14159265358979323846 * R * R * R;
  }
  const Vec3 e = 2 * (half_extents - Vec3::Constant(margin));
  return e.prod();
}

double Obstacle::entry(const Vec3& a, const Vec3& b) const { return qbond::entry(*this, a, b); }

std::unique_ptr<Heuristic> make_obstacle_heuristic(std::vector<Obstacle> obstacles) {
  return std::make_unique<ObstacleHeuristic>(std::move(obstacles));
}

std::unique_ptr<Heuristic> make_heuristic(const Obstacle& obstacle) { return make_obstacle_heuristic({obstacle}); }

std::unique_ptr<Heuristic> make_heuristic(QuantaContactRule rule) {
  return std::make_unique<QuantaContactHeuristic>(rule);
}

std::unique_ptr<Heuristic> make_heuristic(QuantaContactRule rule, ContactRanks& ranks) {
  return std::make_unique<QuantaContactHeuristic>(rule, &ranks);
}

}  // namespace qbond

// ---- Scene types: `ground`, `plane`, `sphere`, `box` and `contact` --------------------------

namespace qbond::scene_detail {
namespace {

ContactMethod contact_method(const Obj& o) {
  return choice<ContactMethod>(
      o["method"], o.at("method"),
      {{"projection", ContactMethod::projection}, {"implicit", ContactMethod::implicit}, {"penalty", ContactMethod::penalty}});
}

// A contact held in the step (method implicit or penalty) against the scene's integrator and its
// other such contacts; its κ from "penalty", or the method's default.
void check_step_contact(const HeuristicEntry& e, ContactMethod method, double& penalty) {
  const Obj& o = e.o;
  const IntegratorType type = e.integrator().type;
  const std::string integrator(to_string(type));
  if (method == ContactMethod::implicit && type != IntegratorType::coupled_implicit)
    bad(o.at("method"), "'implicit' contact is solved by the coupled_implicit integrator, not " + integrator +
                            " (use \"penalty\" or \"projection\")");
  if (method == ContactMethod::penalty && !holds_penalty_contact(type))
    bad(o.at("method"), "'penalty' contact is a force of the explicit integrators, not of " + integrator +
                            (type == IntegratorType::coupled_implicit ? " (use \"implicit\")" : " (use \"projection\")"));
  const Model& m = e.w.model;
  const bool other = std::any_of(m.obstacles.begin(), m.obstacles.end(), [&](const Obstacle& ob) { return ob.method != method; }) ||
                     (m.quanta_contact.radius > 0 && m.quanta_contact.method != method);
  if (other) bad(o.at("method"), "the contacts held in the step take one method, \"implicit\" or \"penalty\"");
  if (method == ContactMethod::penalty) {
    penalty = kPenaltyForceDefault;
    if (o.has("static_friction"))
      bad(o.at("static_friction"), "is a key of \"method\": \"implicit\": a penalty force has no memory of where a contact stuck");
  }
  if (o.has("penalty")) penalty = positive(o["penalty"], o.at("penalty"));
  if (method == ContactMethod::penalty && penalty > kPenaltyForceMost)
    bad(o.at("penalty"), "must be at most " + num_str(kPenaltyForceMost) +
                             " for \"method\": \"penalty\" (the contact's ω h = √penalty; above 1 the explicit step is unstable)");
}

void read_obstacle(const HeuristicEntry& e) {
  const Obj& o = e.o;
  Obstacle ob;
  ob.material = e.contact_material();
  if (o.has("margin")) ob.margin = non_negative(o["margin"], o.at("margin"));
  if (e.type == "ground") {
    ob.center = Vec3(0, 0, o.has("height") ? number(o["height"], o.at("height")) : 0.0);
  } else if (e.type == "plane") {
    ob.center = vec3(o.required("point"), o.at("point"));
    ob.normal = direction(o.required("normal"), o.at("normal"));
  } else if (e.type == "sphere") {
    ob.shape = Obstacle::Shape::sphere;
    ob.center = vec3(o.required("center"), o.at("center"));
    ob.radius = positive(o.required("radius"), o.at("radius"));
  } else {
    ob.shape = Obstacle::Shape::box;
    ob.center = vec3(o.required("center"), o.at("center"));
    const Vec3 size = vec3(o.required("size"), o.at("size"));
    if (!(size.minCoeff() > 0)) bad(o.at("size"), "every edge must be > 0");
    ob.half_extents = 0.5 * size;
    if (o.has("rotation")) {
      Obj r(o["rotation"], o.at("rotation"), keys_of("rotation"));
      ob.rotation = Eigen::AngleAxisd(number(r.required("angle"), r.at("angle")),
                                      direction(r.required("axis"), r.at("axis")))
                        .toRotationMatrix();
    }
  }
  if (o.has("inside")) {
    ob.inside = boolean(o["inside"], o.at("inside"));
    const double room = ob.shape == Obstacle::Shape::sphere ? ob.radius : ob.half_extents.minCoeff();
    if (ob.inside && !(ob.margin < room))
      bad(o.at("margin"), "must be below the container's " + std::string(ob.shape == Obstacle::Shape::sphere ? "radius" : "half size") +
                              " " + num_str(room) + " m, or no quanta fits inside");
  }
  if (o.has("method")) ob.method = contact_method(o);
  if (ob.method != ContactMethod::projection) {
    check_step_contact(e, ob.method, ob.penalty);
    // Held by the step: the model's, not a rule that edits the projection.
    e.w.model.obstacles.push_back(ob);
    return;
  }
  if (o.has("static_friction") || o.has("penalty"))
    bad(o.path(), "static_friction and penalty are keys of \"method\": \"implicit\" or \"penalty\" obstacles");
  // Every obstacle records the impulse it gives (diagnostics' obstacle<k>_ columns).
  ob.record = e.next_obstacle_record();
  e.out.emplace_back(ob);
}

// Quanta that share no bond but start closer than two contact radii would be pushed apart on
// the first step: a radius too large for the lattice.
void check_contact_radius(const QuantaContactRule& r, const Obj& o, const World& w) {
  std::unordered_set<std::uint64_t> bonded;
  for (std::size_t b = 0; b < w.num_bonds(); ++b) bonded.insert(pair_key(w.state.bonds.i[b], w.state.bonds.j[b]));
  // Touching neighbours are a few dozen a quanta at most; far more means a radius of another
  // scale, refused before a quadratic number of pairs is listed.
  const std::size_t most = w.num_bonds() + 64 * w.num_quanta();
  std::vector<std::pair<Index, Index>> pairs;
  try {
    pairs = pairs_within_radius(w.state.x, 2 * r.radius, most);
  } catch (const std::length_error&) {
    bad(o.at("radius"), "more than " + std::to_string(most) + " pairs of quanta lie within 2 x radius = " +
                            num_str(2 * r.radius) + " m: the radius is far larger than the quanta's spacing");
  }
  for (const auto& [a, b] : pairs) {
    if (bonded.count(pair_key(a, b))) continue;
    if (!r.same_body && w.model.body[a] == w.model.body[b]) continue;
    if (w.model.is_kinematic(a) && w.model.is_kinematic(b)) continue;
    const double d = (w.state.x[a] - w.state.x[b]).norm();
    if (d < 2 * r.radius)
      bad(o.at("radius"), "2 x radius = " + num_str(2 * r.radius) + " m exceeds the distance " + num_str(d) +
                              " m of quanta " + std::to_string(a) + " and " + std::to_string(b) +
                              ", which share no bond: they would be pushed apart at once");
  }
}

}  // namespace

std::span<const HeuristicReader> scene_readers(std::type_identity<Obstacle>) {
  using Keys = std::vector<SceneKey>;
  static const Keys obstacle_keys = {{"type", "string"},          {"restitution", "number"},
                                     {"friction", "number"},      {"margin", "number"},
                                     {"static_friction", "number"}, {"method", "enum:projection|implicit|penalty"},
                                     {"penalty", "number"}};
  auto with = [](Keys keys, std::initializer_list<SceneKey> more) {
    keys.insert(keys.end(), more);
    return keys;
  };
  static const HeuristicReader rows[] = {
      {"ground", "an obstacle: the plane z = height", with(obstacle_keys, {{"height", "number"}}), read_obstacle},
      {"plane", "an obstacle: a plane through a point", with(obstacle_keys, {{"point", "vec3"}, {"normal", "vec3"}}), read_obstacle},
      {"sphere", "an obstacle: a sphere, or a spherical container with inside: true",
       with(obstacle_keys, {{"center", "vec3"}, {"radius", "number"}, {"inside", "boolean"}}), read_obstacle},
      {"box", "an obstacle: a box, turned by rotation, or a box container with inside: true",
       with(obstacle_keys, {{"center", "vec3"}, {"size", "vec3"}, {"rotation", "@rotation"}, {"inside", "boolean"}}),
       read_obstacle},
  };
  return rows;
}

std::span<const HeuristicReader> scene_readers(std::type_identity<QuantaContactRule>) {
  static const HeuristicReader rows[] = {
      {"contact", "quanta–quanta collisions between quanta that share no bond",
       {{"type", "string"},
        {"radius", "number"},
        {"restitution", "number"},
        {"friction", "number"},
        {"iterations", "integer"},
        {"same_body", "boolean"},
        {"static_friction", "number"},
        {"method", "enum:projection|implicit|penalty"},
        {"penalty", "number"}},
       [](const HeuristicEntry& e) {
         const Obj& o = e.o;
         QuantaContactRule r;
         r.radius = positive(o.required("radius"), o.at("radius"));
         r.material = e.contact_material();
         if (o.has("iterations")) r.iterations = static_cast<int>(integer(o["iterations"], o.at("iterations"), 1));
         if (o.has("same_body")) r.same_body = boolean(o["same_body"], o.at("same_body"));
         if (o.has("method")) r.method = contact_method(o);
         check_contact_radius(r, o, e.w);
         if (r.method != ContactMethod::projection) {
           check_step_contact(e, r.method, r.penalty);
           if (o.has("iterations")) bad(o.at("iterations"), "is a key of \"method\": \"projection\" contact");
           if (e.w.model.quanta_contact.radius > 0)
             bad(o.path(), "one \"contact\" rule held in the step (\"implicit\" or \"penalty\") at most");
           // Held by the step: the model's, not a rule that edits the projection.
           e.w.model.quanta_contact = r;
           return;
         }
         if (o.has("static_friction") || o.has("penalty"))
           bad(o.path(), "static_friction and penalty are keys of \"method\": \"implicit\" or \"penalty\" contact");
         e.out.emplace_back(r);
       }},
  };
  return rows;
}

}  // namespace qbond::scene_detail
