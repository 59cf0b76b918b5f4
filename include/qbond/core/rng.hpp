#pragma once
/// A small counter-free PRNG whose whole state is one 64-bit word, so checkpoints save it exactly.
#include <cstdint>

namespace qbond {

/// SplitMix64 (Steele, Lea, Flood 2014): passes BigCrush, trivially serialisable.
struct Rng {
  std::uint64_t state = 0x9E3779B97F4A7C15ull;  ///< the entire generator state

  /// Next 64 random bits.
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform double in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
};

}  // namespace qbond
