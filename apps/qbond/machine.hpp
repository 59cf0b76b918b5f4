#pragma once
// What the benchmarks say about the machine they ran on: its name and cores, and how fast each
// core runs at the moment (a shared or virtual machine's cores need not run alike).
#include <string>
#include <vector>

namespace qbond::cli {

/// "HOST, N cores".
std::string machine();

/// The speed of each core this process may run on, relative to the fastest (1), from the best of
/// a few runs of a fixed arithmetic loop on that core alone; CPU numbers in `cpus`. Empty where
/// the process cannot pin itself (then the calling thread's cores are left as they were).
struct CoreSpeeds {
  std::vector<int> cpus;
  std::vector<double> speed;
  int fastest() const;     ///< the CPU of the fastest core (-1 when none was measured)
  double slowest() const;  ///< the slowest core's speed (1 when none was measured)
};
CoreSpeeds core_speeds();

/// Pins the calling thread to one CPU while it lives (nothing when cpu < 0 or pinning fails),
/// then gives it back the cores it had.
class PinToCore {
 public:
  explicit PinToCore(int cpu);
  ~PinToCore();
  PinToCore(const PinToCore&) = delete;
  PinToCore& operator=(const PinToCore&) = delete;

 private:
  bool pinned_ = false;
  std::vector<unsigned char> saved_;  // the thread's cpu_set_t before
};

}  // namespace qbond::cli
