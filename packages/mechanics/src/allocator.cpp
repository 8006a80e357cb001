#include "demnerf/mechanics/allocator.hpp"

#include <malloc.h>

namespace demnerf::mechanics {

void keepLargeAllocationsInHeap() {
  mallopt(M_MMAP_THRESHOLD, 512 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
}

}  // namespace demnerf::mechanics
