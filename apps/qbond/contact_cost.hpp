#pragma once
// `qbond bench --contact`: what contact costs a step. Each scene runs three ways in one process,
// in interleaved rounds: its contact inside the implicit step, the same obstacles and quanta
// contact by projection (the post-projection heuristic), and no contact at all (docs/heuristics.md).
#include <string>

namespace qbond::cli {

struct ContactCostArgs {
  std::string scenes = "block_rest,stack,trampoline,gap,mesh_drop";  ///< built-in scene names
  double dt = 0;         ///< timestep [s] for every scene (0: each scene's own)
  int rounds = 5;        ///< interleaved rounds; the medians over them are reported
  int steps = 30;        ///< steps timed per variant and round
  std::string json;      ///< also write the table as JSON here (atomically)
  std::string command;   ///< the command line, recorded in the JSON
};

/// Times every scene's step with implicit, projection and no contact; prints the table and
/// returns the exit code.
int bench_contact(const ContactCostArgs& args);

}  // namespace qbond::cli
