#pragma once
/// ParaView output (docs/running.md): VTK XML PolyData frames and a .pvd time series.
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
