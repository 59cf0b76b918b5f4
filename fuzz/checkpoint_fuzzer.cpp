// libFuzzer target: the checkpoint reader (docs/running.md, "Fuzzing"). The input's last 8 bytes
// are replaced by its checksum, so that mutations reach the state reader behind it rather than
// stopping at the checksum. Any input must be read or refused with a CheckpointError.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "qbond/io/checkpoint.hpp"
#include "qbond/io/checksum.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string bytes(reinterpret_cast<const char*>(data), size);
  if (bytes.size() >= 12 + 8) {
    std::uint32_t version = 0;
    std::memcpy(&version, bytes.data() + 8, 4);
    const std::string_view body = std::string_view(bytes).substr(0, bytes.size() - 8);
    const std::uint64_t sum = version >= 6 ? qbond::xxh64(body) : qbond::fnv1a_version5(body);
    std::memcpy(bytes.data() + bytes.size() - 8, &sum, 8);
  }
  try {
    qbond::parse_checkpoint(bytes, "fuzz.qbc");
  } catch (const qbond::CheckpointError&) {
  }
  return 0;
}
