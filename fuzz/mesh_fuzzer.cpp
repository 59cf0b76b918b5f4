// libFuzzer target: the mesh readers, OBJ and STL (ASCII and binary), and the closedness check a
// mesh body runs (docs/running.md, "Fuzzing"). The first byte picks the format. Any input must be
// read or refused with a std::runtime_error naming it.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include "qbond/builders/mesh_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    const qbond::TriangleMesh mesh = data[0] % 2 ? qbond::parse_obj(bytes, "fuzz.obj") : qbond::parse_stl(bytes, "fuzz.stl");
    qbond::check_closed(mesh, "fuzz");
  } catch (const std::runtime_error&) {
  }
  return 0;
}
