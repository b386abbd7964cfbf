#include "core/malloc_tuning.h"

#include <malloc.h>

namespace wm {

void KeepLargeAllocationsInHeap() {
#ifdef M_MMAP_THRESHOLD
  constexpr int kOneGiB = 1 << 30;
  mallopt(M_MMAP_THRESHOLD, kOneGiB);
  mallopt(M_TRIM_THRESHOLD, kOneGiB);
#endif
}

}  // namespace wm
