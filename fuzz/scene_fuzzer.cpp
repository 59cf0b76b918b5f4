// libFuzzer target: the scene reader (docs/running.md, "Fuzzing"). Any input must either build a
// scene or be refused with a SceneError; anything else (a crash, a sanitizer report, another
// exception, a leak) is a bug.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "qbond/io/scene.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    // A small memory limit (about 25 000 quanta): a scene may ask for a large world, the fuzzer
    // must not spend seconds building one.
    qbond::parse_scene(text, "fuzz.json", {.max_memory = 64u << 20});
  } catch (const qbond::SceneError&) {
  }
  return 0;
}
