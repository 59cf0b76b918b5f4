#pragma once
/// Closed triangle meshes read from OBJ and STL files (docs/geometry.md), for voxelise.hpp.
#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "qbond/core/math.hpp"
#include "qbond/model/world.hpp"

namespace qbond {

/// An indexed triangle mesh [m].
struct TriangleMesh {
  std::vector<Vec3> vertices{};
  std::vector<std::array<Index, 3>> triangles{};  ///< vertex ids of each triangle
};

/// Reads a Wavefront OBJ file: `v x y z [w]` and `f` lines (`a`, `a/t`, `a//n`, `a/t/n`,
/// 1-based, negative = relative to the last vertex); polygons are fan-triangulated; every other
/// line is ignored. Throws std::runtime_error "FILE:LINE: rule" on a malformed file.
TriangleMesh read_obj(const std::filesystem::path& file);
/// Reads an STL file, binary (size 84 + 50 n) or ASCII (`solid` … `endsolid`); vertices with
/// identical coordinates are merged. Throws std::runtime_error "FILE[:LINE]: rule".
TriangleMesh read_stl(const std::filesystem::path& file);
/// read_obj or read_stl by the extension (.obj, .stl, any case).
TriangleMesh read_mesh(const std::filesystem::path& file);
/// read_obj on a file's contents (e.g. a mesh compiled in); `name` stands for the file in messages.
TriangleMesh parse_obj(std::string_view text, const std::string& name);
/// read_stl on a file's contents; `name` stands for the file in messages.
TriangleMesh parse_stl(std::string_view bytes, const std::string& name);
/// parse_obj or parse_stl by the extension of `name`.
TriangleMesh parse_mesh(std::string_view bytes, const std::string& name);

/// Throws std::runtime_error "NAME: ..." unless the mesh is closed: at least one triangle, no
/// triangle with a repeated vertex, and every edge shared by exactly two triangles.
void check_closed(const TriangleMesh& mesh, const std::string& name);

}  // namespace qbond
