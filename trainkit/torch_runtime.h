#pragma once
// LibTorch process settings and version for the trainers and the manifests that record them
// (torch-free interface).
#include <cstdint>
#include <string>

namespace wm::trainkit {

// "1.13.0" etc.: the LibTorch this binary was built against.
std::string TorchVersion();

// Throws wm::Error when `device` ("cpu", "cuda", "cuda:N") names CUDA and none is available.
void CheckDevice(const std::string& device);

// Intra-op threads, deterministic algorithms and the global torch seed, before a trainer builds
// its model. CPU kernels used by wmkit are deterministic for a fixed thread count; on CUDA some
// (bincount, index_copy_) are not, so with `cuda` a non-deterministic one only warns.
void SetUpTorch(int threads, uint64_t seed, bool cuda);

}  // namespace wm::trainkit
