#pragma once
// `qbond bench --realtime`: the wall time of a 1/60 s frame, as the viewer steps it, for the
// canonical workload and every built-in scene, and whether it keeps up with 60 Hz
// (docs/performance.md).
#include <string>
#include <vector>

namespace qbond::cli {

struct RealtimeArgs {
  std::string sizes = "10,20,40";  ///< canonical lattice sizes n
  std::string threads = "1,2";     ///< thread counts
  std::string scenes;              ///< built-in scene names, comma-separated (empty: every one)
  std::string preconditioner;      ///< the canonical lattice's CG preconditioner (empty: the default)
  double budget = 8;               ///< wall seconds measured per workload and thread count at most
  int frames = 30;                 ///< frames measured at most (after the warm-up)
  std::string json;                ///< also write the table as JSON here (atomically)
  std::string command;             ///< the command line, recorded in the JSON
};

/// Runs every workload on every thread count and prints the table; returns the exit code.
int bench_realtime(const RealtimeArgs& args);

/// The non-empty items of a comma-separated list.
std::vector<std::string> split(const std::string& s);

/// The median of `v` (NaN when empty).
double median(std::vector<double> v);

}  // namespace qbond::cli
