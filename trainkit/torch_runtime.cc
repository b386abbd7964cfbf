#include "trainkit/torch_runtime.h"

#include <dlfcn.h>
#include <link.h>
#include <torch/torch.h>

#include <climits>
#include <cstdlib>
#include <cstring>

#include "core/error.h"

namespace wm::trainkit {

std::string TorchVersion() { return TORCH_VERSION; }

namespace {

// dl_iterate_phdr's callback: stops at the first loaded object named libblas.so*, keeping its
// resolved path (Debian's libblas.so.3 is a chain of alternatives symlinks).
int FindBlas(dl_phdr_info* info, size_t /*size*/, void* found) {
  const char* name = info->dlpi_name;
  const char* base = std::strrchr(name, '/');
  if (std::strncmp(base ? base + 1 : name, "libblas.so", 10) != 0) return 0;
  char resolved[PATH_MAX];
  *static_cast<std::string*>(found) = realpath(name, resolved) ? resolved : name;
  return 1;
}

}  // namespace

std::string BlasLibrary() {
  using Config = const char* (*)();
  if (const auto config = reinterpret_cast<Config>(dlsym(RTLD_DEFAULT, "openblas_get_config")))
    return config();
  std::string found;
  dl_iterate_phdr(FindBlas, &found);
  return found.empty() ? "none loaded" : found;
}

nlohmann::json TorchLibraryVersions() {
  return {{"libtorch", TorchVersion()}, {"blas", BlasLibrary()}};
}

void CheckDevice(const std::string& device) {
  Check(!torch::Device(device).is_cuda() || torch::cuda::is_available(),
        "--device " + device + " requested but CUDA is not available");
}

void SetUpTorch(int threads, uint64_t seed, bool cuda) {
  torch::set_num_threads(threads);
  at::globalContext().setDeterministicAlgorithms(true, /*warn_only=*/cuda);
  torch::manual_seed(seed);
}

}  // namespace wm::trainkit
