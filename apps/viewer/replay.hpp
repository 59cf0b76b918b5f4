#pragma once
/// Replaying a finished run in the viewer: its series.pvd and .vtp frames (qbond/io/vtp_reader.hpp),
/// each turned into a world the viewer draws as it draws a live one.
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "qbond/io/scene.hpp"
#include "qbond/io/vtp_reader.hpp"

namespace qbond::view {

/// Whether `path` names a run to replay: a .pvd file, or a directory holding series.pvd.
bool is_replay(const std::filesystem::path& path);

/// A finished run's frames, read one at a time.
class Replay {
 public:
  /// Opens the series `path` names (a .pvd file, or a run directory holding series.pvd) and reads
  /// its first frame. Throws VtkReadError.
  explicit Replay(const std::filesystem::path& path);

  std::size_t size() const { return entries_.size(); }
  /// Frame k's time [s].
  double time(std::size_t k) const { return entries_[k].time; }
  /// The last frame at or before time t (the first when t is before it).
  std::size_t at_time(double t) const;
  /// Loads frame k (unless it is the one loaded). Throws VtkReadError.
  void load(std::size_t k);
  /// The frame loaded: its index, file contents, and the world drawn from it (point k the quanta
  /// of id k, bond b its b-th line, so that the frame's arrays index the world directly).
  std::size_t index() const { return index_; }
  const VtpFrame& frame() const { return frame_; }
  const World& world() const { return world_; }
  /// The .pvd file.
  const std::filesystem::path& series() const { return pvd_; }

 private:
  std::filesystem::path pvd_;
  std::vector<PvdEntry> entries_;
  std::size_t index_ = 0;
  VtpFrame frame_;
  World world_;
};

/// The scene a replay is drawn with: the scene in the run directory's run.json when it has one
/// that loads (its name, ground and obstacles, contact radius and `camera`), else a bare scene
/// named after the directory; its world is the first frame's. `note` receives why run.json's
/// scene was not used, when it exists and was not.
Scene replay_scene(const Replay& replay, std::string& note);

}  // namespace qbond::view
