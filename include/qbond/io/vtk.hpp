#pragma once
/// ParaView output (docs/running.md): VTK XML PolyData frames and a .pvd time series.
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "qbond/model/world.hpp"

namespace qbond {

/// An extra per-quanta array for a frame (e.g. von Mises stress): `components` values per quanta.
struct PointArray {
  std::string name;
  int components = 1;
  std::span<const double> values;
};

/// Writes one frame atomically as VTK XML PolyData (binary, appended raw): points are the quanta,
/// point k the quanta of user id k (Model::quanta_id; `extra` holds values in the world's order)
/// (arrays velocity, mass, id, body, kinematic, von_mises, stress — the virial stress tensor of
/// stress.hpp, 0 where the volume is unknown — and `extra`), drawn as vertex cells; lines are the
/// alive bonds in bond-id order. Cell arrays strain, tension and bond (the bond id) cover the
/// vertex cells first (0, 0, -1), then the lines, as VTK orders cells.
void write_vtp(const std::filesystem::path& path, const Model& model, const State& state,
               std::span<const PointArray> extra = {});

/// Writes one piece of a frame split over MPI ranks (a VTK XML PolyData file a .pvtp lists): the
/// quanta with `owned` set, as vertex cells, and the alive bonds with `shown` set, as lines; the
/// other ends of those bonds are points too, with vtkGhostType 1 (a duplicate point, which
/// ParaView shows once) and no vertex cell. The arrays are write_vtp's, computed over the whole
/// of `model` and `state` (a rank's piece, which holds every bond of the quanta it owns), and the
/// point array vtkGhostType (UInt8: 0 for owned quanta, 1 for the other ends). Points come in
/// ascending user id, lines in bond-id order.
void write_vtp_piece(const std::filesystem::path& path, const Model& model, const State& state,
                     std::span<const std::uint8_t> owned, std::span<const std::uint8_t> shown);

/// Writes a ParaView parallel PolyData file (.pvtp) whose pieces are `pieces` (file names relative
/// to its directory, each written by write_vtp_piece), declaring their arrays.
void write_pvtp(const std::filesystem::path& path, std::span<const std::string> pieces);

/// A ParaView collection (.pvd) of frames over time.
class PvdSeries {
 public:
  /// Adds a frame; `file` is relative to the .pvd's directory.
  void add(double time, std::string file);
  /// Writes the collection atomically.
  void write(const std::filesystem::path& pvd) const;
  std::size_t size() const { return frames_.size(); }

 private:
  std::vector<std::pair<double, std::string>> frames_;
};

}  // namespace qbond
