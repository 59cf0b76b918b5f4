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
///   u64 checksum           XXH64 (seed 0) of every byte before it (checksum.hpp); versions 4
///                          and 5 carry FNV-1a with their own basis (fnv1a_version5)
#include <bit>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "qbond/model/world.hpp"

namespace qbond {

static_assert(std::endian::native == std::endian::little, "checkpoints are written little-endian");

// 2: bond times and formed bonds; 3: obstacle impulses; 4: the state in the world's locality
// order (ordering.hpp), which a version-3 file of the same scene does not follow; 5: the
// integrator's carry-over as a kind tag and its own fields (save_carry), and formed bonds save
// their law's shape parameters (laws/law.hpp's LawShape) where they saved eps; 6: every bond
// whole (State::bonds: ends, law, parameters, shape row, rest lengths, alive, time), where 5 saved
// the formed bonds' entries only; the checksum is XXH64 (5's FNV-1a started from a non-standard
// basis); the metadata holds the adaptive controller's next step. Version 4 and 5 files are still
// read, their carry-over and formed bonds converted (adopt_scene_bonds).
inline constexpr std::uint32_t kCheckpointVersion = 6;

/// A checkpoint that cannot be read: not one, another version, truncated or corrupted.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A bond formed during the run as files before version 6 saved it (its shape by value).
struct SavedFormedBond {
  Index i = 0, j = 0;
  Law law = Law::linear;
  DampingModel damping_model = DampingModel::axial;
  double strength = 0, damping = 0, rest0 = 0;
  LawShape shape{};
};

/// What a checkpoint holds.
struct Checkpoint {
  std::uint32_t version = kCheckpointVersion;  ///< the format the file was written in
  std::string metadata;                         ///< the caller's JSON text
  State state;
  /// Files before version 6 saved every bond's rest length, alive flag and time but the ends and
  /// laws of the bonds formed during the run only (these): state.bonds then holds just those
  /// three arrays, and adopt_scene_bonds completes it from the scene. Empty for newer files.
  std::optional<std::vector<SavedFormedBond>> formed_before_v6;
};

/// Writes a checkpoint atomically.
void save_checkpoint(const std::filesystem::path& path, std::string_view metadata, const State& state);
/// Reads a checkpoint of at most `max_bytes`; throws CheckpointError naming the file and what is
/// wrong. Its layout is checked against the file's size before more than its header is read, and
/// anything but a regular file (a directory, a FIFO, a device) is refused unread.
Checkpoint load_checkpoint(const std::filesystem::path& path, std::uint64_t max_bytes = ~std::uint64_t{0});

/// Reads a checkpoint from its bytes (as load_checkpoint, `name` naming it in errors).
Checkpoint parse_checkpoint(std::string_view bytes, const std::string& name);

/// Makes a checkpoint's state fit the world its scene builds (`scene`, not yet run): a file
/// before version 6 gets its bonds' ends and laws, the scene's bonds then its formed ones (their
/// shapes interned in the scene's model, as the scene's formation rules did); any file has its
/// counts and shape rows checked against the scene. Throws CheckpointError when they disagree.
void adopt_scene_bonds(Checkpoint& checkpoint, World& scene);

/// The exact bytes of a state (every field, vectors with their lengths).
std::string serialize_state(const State& s);
/// The inverse of serialize_state; throws CheckpointError on inconsistent bytes.
State deserialize_state(std::string_view bytes);

}  // namespace qbond
