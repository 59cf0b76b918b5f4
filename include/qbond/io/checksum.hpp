#pragma once
/// Checksums of checkpoint files: XXH64 (the xxHash specification, 64-bit, seed 0) for the
/// current format, and the FNV-1a variant earlier formats were written with.
#include <cstdint>
#include <string_view>

namespace qbond {

/// XXH64 of `bytes` with `seed`: 32-byte stripes of four multiply-rotate lanes, merged and
/// avalanched as the xxHash specification says (xxh64("") = 0xEF46DB3751D8E999). Detects every
/// random damage a 64-bit checksum can, at memory speed.
std::uint64_t xxh64(std::string_view bytes, std::uint64_t seed = 0);

/// FNV-1a 64 as checkpoint versions 4 and 5 computed it: h = (h ⊕ byte) · 1099511628211 from the
/// offset basis 1469598103934665603, which is not the standard FNV basis (14695981039346656037);
/// kept only to read those files.
std::uint64_t fnv1a_version5(std::string_view bytes);

}  // namespace qbond
