#pragma once
/// How much memory a run may take: the machine's, the default limit, and the estimate of what a
/// scene's world needs, checked before its bodies are built (docs/running.md, "Memory").
#include <cstdint>
#include <string>

namespace qbond {

/// The memory this process can have [bytes]: the physical memory, or the control group's limit
/// (cgroup v2 memory.max) when that is smaller.
std::uint64_t available_memory();

/// The default limit on a scene's estimated memory: 3/4 of available_memory(), leaving room for
/// the system and the page cache the outputs go through.
std::uint64_t default_memory_limit();

/// Peak resident memory of `qbond run` for a world of `quanta` quanta and `bonds` bonds, with
/// ParaView frames on [bytes]: a · quanta + b · bonds + c, the constants fitted to measured peaks
/// (docs/running.md) and rounded up, the most memory-hungry integrator (the default) included.
std::uint64_t estimated_run_memory(double quanta, double bonds);

/// "1.84 GB" (decimal units, three significant digits).
std::string format_bytes(double bytes);

/// Parses a size: a number of bytes, or with a suffix k, M, G, T (powers of 1000) or KiB, MiB,
/// GiB, TiB (powers of 1024), e.g. "8G", "512MiB". Throws std::invalid_argument when malformed.
std::uint64_t parse_bytes(const std::string& text);

}  // namespace qbond
