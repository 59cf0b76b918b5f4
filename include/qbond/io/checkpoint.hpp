#pragma once
/// Checkpoints (docs/running.md): the exact State plus the caller's metadata, versioned and
/// checksummed, from which a run continues bit for bit.
///
/// File format (little-endian):
///   "QBONDCKP"             8 bytes, magic
///   u32 version            kCheckpointVersion
///   u32 reserved           0
///   u64 m, m bytes         metadata (JSON text: resolved scene and run settings)
///   u64 s, s bytes         the state, as serialize_state writes it
///   u64 checksum           FNV-1a 64 of every byte before it
#include <bit>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

#include "qbond/model/world.hpp"

namespace qbond {

static_assert(std::endian::native == std::endian::little, "checkpoints are written little-endian");

// 2: bond times and formed bonds; 3: obstacle impulses; 4: the state in the world's locality
// order (ordering.hpp), which a version-3 file of the same scene does not follow; 5: the
// integrator's carry-over as a kind tag and its own fields (save_carry), and formed bonds save
// their law's shape parameters (laws/law.hpp's LawShape) where they saved eps. Version 4 files
// are still read, their carry-over and formed bonds converted.
inline constexpr std::uint32_t kCheckpointVersion = 5;

/// A checkpoint that cannot be read: not one, another version, truncated or corrupted.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What a checkpoint holds.
struct Checkpoint {
  std::string metadata;  ///< the caller's JSON text
  State state;
};

/// Writes a checkpoint atomically.
void save_checkpoint(const std::filesystem::path& path, std::string_view metadata, const State& state);
/// Reads a checkpoint; throws CheckpointError naming the file and what is wrong.
Checkpoint load_checkpoint(const std::filesystem::path& path);

/// The exact bytes of a state (every field, vectors with their lengths).
std::string serialize_state(const State& s);
/// The inverse of serialize_state; throws CheckpointError on inconsistent bytes.
State deserialize_state(std::string_view bytes);

}  // namespace qbond
