#pragma once
// `qbond bench`: runs the Google Benchmark program qbond_bench (bench/) and prints one table of
// the canonical workload's cost per step against this machine's memory-bandwidth bound,
// measured in the same run (docs/performance.md).
#include <string>

namespace qbond::cli {

struct BenchArgs {
  bool quick = false;          ///< n = 10, one short repetition: what CI runs so the suite cannot rot
  std::string sizes;           ///< lattice sizes n, e.g. "10,20,40" (default: 10,20,40; quick: 10)
  std::string threads = "1";   ///< thread counts, e.g. "1,2"
  std::string integrators;     ///< integrator rows (bench_integrators.hpp); empty: the default four
  double dt = 0;                ///< timestep [s] (0: the workload's 1e-4 s)
  bool solve = false;           ///< the solver comparison at h = 1/60 s instead (default n: 10,20,40)
  bool as_run = false;          ///< time steps as `qbond run` takes them: energy ledger and rollback copy on
  int repetitions = 3;         ///< the median of this many is reported
  std::string json;            ///< also write the table as JSON here (atomically)
};

/// Runs the suite and prints the table; returns the process exit code (throws
/// std::runtime_error when qbond_bench is missing or fails).
int bench(const BenchArgs& args);

}  // namespace qbond::cli
