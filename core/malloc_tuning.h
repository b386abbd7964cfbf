#pragma once

namespace wm {

// LibTorch allocates and frees multi-megabyte tensors every step; glibc's default hands them
// back to the kernel each time (mmap/munmap + page faults), which cost up to 2.7x in encode
// throughput until the quantiser stopped building [N, K] temporaries (docs/tokenizer.md,
// "Benchmark"); training still allocates large tensors every step. Raising the mmap and trim
// thresholds keeps them in the heap. Call once at the start of main in tools that run torch models.
void KeepLargeAllocationsInHeap();

}  // namespace wm
