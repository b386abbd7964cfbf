#include "trainkit/torch_runtime.h"

#include <torch/torch.h>

#include "core/error.h"

namespace wm::trainkit {

std::string TorchVersion() { return TORCH_VERSION; }

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
