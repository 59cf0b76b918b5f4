#pragma once
/// Quanta and bonds read from CSV tables (docs/scene-format.md, `csv` bodies).
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "qbond/core/math.hpp"

namespace qbond {

/// Quanta as a CSV table lists them: one row each, in file order.
struct CsvQuanta {
  std::vector<Vec3> x{};       ///< [m]
  std::vector<double> mass{};  ///< [kg]; empty when the table has no mass column
  std::vector<Vec3> v{};       ///< [m/s]; empty when the table has no velocity columns
};

/// Bonds as a CSV table lists them: the two ends (0-based rows of the quanta table) and, when the
/// table has the column, each bond's material name.
struct CsvBonds {
  std::vector<std::pair<Index, Index>> ends{};
  std::vector<std::string> material{};  ///< empty when the table has no material column
};

/// Reads a quanta table: comma-separated rows x,y,z[,mass][,vx,vy,vz] (3, 4, 6 or 7 columns), or,
/// when the first row is a header (its first field is not a number), columns named x, y, z and
/// optionally mass and vx, vy, vz in any order. Blank lines and lines starting with '#' are
/// skipped; every row has the header's (or the first row's) field count. Throws
/// std::runtime_error "NAME:LINE: rule".
CsvQuanta parse_quanta_csv(std::string_view text, const std::string& name);
/// Reads a bond table: rows i,j[,material] (i, j 0-based rows of a quanta table of `quanta`
/// rows, distinct), or a header naming columns i, j and optionally material. A pair listed twice
/// is an error. Throws std::runtime_error "NAME:LINE: rule".
CsvBonds parse_bonds_csv(std::string_view text, const std::string& name, std::size_t quanta);

}  // namespace qbond
