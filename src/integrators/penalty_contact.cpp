#include "integrators/penalty_contact.hpp"

#include <algorithm>
#include <cmath>

namespace qbond {

bool PenaltyContact::used(const Model& model) {
  const QuantaContactRule& rule = model.quanta_contact;
  if (rule.radius > 0 && rule.method == ContactMethod::penalty) return true;
  return std::any_of(model.obstacles.begin(), model.obstacles.end(),
                     [](const Obstacle& o) { return o.method == ContactMethod::penalty; });
}

namespace {

// The restitution of a spring–dashpot contact of damping ratio ζ, whose force k δ + c δ̇ ends the
// contact when it reaches zero (it never pulls): in time τ = ω t the depth is δ = e^{−ζτ} sin(sτ)/s,
// s = √(1 − ζ²) (sinh and √(ζ² − 1) above ζ = 1), the force is zero at tan(sτ) = 2ζs / (2ζ² − 1),
// and e = −δ'(τ) there.
double restitution_of(double zeta) {
  if (zeta == 0) return 1;
  if (std::abs(zeta - 1) < 1e-9) return std::exp(-2.0);
  if (zeta < 1) {
    const double s = std::sqrt(1 - zeta * zeta), theta = std::atan2(2 * zeta * s, 2 * zeta * zeta - 1);
    return -std::exp(-zeta * theta / s) * (std::cos(theta) - zeta / s * std::sin(theta));
  }
  const double s = std::sqrt(zeta * zeta - 1), theta = std::atanh(2 * zeta * s / (2 * zeta * zeta - 1));
  return -std::exp(-zeta * theta / s) * (std::cosh(theta) - zeta / s * std::sinh(theta));
}

// The damping ratio for restitution e at penalty κ: restitution_of falls from 1 at ζ = 0, bisected
// up to the most the step takes, 1 / (2 √κ).
double damping_ratio_for(double e, double kappa) {
  const double most = 0.5 / std::sqrt(kappa);
  if (restitution_of(most) >= e) return most;
  double lo = 0, hi = most;
  for (int k = 0; k < 100; ++k) {
    const double mid = 0.5 * (lo + hi);
    (restitution_of(mid) > e ? lo : hi) = mid;
  }
  return lo;
}

}  // namespace

double penalty_restitution(double e, double kappa) { return restitution_of(damping_ratio_for(e, kappa)); }

double PenaltyContact::damping_ratio(double e, double kappa) {
  for (const Damping& d : damping_)
    if (d.e == e && d.kappa == kappa) return d.zeta;
  damping_.push_back({e, kappa, damping_ratio_for(e, kappa)});
  return damping_.back().zeta;
}

void PenaltyContact::add(const ContactMaterial& mat, double kappa, double m, double h, double depth, const Vec3& n,
                         const Vec3& w, bool counted, Vec3& f) {
  const double k = kappa * m / (h * h);
  const double c = 2 * damping_ratio(mat.restitution, kappa) * std::sqrt(kappa) * m / h;  // 2 ζ √(k m)
  const double rate = -n.dot(w);  // δ̇: the approach speed
  const double fn = std::max(0.0, k * depth + c * rate);
  if (counted) stored_ += 0.5 * k * depth * depth;
  const Vec3 wt = w + rate * n;  // the tangential part of w
  const double s = wt.norm();
  if (mat.friction > 0 && s > 0) f -= (std::min(mat.friction * fn, m / h * s) / s) * wt;
  f += fn * n;
}

void PenaltyContact::update_pairs(const Model& model, const Adjacency& adj, const PointsView& p) {
  const QuantaContactRule& rule = model.quanta_contact;
  const std::size_t n = model.num_quanta();
  const double skin = rule.radius;
  bool listed = listed_at_.size() == n && listed_version_ == adj.version;
  for (std::size_t q = 0; q < n && listed; ++q)
    listed = (p.x_at(q) - listed_at_[q]).squaredNorm() <= 0.25 * skin * skin;
  if (listed) return;
  listed_at_.resize(n);
  for (std::size_t q = 0; q < n; ++q) listed_at_[q] = p.x_at(q);
  listed_version_ = adj.version;
  pairs_.clear();
  const double reach = 2 * rule.radius + skin;
  grid_.build(listed_at_, reach);
  grid_.pairs(listed_at_, [&](Index i, Index j) {
    if (model.is_kinematic(i) && model.is_kinematic(j)) return;
    if (!rule.same_body && model.body[i] == model.body[j]) return;
    if ((listed_at_[j] - listed_at_[i]).norm() >= reach) return;
    for (Index e = adj.offset[i]; e < adj.offset[i + 1]; ++e)
      if (adj.other[e] == j) return;
    pairs_.emplace_back(i, j);
  });
  std::sort(pairs_.begin(), pairs_.end());
}

void PenaltyContact::evaluate(const Model& model, const Adjacency& adj, double h, const PointsView& p,
                              std::span<const std::uint8_t> counted) {
  auto counts = [&](Index q) { return counted.empty() || counted[q] != 0; };
  forces_.clear();
  stored_ = 0;
  const std::size_t n = model.num_quanta();
  const QuantaContactRule& rule = model.quanta_contact;
  const bool pairs = rule.radius > 0 && rule.method == ContactMethod::penalty;
  if (pairs) {
    update_pairs(model, adj, p);
    sum_.assign(n, Vec3::Zero());
    touched_.assign(n, 0);
    for (const auto& [i, j] : pairs_) {
      const Vec3 d = p.x_at(j) - p.x_at(i);
      const double r = d.norm(), depth = 2 * rule.radius - r;
      if (!(depth > 0) || !(r > 0)) continue;
      const double mu = 1 / (model.inv_mass[i] + model.inv_mass[j]);
      Vec3 f = Vec3::Zero();  // on j
      add(rule.material, rule.penalty, mu, h, depth, d / r, p.v_at(j) - p.v_at(i), counts(i), f);
      sum_[i] -= f;
      sum_[j] += f;
      touched_[i] = touched_[j] = 1;
    }
  }
  for (std::size_t q = 0; q < n; ++q) {
    const Index i = static_cast<Index>(q);
    if (model.is_kinematic(i)) continue;
    bool touching = pairs && touched_[q];
    Vec3 f = pairs ? sum_[q] : Vec3::Zero();
    for (const Obstacle& ob : model.obstacles) {
      Vec3 normal;
      const double depth = ob.margin - ob.distance(p.x_at(q), normal);
      if (!(depth > 0)) continue;
      add(ob.material, ob.penalty, model.mass[q], h, depth, normal, p.v_at(q), counts(i), f);
      touching = true;
    }
    if (touching) forces_.push_back({i, f});
  }
}

}  // namespace qbond
