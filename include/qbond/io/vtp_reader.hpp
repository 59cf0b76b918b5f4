#pragma once
/// Reading back what vtk.hpp writes: a run's .pvd time series and its VTK XML PolyData frames
/// (binary, appended raw, UInt64 headers), for replaying a finished run. Not a general VTK
/// reader: other encodings (ASCII, base64, compressed) are refused with a message.
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "qbond/core/math.hpp"

namespace qbond {

/// A file that is not a frame or series as vtk.hpp writes them: what() names the file and what
/// is wrong with it.
class VtkReadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One frame: the quanta (point k is the quanta of user id k) and the alive bonds.
struct VtpFrame {
  std::vector<Vec3> x;               ///< positions [m]
  std::vector<Vec3> v;               ///< velocities [m/s]; zero when the file has none
  std::vector<double> mass;          ///< [kg]; empty when the file has none
  std::vector<std::int32_t> body;    ///< body ids; zero when the file has none
  std::vector<std::uint8_t> kinematic;  ///< 1: anchored or prescribed; zero when the file has none
  std::vector<double> von_mises;     ///< [Pa]; empty when the file has none
  std::vector<std::pair<Index, Index>> lines;  ///< the bonds' end points (point indices)
  std::vector<double> strain, tension;         ///< per line (the vertex cells' entries dropped); empty when absent
};

/// Reads a frame. Throws VtkReadError.
VtpFrame read_vtp(const std::filesystem::path& path);

/// One entry of a .pvd collection: its time [s] and its file (resolved against the .pvd's directory).
struct PvdEntry {
  double time = 0;
  std::filesystem::path file;
};

/// Reads a .pvd collection, entries sorted by time (a stable sort: files of equal time keep
/// their order). Throws VtkReadError (also for a collection without a frame).
std::vector<PvdEntry> read_pvd(const std::filesystem::path& path);

}  // namespace qbond
