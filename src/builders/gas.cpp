#include "qbond/builders/gas.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "qbond/builders/packing.hpp"

namespace qbond {
namespace {

// The gas's velocity stream, apart from the positions' (the packing's, same seed) and the run's.
Rng gas_rng(std::uint64_t seed) {
  Rng mix{seed ^ 0x6761732076656c21ull};  // "gas vel!"
  return Rng{mix.next()};
}

// A standard normal pair by Marsaglia's polar method (a point in the unit disc, no trigonometry).
std::pair<double, double> normal_pair(Rng& rng) {
  for (;;) {
    const double u = 2 * rng.uniform() - 1, v = 2 * rng.uniform() - 1, s = u * u + v * v;
    if (s >= 1 || s == 0) continue;
    const double f = std::sqrt(-2 * std::log(s) / s);
    return {u * f, v * f};
  }
}

// A uniformly random unit vector: a point of the unit ball, normalised (rejection, no trigonometry).
Vec3 unit_vector(Rng& rng) {
  for (;;) {
    const Vec3 p(2 * rng.uniform() - 1, 2 * rng.uniform() - 1, 2 * rng.uniform() - 1);
    const double r2 = p.squaredNorm();
    if (r2 <= 1 && r2 > 1e-6) return p / std::sqrt(r2);
  }
}

}  // namespace

std::vector<Index> add_gas(World& w, const Gas& g, Index body) {
  if (g.count < 2) throw std::invalid_argument("a gas needs at least 2 quanta (zero total momentum)");
  if (!(g.size.minCoeff() > 0)) throw std::invalid_argument("a gas's box needs every edge > 0");
  if (!(g.quanta_mass > 0)) throw std::invalid_argument("a gas's quanta mass must be > 0");
  if (!(g.kT > 0)) throw std::invalid_argument("a gas's kT must be > 0");
  PointPacking pack;
  pack.kind = PointPacking::random;
  pack.size = g.size;
  pack.min_distance = g.min_distance;
  pack.count = g.count;
  pack.seed = g.seed;
  const std::vector<Vec3> x = sample_points(pack);

  const std::size_t n = x.size();
  std::vector<Vec3> v(n);
  Rng rng = gas_rng(g.seed);
  if (g.speeds == Gas::Speeds::maxwell) {
    // Each component normal with variance kT/m, then the mean removed (zero momentum: the masses
    // are equal) and the whole scaled so that ½ m Σ|v|² is exactly 3/2 n kT.
    std::vector<double> z(3 * n);
    for (std::size_t k = 0; k < z.size(); k += 2) {
      const auto [a, b] = normal_pair(rng);
      z[k] = a;
      if (k + 1 < z.size()) z[k + 1] = b;
    }
    Vec3 mean = Vec3::Zero();
    for (std::size_t i = 0; i < n; ++i) {
      v[i] = Vec3(z[3 * i], z[3 * i + 1], z[3 * i + 2]);
      mean += v[i];
    }
    mean /= static_cast<double>(n);
    double sum2 = 0;
    for (Vec3& vi : v) {
      vi -= mean;
      sum2 += vi.squaredNorm();
    }
    const double scale = std::sqrt(3 * static_cast<double>(n) * g.kT / (g.quanta_mass * sum2));
    for (Vec3& vi : v) vi *= scale;
  } else {
    // Equal speeds: pairs ±u, and for an odd count three vectors 120° apart in a random plane,
    // so that the momentum is zero without changing any speed.
    const double u = std::sqrt(3 * g.kT / g.quanta_mass);
    std::size_t i = 0;
    for (; i + (n % 2 ? 3 : 0) < n; i += 2) {
      v[i] = u * unit_vector(rng);
      v[i + 1] = -v[i];
    }
    if (n % 2) {
      const Vec3 a = unit_vector(rng);
      Vec3 b;
      do {
        b = unit_vector(rng);
        b -= b.dot(a) * a;
      } while (b.squaredNorm() < 1e-6);
      b.normalize();
      const double c = std::sqrt(3.0) / 2;
      v[i] = u * a;
      v[i + 1] = u * (-0.5 * a + c * b);
      v[i + 2] = u * (-0.5 * a - c * b);
    }
  }
  std::vector<Index> ids;
  ids.reserve(n);
  for (std::size_t i = 0; i < n; ++i) ids.push_back(w.add_quanta(x[i], v[i], g.quanta_mass, body));
  return ids;
}

double kinetic_temperature(const Model& m, const State& s, std::span<const Index> ids) {
  if (ids.empty()) return 0;
  double e = 0;
  for (Index i : ids) e += 0.5 * m.mass[i] * s.v[i].squaredNorm();
  return 2.0 / 3.0 * e / static_cast<double>(ids.size());
}

}  // namespace qbond
