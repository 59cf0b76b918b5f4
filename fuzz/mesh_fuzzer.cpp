// libFuzzer target: the mesh readers, OBJ and STL (ASCII and binary) with the closedness check a
// mesh body runs, and the tetrahedral ones, Gmsh .msh and VTK .vtu, with the checks and the
// edges and volumes a tet_mesh body computes (docs/running.md, "Fuzzing"). The first byte picks
// the format (mod 4: 0 STL, 1 OBJ, 2 Gmsh, 3 VTU). Any input must be read or refused with a
// std::runtime_error naming it.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include "qbond/builders/mesh_reader.hpp"
#include "qbond/builders/tet_mesh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    switch (data[0] % 4) {
      case 0:
      case 1: {
        const qbond::TriangleMesh mesh =
            data[0] % 2 ? qbond::parse_obj(bytes, "fuzz.obj") : qbond::parse_stl(bytes, "fuzz.stl");
        qbond::check_closed(mesh, "fuzz");
        break;
      }
      default: {
        const qbond::TetMesh mesh = qbond::parse_tet_mesh(bytes, data[0] % 4 == 2 ? "fuzz.msh" : "fuzz.vtu");
        qbond::tet_edges(mesh);
        qbond::lumped_volumes(mesh);
      }
    }
  } catch (const std::runtime_error&) {
  }
  return 0;
}
