#pragma once
// `automatic`'s choice between block Jacobi and multigrid for the coupled integrator's CG, from
// the iteration counts of whole steps alone (never their times): the same choices, hence the
// same bits, on any machine and thread count.
#include <algorithm>
#include <cstddef>

#include "qbond/integrators/integrators.hpp"

namespace qbond {

/// A multigrid iteration's cost in block-Jacobi iterations: a V-cycle applies the fine operator
/// four times (two Chebyshev smoothings of degree 2) beside CG's product, and restricts,
/// prolongs and smooths the coarse levels (docs/integrators.md, "Multigrid").
inline constexpr int kMultigridIterationCost = 10;
/// Multigrid iterations at or below which block Jacobi is tried again (the steps may have become
/// small enough for it), and the most whole steps between two such tries.
inline constexpr int kJacobiTryBelow = 2;
inline constexpr int kJacobiTryWaitMost = 64;

/// Block Jacobi first; multigrid once a block-Jacobi step needs more than kMultigridAfter
/// iterations a solve on a world of at least kMultigridQuanta quanta. Then each step's solves (a
/// step with contacts solves again while its active set changes), their mean iterations, are
/// compared with the other preconditioner's last step's, a multigrid iteration counted as
/// kMultigridIterationCost block-Jacobi ones: block Jacobi turns to multigrid when its solves cost
/// more than multigrid's last; a multigrid step whose solves cost more than block Jacobi's last (a
/// hierarchy that fits the system badly, as with many contacts changing from step to step), or
/// took at most kJacobiTryBelow iterations (the steps may have become small), tries block Jacobi
/// next. A step may report both (its first solves by block Jacobi, the rest by multigrid). Each
/// return to multigrid after such a try doubles the multigrid steps before the next try (at most
/// kJacobiTryWaitMost): a settled body whose multigrid solves take two iterations and block
/// Jacobi's fifty does not alternate between the two.
class PreconditionerChoice {
 public:
  /// Whether the next whole step's solve on a world of `quanta` quanta uses multigrid.
  bool multigrid(std::size_t quanta) {
    if (quanta != quanta_) *this = PreconditionerChoice{};  // another body: block Jacobi first
    quanta_ = quanta;
    return multigrid_;
  }

  /// A whole step's block-Jacobi solves took `iterations` each on average.
  void after_jacobi(int iterations) {
    jacobi_iterations_ = std::max(iterations, 1);
    if (quanta_ < kMultigridQuanta) return;
    const int most = multigrid_iterations_ > 0 ? kMultigridIterationCost * multigrid_iterations_ : kMultigridAfter;
    if (iterations <= most) return;
    multigrid_ = true;
    if (multigrid_iterations_ > 0) {  // back from a try
      wait_most_ = std::min(2 * wait_most_, kJacobiTryWaitMost);
      wait_ = wait_most_;
    }
  }

  /// A whole step's multigrid solves took `iterations` each on average.
  void after_multigrid(int iterations) {
    multigrid_iterations_ = std::max(iterations, 1);
    if (iterations > kJacobiTryBelow && kMultigridIterationCost * iterations <= jacobi_iterations_) return;
    if (wait_ > 0)
      --wait_;
    else
      multigrid_ = false;
  }

 private:
  std::size_t quanta_ = 0;        // the world the choice was made on
  bool multigrid_ = false;        // the next whole step's preconditioner
  int jacobi_iterations_ = 0;     // the last block-Jacobi step's
  int multigrid_iterations_ = 0;  // the last multigrid step's (0: none yet on this world)
  int wait_ = 0;                  // multigrid steps that would try block Jacobi before the next try
  int wait_most_ = 1;             // the last wait set: doubled by each return to multigrid
};

}  // namespace qbond
