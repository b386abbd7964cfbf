#pragma once
// LibTorch process settings and version for the trainers and the manifests that record them
// (torch-free interface).
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

namespace wm::trainkit {

// "1.13.0" etc.: the LibTorch this binary was built against.
std::string TorchVersion();

// The BLAS LibTorch's CPU matmuls run on, which decides their last bits: OpenBLAS's own
// description when it is loaded ("OpenBLAS 0.3.21 NO_LAPACKE DYNAMIC_ARCH NO_AFFINITY USE_OPENMP
// Zen MAX_THREADS=64": version, build, the kernels it picked for this CPU), otherwise the file
// the process loaded as libblas.so.3 (Debian's update-alternatives picks it: ATLAS, reference
// BLAS), otherwise "none loaded" (a LibTorch with its own, such as pip's MKL).
std::string BlasLibrary();

// {"libtorch": TorchVersion(), "blas": BlasLibrary()}: what manifests record next to
// wm::CoreLibraryVersions() for outputs that LibTorch computed.
nlohmann::json TorchLibraryVersions();

// Throws wm::Error when `device` ("cpu", "cuda", "cuda:N") names CUDA and none is available.
void CheckDevice(const std::string& device);

// Intra-op threads, deterministic algorithms and the global torch seed, before a trainer builds
// its model. CPU kernels used by wmkit are deterministic for a fixed thread count; on CUDA some
// (bincount, index_copy_) are not, so with `cuda` a non-deterministic one only warns.
void SetUpTorch(int threads, uint64_t seed, bool cuda);

}  // namespace wm::trainkit
