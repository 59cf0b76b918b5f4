#pragma once
/// The registry of bond force laws: every law is declared once, in its own header (linear.hpp,
/// inverse.hpp, …), and listed once in QBOND_LAWS below. The Law enum, the law names of scene
/// files, each law's scene keys and their checks, the resolved scene, the checkpoint's law ids
/// and the docs test all derive from this list.
///
/// Adding a law touches only: its header (name, parameters, T, T', U, the mean tension, its
/// failure stretch), its tests (tests/laws_test.cpp: add it to law_cases()), and one line of
/// QBOND_LAWS (appended last: the enum's values are saved in checkpoints). Its rows of
/// docs/scene-format.md's "Force laws" table are written from its header by `qbond key-tables`.
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "qbond/laws/cohesive.hpp"
#include "qbond/laws/fene.hpp"
#include "qbond/laws/inverse.hpp"
#include "qbond/laws/linear.hpp"
#include "qbond/laws/morse.hpp"

namespace qbond {

/// X(enum name, law type). Append new laws; the order fixes the ids saved in checkpoints.
#define QBOND_LAWS(X) \
  X(linear, LinearLaw) \
  X(inverse, InverseLaw) \
  X(morse, MorseLaw) \
  X(fene, FeneLaw) \
  X(cohesive, CohesiveLaw)

/// Which scalar law a bond follows (its header says the formula and parameters).
enum class Law : std::uint8_t {
#define QBOND_LAW_ENUM(id, Type) id,
  QBOND_LAWS(QBOND_LAW_ENUM)
#undef QBOND_LAW_ENUM
};

/// Number of laws: a Law's id is below it.
inline constexpr int kNumLaws = 0
#define QBOND_LAW_COUNT(id, Type) +1
    QBOND_LAWS(QBOND_LAW_COUNT)
#undef QBOND_LAW_COUNT
    ;

// The dispatchers are switches forced inline, as one law's evaluation was before the registry:
// in a bond loop the compiler then drops what the caller does not use (U's log1p when only T
// is read) and keeps the hot loops' code its own (the vector clones of core/simd.hpp).
/// Evaluates a law at length r for rest length L.
[[gnu::always_inline]] inline LawValue evaluate_law(Law law, double r, double L, const LawArgs& a) {
  switch (law) {
#define QBOND_LAW_CASE(id, Type) \
  case Law::id:                  \
    return Type::eval(r, L, a);
    QBOND_LAWS(QBOND_LAW_CASE)
#undef QBOND_LAW_CASE
  }
  return {};
}

/// The law's mean tension T̄ and ∂T̄/∂r1 over a step from length r0 to r1 (MeanTension).
[[gnu::always_inline]] inline MeanTension mean_tension(Law law, double r0, double r1, double L, const LawArgs& a) {
  switch (law) {
#define QBOND_LAW_CASE(id, Type) \
  case Law::id:                  \
    return Type::mean(r0, r1, L, a);
    QBOND_LAWS(QBOND_LAW_CASE)
#undef QBOND_LAW_CASE
  }
  return {};
}

/// Stretch r − L at which the law breaks its bond (the step's break_failed_bonds stage applies it); +∞ for laws
/// that never break by themselves.
inline double failure_stretch(Law law, double L, const LawArgs& a) {
  switch (law) {
#define QBOND_LAW_CASE(id, Type) \
  case Law::id:                  \
    return Type::failure_stretch(L, a);
    QBOND_LAWS(QBOND_LAW_CASE)
#undef QBOND_LAW_CASE
  }
  return std::numeric_limits<double>::infinity();
}

/// Whether the law has a failure stretch at all (failure_stretch is finite).
inline bool law_breaks(Law law) {
  switch (law) {
#define QBOND_LAW_CASE(id, Type) \
  case Law::id:                  \
    return Type::breaks;
    QBOND_LAWS(QBOND_LAW_CASE)
#undef QBOND_LAW_CASE
  }
  return false;
}

/// T'(L): the law's stiffness at rest (what an explicit step's stability sees).
inline double rest_stiffness(Law law, const LawArgs& a) {
  switch (law) {
#define QBOND_LAW_CASE(id, Type) \
  case Law::id:                  \
    return Type::rest_stiffness(a);
    QBOND_LAWS(QBOND_LAW_CASE)
#undef QBOND_LAW_CASE
  }
  return 0;
}

/// A law's declaration as scenes and docs see it.
struct LawInfo {
  Law law;
  std::string_view name;               ///< as written in scene files
  std::string_view doc;                ///< its formula in s = r − L (docs: after its strength's doc)
  LawParam strength;                   ///< the per-bond parameter (Bonds::strength)
  std::span<const LawParam> shape;     ///< the material's shape parameters (Model::shapes)
  bool calibrated_by_modulus;          ///< its strength is its stiffness at rest [N/m]
  std::string_view (*invalid)(const LawShape&);  ///< cross-parameter rule: empty when valid
};

/// Every law, in id order.
inline std::span<const LawInfo> all_laws() {
  static const LawInfo laws[] = {
#define QBOND_LAW_INFO(id, Type) \
  LawInfo{Law::id, Type::name, Type::doc, Type::strength, Type::shape, Type::calibrated_by_modulus, &Type::invalid},
      QBOND_LAWS(QBOND_LAW_INFO)
#undef QBOND_LAW_INFO
  };
  return laws;
}

/// The declaration of one law.
inline const LawInfo& law_info(Law law) { return all_laws()[static_cast<std::size_t>(law)]; }

/// Name of a law as written in scene files.
inline std::string_view to_string(Law law) { return law_info(law).name; }

/// The law of a scene file's name, if there is one.
inline std::optional<Law> parse_law(std::string_view name) {
  for (const LawInfo& l : all_laws())
    if (l.name == name) return l.law;
  return std::nullopt;
}

/// Whether a stored law id (a checkpoint's byte) names a law.
inline bool is_law_id(std::uint8_t id) { return id < kNumLaws; }

/// The shape parameters a bond's law validates, or a message: each must be > 0 unless it has a
/// default (stored as 0), then the law's own cross-parameter rule.
inline std::string invalid_law_shape(Law law, const LawShape& p) {
  const LawInfo& l = law_info(law);
  for (std::size_t k = 0; k < kMaxLawShape; ++k) {
    if (k >= l.shape.size()) {
      if (p[k] != 0) return std::string(l.name) + " has no shape parameter " + std::to_string(k);
      continue;
    }
    if (!(p[k] > 0) && !(l.shape[k].fallback.size() && p[k] == 0))
      return std::string(l.name) + "." + std::string(l.shape[k].key) + " must be > 0";
  }
  return std::string(l.invalid(p));
}

}  // namespace qbond
