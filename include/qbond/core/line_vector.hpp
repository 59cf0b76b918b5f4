#pragma once
/// Vectors whose storage starts on a 64-byte cache line: the bond kernels' per-quanta arrays
/// (structure of arrays) and the integrators' carry-over (State::carry), which the kernels load
/// and store eight doubles at a time. A std::vector's large block starts 16 bytes past a line
/// (glibc's mmap'd chunks), and then every such access spans two lines, which slows the frozen
/// step by about a sixth. The layout inside the storage, and so every
/// bit the kernels compute and a checkpoint saves, does not depend on where it lies.
#include <cstddef>
#include <new>
#include <vector>

namespace qbond {

/// std::allocator with storage on a cache line (aligned operator new).
template <class T>
struct LineAllocator {
  using value_type = T;
  static constexpr std::align_val_t kLine{64};
  LineAllocator() = default;
  template <class U>
  LineAllocator(const LineAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), kLine)); }
  void deallocate(T* p, std::size_t) noexcept { ::operator delete(p, kLine); }
  template <class U>
  bool operator==(const LineAllocator<U>&) const noexcept {
    return true;
  }
};

/// A std::vector whose data() is on a cache line.
template <class T>
using LineVector = std::vector<T, LineAllocator<T>>;

}  // namespace qbond
