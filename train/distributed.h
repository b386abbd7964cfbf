#pragma once
// Data-parallel gradient averaging over torch c10d (docs/dynamics.md, "Data parallel").
// Rendezvous is a c10d::TCPStore at MASTER_ADDR:MASTER_PORT (rank 0 serves it). The reduction
// backend is, in order of preference: NCCL for CUDA tensors (when LibTorch was built with it),
// Gloo for CPU tensors (when the gloo headers were found at build time: WM_HAVE_GLOO), else a
// store-based all-reduce (every rank publishes its flattened gradients in the store and sums all
// ranks' in rank order: slower, but exact and identical on every rank). Internal header.
#include <torch/torch.h>

#include <memory>
#include <string>
#include <vector>

namespace wm::train {

struct DistributedOptions {
  int rank = 0, world_size = 1;
  // Set when a launcher named the world (WORLD_SIZE in the environment): then a process group is
  // made even for world size 1, as torchrun does, so a one-GPU job exercises NCCL end to end.
  bool launched = false;
  std::string master_addr = "127.0.0.1";
  int master_port = 29500;
};

class GradientReducer {
 public:
  GradientReducer(const DistributedOptions& options, const torch::Device& device);
  ~GradientReducer();
  // tensors <- mean over ranks (in place). A no-op without a process group.
  void AllReduceMean(const std::vector<torch::Tensor>& tensors);
  std::string backend() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// A free TCP port on 127.0.0.1 (for --nproc).
int FindFreePort();

}  // namespace wm::train
