// The carry-over types' checkpoint encoding and sizes (carry.hpp).
#include "qbond/integrators/carry.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "integrators/affine_run_terms.hpp"  // soa_stride
#include "qbond/io/binary.hpp"

namespace qbond {
namespace {

// A vector read from a checkpoint, of the length a state of n quanta needs.
template <class T, class A>
void read_sized(Reader& r, std::vector<T, A>& v, std::size_t length, const char* what) {
  v = r.vec<T, A>();
  if (v.size() != length)
    throw CheckpointError(std::string("state: carry-over ") + what + " has " + std::to_string(v.size()) +
                          " entries, not " + std::to_string(length));
}

template <class... T>
struct Overloaded : T... {
  using T::operator()...;
};
template <class... T>
Overloaded(T...) -> Overloaded<T...>;  // for compilers without C++20's aggregate deduction (clang 14)

// Every kind has its own tag, and monostate's is 0.
constexpr bool distinct_kinds() {
  const std::uint8_t k[] = {0, SolverGuess::kKind, SolverGuessPair::kKind, Bdf2History::kKind, VerletForces::kKind};
  for (std::size_t a = 0; a < std::size(k); ++a)
    for (std::size_t b = a + 1; b < std::size(k); ++b)
      if (k[a] == k[b]) return false;
  return true;
}
static_assert(distinct_kinds(), "carry-over kinds need distinct tags");

}  // namespace

void SolverGuess::save(Writer& w) const { w.vec(dv); }
void SolverGuess::load(Reader& r, std::size_t n) { read_sized(r, dv, n, "dv"); }

void SolverGuessPair::save(Writer& w) const {
  w.vec(dv);
  w.vec(dv_before);
  w.pod(h);
  w.pod(h_before);
}
void SolverGuessPair::load(Reader& r, std::size_t n) {
  read_sized(r, dv, n, "dv");
  read_sized(r, dv_before, n, "dv_before");
  h = r.pod<double>();
  h_before = r.pod<double>();
}

void Bdf2History::save(Writer& w) const {
  w.vec(x);
  w.vec(v);
  w.pod(t);
  w.pod(h);
  w.pod(step);
}
void Bdf2History::load(Reader& r, std::size_t n) {
  read_sized(r, x, n, "x");
  read_sized(r, v, n, "v");
  t = r.pod<double>();
  h = r.pod<double>();
  step = r.pod<std::uint64_t>();
}

void VerletForces::resize(std::size_t n) {
  const std::size_t stride = soa_stride(n);
  f.resize(3 * stride);
  x.resize(3 * stride);
  v.resize(n);
  // The affine runs read up to a vector past the last quanta, and a checkpoint saves the padding.
  for (std::size_t c = 0; c < 3; ++c) {
    std::fill(f.begin() + static_cast<std::ptrdiff_t>(c * stride + n),
              f.begin() + static_cast<std::ptrdiff_t>((c + 1) * stride), 0.0);
    std::fill(x.begin() + static_cast<std::ptrdiff_t>(c * stride + n),
              x.begin() + static_cast<std::ptrdiff_t>((c + 1) * stride), 0.0);
  }
}

void VerletForces::save(Writer& w) const {
  w.vec(f);
  w.vec(x);
  w.vec(v);
  w.pod(topology_version);
}
void VerletForces::load(Reader& r, std::size_t n) {
  read_sized(r, f, 3 * soa_stride(n), "f");
  read_sized(r, x, 3 * soa_stride(n), "x");
  read_sized(r, v, n, "v");
  topology_version = r.pod<std::uint64_t>();
}

void drop_after_bond_edit(Carry& c) {
  const bool holds =
      std::visit(Overloaded{[](const std::monostate&) { return true; },
                            [](const auto& kept) { return kept.holds_after_bond_edit(); }},
                 c);
  if (!holds) c = std::monostate{};
}

void save_carry(Writer& w, const Carry& c) {
  std::visit(Overloaded{[&](const std::monostate&) { w.pod<std::uint8_t>(0); },
                        [&](const auto& kept) {
                          w.pod(kept.kKind);
                          kept.save(w);
                        }},
             c);
}

Carry load_carry(Reader& r, std::size_t n) {
  Carry c;
  const auto kind = r.pod<std::uint8_t>();
  auto read = [&]<class T>(T&& kept) {
    kept.load(r, n);
    c = std::move(kept);
  };
  switch (kind) {
    case 0: break;
    case SolverGuess::kKind: read(SolverGuess{}); break;
    case SolverGuessPair::kKind: read(SolverGuessPair{}); break;
    case Bdf2History::kKind: read(Bdf2History{}); break;
    case VerletForces::kKind: read(VerletForces{}); break;
    default: throw CheckpointError("state: unknown carry-over kind " + std::to_string(kind));
  }
  return c;
}

Carry carry_from_version4(const LineVector<Vec3>& old, std::size_t n) {
  // Version 4 kept every kind in one array of triples: Δv (n); Δv, the Δv before and (h, h before,
  // -1) (2n + 1); BDF2's x, v and (t, h, step) (2n + 1, t ≥ 0 never -1 in the last slot's z);
  // Verlet's f and x rows, v and (topology version, 0, 0) (2 soa_stride(n) + n + 1); or Verlet's
  // older layout (3n + 1), which a step dropped.
  const auto at = [&](std::size_t i) { return old.begin() + static_cast<std::ptrdiff_t>(i); };
  // A count kept as a double: a whole number in [0, 2^64), or the file is damaged (casting
  // anything else is undefined).
  const auto count = [](double v, const char* what) {
    if (!(v >= 0 && v < 18446744073709551616.0 && v == std::floor(v)))
      throw CheckpointError(std::string("state: a version-4 carry-over's ") + what + " is not a count");
    return static_cast<std::uint64_t>(v);
  };
  if (old.empty() || old.size() == 3 * n + 1) return {};
  if (old.size() == n) return SolverGuess{LineVector<Vec3>(old.begin(), old.end())};
  if (old.size() == 2 * n + 1) {
    const Vec3& tag = old[2 * n];
    if (tag.z() == -1.0)
      return SolverGuessPair{LineVector<Vec3>(old.begin(), at(n)), LineVector<Vec3>(at(n), at(2 * n)), tag.x(),
                             tag.y()};
    return Bdf2History{std::vector<Vec3>(old.begin(), at(n)), std::vector<Vec3>(at(n), at(2 * n)), tag.x(), tag.y(),
                       count(tag.z(), "step")};
  }
  const std::size_t stride = soa_stride(n);
  if (old.size() == 2 * stride + n + 1) {
    VerletForces c;
    const double* d = old.data()->data();
    c.f.assign(d, d + 3 * stride);
    c.x.assign(d + 3 * stride, d + 6 * stride);
    c.v.assign(at(2 * stride), at(2 * stride + n));
    c.topology_version = count(old.back().x(), "topology version");
    return c;
  }
  throw CheckpointError("state: a version-4 carry-over of " + std::to_string(old.size()) + " triples is for no " +
                        "integrator of " + std::to_string(n) + " quanta");
}

}  // namespace qbond
