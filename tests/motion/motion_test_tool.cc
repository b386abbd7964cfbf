// motion_test_tool: fixtures for the Python checks of the motion model.
//   reference --out FILE [--seed S] [--no-jacobian] [--action-dim D]
//       a tensor archive with random weights ("model/...", the head too, so flows are several
//       pixels), inputs ("input/...") and the C++ outputs ("output/...") of one forward and of a
//       3-step Imagine, for the PyTorch twin (warp_twin.py)
//   make-data --out DIR [--episodes N] [--steps T] [--seed S]
//       a moving-square shard dataset (moving_square.h)
#include <CLI/CLI.hpp>
#include <iostream>

#include "core/error.h"
#include "core/tensor_archive.h"
#include "motion/warp_net.h"
#include "tests/motion/moving_square.h"
#include "trainkit/module_archive.h"

namespace {
using namespace wm::motion;

void WriteReference(const std::string& path, uint64_t seed, bool jacobian, int action_dim) {
  MotionConfig c = test::TestConfig();
  c.model.channels = 8;
  c.model.action_jacobian = jacobian;
  torch::manual_seed(seed);
  WarpNet net(c.model, action_dim);
  {
    torch::NoGradGuard no_grad;  // a non-zero head: flows of a few pixels, a visible gate
    net->named_parameters()["head.weight"].normal_(0, 0.05);
    net->named_parameters()["head.bias"].normal_(0, 0.3);
  }
  const int64_t B = 2, S = c.model.image_size, H = 3;
  const torch::Tensor current = torch::rand({B, 3, S, S}) * 2 - 1;
  const torch::Tensor previous = torch::rand({B, 3, S, S}) * 2 - 1;
  const torch::Tensor action = torch::randn({B, action_dim});
  const torch::Tensor actions = torch::randn({B, H, action_dim});
  const WarpStep out = net->forward(current, previous, action);
  const torch::Tensor imagined = Imagine(net, current, actions);
  wm::TensorArchiveWriter w;
  wm::trainkit::AddModule(w, "model/", *net);
  for (const auto& [name, t] : {std::pair{"input/current", current},
                                {"input/previous", previous},
                                {"input/action", action},
                                {"input/actions", actions},
                                {"output/next", out.next.detach()},
                                {"output/flow", out.flow.detach()},
                                {"output/gate", out.gate.detach()},
                                {"output/imagined", imagined}}) {
    wm::trainkit::AddTensor(w, name, t);
  }
  w.SetMeta({{"config", ConfigToJson(c)}, {"action_dim", action_dim}});
  w.Write(path);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"motion_test_tool: fixtures for the motion model's Python checks"};
  app.require_subcommand(1);
  std::string out;
  uint64_t seed = 3;
  bool no_jacobian = false;
  int action_dim = 7, episodes = 24, steps = 12;
  CLI::App* ref = app.add_subcommand("reference", "Weights, inputs and C++ outputs");
  ref->add_option("--out", out)->required();
  ref->add_option("--seed", seed);
  ref->add_flag("--no-jacobian", no_jacobian);
  ref->add_option("--action-dim", action_dim);
  CLI::App* data = app.add_subcommand("make-data", "A moving-square shard dataset");
  data->add_option("--out", out)->required();
  data->add_option("--episodes", episodes);
  data->add_option("--steps", steps);
  data->add_option("--seed", seed);
  CLI11_PARSE(app, argc, argv);
  try {
    if (ref->parsed()) WriteReference(out, seed, !no_jacobian, action_dim);
    if (data->parsed()) test::WriteMovingSquares(out, episodes, steps, seed);
  } catch (const std::exception& e) {
    std::cerr << "motion_test_tool: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
