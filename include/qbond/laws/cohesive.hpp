#pragma once
/// The bilinear cohesive bond for fracture: T = k s up to the peak stretch, then linear softening
/// to zero at the failure stretch, where the bond breaks.
#include "qbond/laws/law.hpp"

namespace qbond {

/// With s = r − L, s_p = ε_p L and s_f = ε_f L (strains of the rest length L):
///   T = k s                          for s ≤ s_p (compression too),
///   T = k s_p (s_f − s)/(s_f − s_p)  for s_p < s < s_f,
///   T = 0                            for s ≥ s_f;
/// U = k s²/2, then G − k s_p (s_f − s)²/(2 (s_f − s_p)), then G = k s_p s_f / 2 (the energy a bond
/// takes to break, the area under T). The law declares s_f as its failure stretch: the step breaks a
/// bond that reaches it (events.csv reason `failure`), with or without heuristics, and charges G
/// as dissipated. Softening is elastic: a bond unloaded before s_f goes back along T(s), not along a
/// damaged secant (no damage history is kept).
struct CohesiveLaw {
  static constexpr std::string_view name = "cohesive";
  static constexpr std::string_view doc =
      "T = k s up to s_p, then linear softening to 0 at s_f, 0 beyond; T = k s in compression";
  static constexpr LawParam strength{"stiffness", "N/m", "k, before the peak"};
  static constexpr std::array<LawParam, 2> shape{
      LawParam{"peak_strain", "1", "ε_p: s_p = ε_p L, the largest tension k s_p"},
      LawParam{"failure_strain", "1", "ε_f, > `peak_strain`: s_f = ε_f L", {},
               "A bond that reaches s_f breaks (events reason `failure`) and its fracture energy G = k s_p s_f / 2 is "
               "charged as dissipated, by the step itself: no `break` rule is needed. The softening is elastic: a bond "
               "unloaded before s_f goes back along T(s), without damage"}};
  static constexpr bool calibrated_by_modulus = true;

  struct Branches {
    double sp, sf, soft;  ///< peak and failure stretch [m], softening slope −k s_p/(s_f − s_p) [N/m]
  };
  static Branches branches(double L, const LawArgs& a) {
    const double sp = a.shape[0] * L, sf = a.shape[1] * L;
    return {sp, sf, -a.strength * sp / (sf - sp)};
  }
  [[gnu::always_inline]] static LawValue at(double s, double k, const Branches& b) {
    if (s <= b.sp) return {k * s, k, 0.5 * k * s * s};
    const double G = 0.5 * k * b.sp * b.sf;
    if (s >= b.sf) return {0, 0, G};
    const double t = b.sf - s;
    return {-b.soft * t, b.soft, G + 0.5 * b.soft * t * t};
  }
  [[gnu::always_inline]] static LawValue eval(double r, double L, const LawArgs& a) { return at(r - L, a.strength, branches(L, a)); }

  /// T is piecewise linear in r, so over each piece of [s0, s1] between the kinks s_p and s_f the
  /// mean tension is T at the piece's middle: T̄ = Σ (len_k/dr) T(mid_k), weights in [0, 1].
  /// ∂T̄/∂r1 = (T(r1) − T̄)/dr = (1/dr²) ∫ T'(ρ) (ρ − s0) dρ = Σ T'_k (e_k − b_k)(e_k + b_k − 2 s0) / (2 dr²)
  /// over the pieces [b_k, e_k] in the step's order: products, no cancellation; T'/2 on one piece.
  static MeanTension mean(double r0, double r1, double L, const LawArgs& a) {
    const double k = a.strength, dr = r1 - r0, s0 = r0 - L, s1 = r1 - L;
    const Branches br = branches(L, a);
    double cuts[2];
    int n = 0;
    for (double c : {br.sp, br.sf})
      if ((s0 - c) * (s1 - c) < 0) cuts[n++] = c;
    if (n == 0) {
      const double mid = 0.5 * (s0 + s1);
      if (mid <= br.sp) return {k * (0.5 * (r0 + r1) - L), 0.5 * k};  // the linear law's, to the bit
      const LawValue v = at(mid, k, br);
      return {v.T, 0.5 * v.dT};
    }
    if (n == 2 && s1 < s0) std::swap(cuts[0], cuts[1]);
    MeanTension m;
    double from = s0;
    for (int j = 0; j <= n; ++j) {
      const double to = j < n ? cuts[j] : s1;
      const LawValue v = at(0.5 * (from + to), k, br);
      m.T += (to - from) / dr * v.T;
      m.dT1 += v.dT * ((to - from) / dr) * ((to + from - 2 * s0) / dr) * 0.5;
      from = to;
    }
    return m;
  }
  static double rest_stiffness(const LawArgs& a) { return a.strength; }
  /// It has a failure stretch, s_f: the bond breaks once r − L reaches it.
  static constexpr bool breaks = true;
  static double failure_stretch(double L, const LawArgs& a) { return a.shape[1] * L; }
  static std::string_view invalid(const LawShape& p) {
    return p[1] > p[0] ? std::string_view{} : "failure_strain must be > peak_strain";
  }
};

}  // namespace qbond
