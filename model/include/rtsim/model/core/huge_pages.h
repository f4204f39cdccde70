#pragma once
// Large arrays the simulator fills once and then visits at random or writes on
// the way: backed by 2 MiB pages where Linux can, so that their first touch costs
// one page fault per 2 MiB instead of one per 4 KiB, and their visits fewer TLB misses.
#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace rtsim {

// Reserves room for `count` elements and asks Linux to back it with huge pages (a
// hint, given before the first touch; it changes no value).
template <typename T>
void reserve_on_huge_pages(std::vector<T>& v, size_t count) {
  v.reserve(count);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr uintptr_t kHuge = uintptr_t(2) << 20;
  const uintptr_t begin = (reinterpret_cast<uintptr_t>(v.data()) + kHuge - 1) & ~(kHuge - 1);
  const uintptr_t end = (reinterpret_cast<uintptr_t>(v.data()) + count * sizeof(T)) & ~(kHuge - 1);
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#endif
}

}  // namespace rtsim
