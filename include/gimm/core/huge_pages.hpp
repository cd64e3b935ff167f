#pragma once
/// Big buffers (volumes, whole files, their inflated bytes) on transparent huge pages.
///
/// A fresh buffer costs a page fault per 4 KB page at its first touch. On a virtual machine a
/// fault costs microseconds, so a CT-size volume (256 MB as float: 65536 pages) took about a
/// second to touch before any work was done on it. Linux backs a region with 2 MB pages where
/// the program asks for it (madvise(MADV_HUGEPAGE); transparent_hugepage "madvise", as on the
/// machines this was measured on) or everywhere ("always"): 512 times fewer faults. The advice is
/// given before the first touch, on the 2 MB-aligned part of the buffer; it is only advice, so a
/// kernel without huge pages, or another system, leaves the buffer as it was.
#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace gimm {

/// Buffers smaller than this are left alone (a few huge pages would not pay for the call).
inline constexpr std::size_t kHugePageAdviceMinBytes = std::size_t{8} << 20;

/// Asks for huge pages over the 2 MB-aligned part of [data, data + bytes). Call it before the
/// buffer is first written. Returns whether the advice was given (and taken by the kernel).
inline bool advise_huge_pages(const void* data, std::size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  if (data == nullptr || bytes < kHugePageAdviceMinBytes) return false;
  const auto first = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t begin = (first + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t end = (first + bytes) & ~(kHuge - 1);
  return end > begin && madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE) == 0;
#else
  (void)data;
  (void)bytes;
  return false;
#endif
}

/// v.reserve(n), with the new storage advised onto huge pages before anything touches it.
template <class T>
void reserve_huge(std::vector<T>& v, std::size_t n) {
  if (n <= v.capacity()) return;
  std::vector<T> bigger;
  bigger.reserve(n);
  advise_huge_pages(bigger.data(), n * sizeof(T));
  bigger.insert(bigger.end(), v.begin(), v.end());
  v.swap(bigger);
}

/// v.resize(n) into storage advised onto huge pages when it has to grow.
template <class T>
void resize_huge(std::vector<T>& v, std::size_t n) {
  reserve_huge(v, n);
  v.resize(n);
}

}  // namespace gimm
