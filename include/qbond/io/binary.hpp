#pragma once
/// The plain binary encoding of checkpoints (little-endian, no padding between fields): what
/// serialize_state and the carry-over types (carry.hpp) write and read.
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "qbond/io/checkpoint.hpp"

namespace qbond {

/// Appends plain values and vectors of them (length first) to `out`.
class Writer {
 public:
  /// Appends the bytes of a plain value.
  template <class T>
  void pod(const T& v) {
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  /// Appends a vector of plain values: its length (u64), then its elements' bytes.
  template <class T, class A>
  void vec(const std::vector<T, A>& v) {
    pod<std::uint64_t>(v.size());
    if (!v.empty()) out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  std::string out;  ///< what was written
};

/// Reads what a Writer wrote, front to back; throws CheckpointError when the bytes run out.
class Reader {
 public:
  explicit Reader(std::string_view b) : bytes(b) {}
  /// Reads a plain value.
  template <class T>
  T pod() {
    T v;
    need(sizeof v);
    std::memcpy(&v, bytes.data(), sizeof v);
    bytes.remove_prefix(sizeof v);
    return v;
  }
  /// Reads a vector that Writer::vec wrote.
  template <class T, class A = std::allocator<T>>
  std::vector<T, A> vec() {
    const auto n = pod<std::uint64_t>();
    if (n > bytes.size() / sizeof(T)) throw CheckpointError("state: a vector runs past the end");
    std::vector<T, A> v(n);
    if (n > 0) std::memcpy(static_cast<void*>(v.data()), bytes.data(), n * sizeof(T));  // T is plain data (doubles)
    bytes.remove_prefix(n * sizeof(T));
    return v;
  }
  /// Throws unless n more bytes remain.
  void need(std::size_t n) const {
    if (bytes.size() < n) throw CheckpointError("truncated: the file ends inside its header");
  }
  std::string_view bytes;  ///< what remains to be read
};

}  // namespace qbond
