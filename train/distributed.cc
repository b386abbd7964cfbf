#include "train/distributed.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstring>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>

#ifdef WM_HAVE_GLOO
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#endif
#ifdef WM_HAVE_NCCL
#include <torch/csrc/distributed/c10d/ProcessGroupNCCL.hpp>
#endif

#include "core/error.h"

namespace wm::train {

struct GradientReducer::State {
  DistributedOptions options;
  c10::intrusive_ptr<c10d::Store> store;
#ifdef WM_HAVE_GLOO
  c10::intrusive_ptr<c10d::ProcessGroupGloo> gloo;
#endif
#ifdef WM_HAVE_NCCL
  c10::intrusive_ptr<c10d::ProcessGroupNCCL> nccl;
#endif
  int64_t round = 0;
  std::string backend = "none";

  std::string Key(int64_t r, int rank) const {
    return "wm/grad/" + std::to_string(r) + "/" + std::to_string(rank);
  }

  // Every rank publishes its bytes, then sums all ranks' in rank order; identical results
  // everywhere. A rank deletes its previous round's key once every rank has published this
  // round (so every rank has finished reading the previous one).
  void StoreAllReduce(torch::Tensor& flat) {
    const int64_t r = round++;
    const auto* p = static_cast<const uint8_t*>(flat.data_ptr());
    store->set(Key(r, options.rank), std::vector<uint8_t>(p, p + flat.nbytes()));
    torch::Tensor sum = torch::zeros_like(flat);
    for (int k = 0; k < options.world_size; ++k) {
      std::vector<uint8_t> bytes = store->get(Key(r, k));
      Check(bytes.size() == flat.nbytes(), "rank " + std::to_string(k) + " sent " +
                                               std::to_string(bytes.size()) + " gradient bytes");
      sum += torch::from_blob(bytes.data(), flat.sizes(), flat.options());
    }
    if (r > 0) store->deleteKey(Key(r - 1, options.rank));
    flat.copy_(sum);
  }
};

GradientReducer::GradientReducer(const DistributedOptions& o, const torch::Device& device)
    : state_(std::make_unique<State>()) {
  state_->options = o;
  if (o.world_size <= 1 && !o.launched) return;
  c10d::TCPStoreOptions so;
  so.port = static_cast<uint16_t>(o.master_port);
  so.isServer = o.rank == 0;
  so.numWorkers = static_cast<size_t>(o.world_size);
  so.waitWorkers = true;
  so.timeout = std::chrono::minutes(10);
  state_->store = c10::make_intrusive<c10d::TCPStore>(o.master_addr, so);
  if (device.is_cuda()) {
#ifdef WM_HAVE_NCCL
    state_->nccl = c10::make_intrusive<c10d::ProcessGroupNCCL>(
        state_->store, o.rank, o.world_size, c10d::ProcessGroupNCCL::Options::create());
    state_->backend = "nccl";
    return;
#endif
  }
#ifdef WM_HAVE_GLOO
  if (!device.is_cuda()) {
    auto go = c10d::ProcessGroupGloo::Options::create();
    go->devices.push_back(c10d::ProcessGroupGloo::createDefaultDevice());
    state_->gloo =
        c10::make_intrusive<c10d::ProcessGroupGloo>(state_->store, o.rank, o.world_size, go);
    state_->backend = "gloo";
    return;
  }
#endif
  state_->backend = "store";
}

GradientReducer::~GradientReducer() = default;

std::string GradientReducer::backend() const { return state_->backend; }

void GradientReducer::AllReduceMean(const std::vector<torch::Tensor>& tensors) {
  const int W = state_->options.world_size;
  if (state_->backend == "none" || tensors.empty()) return;
  torch::NoGradGuard no_grad;
  // One flat buffer: one collective per step instead of one per parameter.
  std::vector<torch::Tensor> flats;
  for (const auto& t : tensors) flats.push_back(t.reshape({-1}).to(torch::kFloat));
  std::vector<torch::Tensor> flat{torch::cat(flats)};
  if (state_->backend == "store") {
    flat[0] = flat[0].to(torch::kCPU).contiguous();
    state_->StoreAllReduce(flat[0]);
  }
#ifdef WM_HAVE_NCCL
  if (state_->nccl) state_->nccl->allreduce(flat)->wait();
#endif
#ifdef WM_HAVE_GLOO
  if (state_->gloo) state_->gloo->allreduce(flat)->wait();
#endif
  flat[0].div_(W);
  int64_t offset = 0;
  for (const auto& t : tensors) {
    const int64_t n = t.numel();
    t.copy_(flat[0].slice(0, offset, offset + n).view_as(t));
    offset += n;
  }
}

int FindFreePort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  Check(fd >= 0, "cannot open a socket to find a free port");
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof(addr);
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0 &&
                  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0;
  ::close(fd);
  Check(ok, std::string("cannot find a free port: ") + std::strerror(errno));
  return ntohs(addr.sin_port);
}

}  // namespace wm::train
