// motion_test_tool: fixtures for the Python checks of the motion model.
//   reference --out FILE [--seed S] [--no-jacobian] [--action-dim D] [--layers | --pose]
//       a tensor archive with random weights ("model/...", the heads too, so flows are several
//       pixels), inputs ("input/...") and the C++ outputs ("output/...") of one forward and of a
//       3-step Imagine, for the PyTorch twin (warp_twin.py); --layers: the layered kind (its
//       masks, fill and the 3-step Imagine); --pose: the pose kind (pose_twin.py: its pose, drawn
//       colour and alpha, background and the 3-step Imagine)
//   make-data --out DIR [--episodes N] [--steps T] [--seed S]
//       a moving-square shard dataset (moving_square.h)
#include <CLI/CLI.hpp>
#include <cmath>
#include <iostream>

#include "core/error.h"
#include "core/tensor_archive.h"
#include "motion/motion_net.h"
#include "tests/motion/moving_square.h"
#include "trainkit/module_archive.h"

namespace {
using namespace wm::motion;

// Random weights with non-zero heads: flows of a few pixels and a visible gate (warp); masks
// that differ per layer and layers that move by pixels per step (layers).
void RandomizeHeads(MotionNet& net) {
  torch::NoGradGuard no_grad;
  auto params = net.module().named_parameters();
  if (net.posed()) {  // a drawn arm and a mask that vary, a dynamics MLP that bends the path
    for (auto& item : params) {  // PyTorch's default init shrinks the pose and what is drawn
      const std::string& name = item.key();
      if ((name.rfind("encoder.", 0) == 0 || name.rfind("renderer.", 0) == 0) &&
          item.value().dim() > 1)
        item.value().normal_(0, 2 / std::sqrt(item.value()[0].numel()));
    }
    params["eraser.sprite_head.weight"].normal_(0, 0.3);
    params["eraser.sprite_head.bias"].normal_(0, 1.0);
    params["dynamics.correction.4.weight"].normal_(0, 0.3);
    params["dynamics.correction.4.bias"].normal_(0, 0.3);
  } else if (net.layered()) {
    params["sprite_head.weight"].normal_(0, 0.3);
    params["sprite_head.bias"].normal_(0, 1.0);
    params["motion_head.weight"].normal_(0, 0.05);
    params["motion_head.bias"].normal_(0, 0.3);
  } else {
    params["head.weight"].normal_(0, 0.05);
    params["head.bias"].normal_(0, 0.3);
  }
}

void WriteReference(const std::string& path, uint64_t seed, bool jacobian, int action_dim,
                    const std::string& kind) {
  MotionConfig c = test::TestConfig();
  c.model.channels = 8;
  c.model.action_jacobian = jacobian;
  c.model.kind = kind;
  c.model.pose_dim = 6;
  c.model.renderer_width = 16;
  c.model.dynamics_hidden = 48;  // not the default: the twin must read it from the config
  torch::manual_seed(seed);
  MotionNet net(c.model, action_dim);
  RandomizeHeads(net);
  const int64_t B = 2, S = c.model.image_size, H = 3;
  const torch::Tensor current = torch::rand({B, 3, S, S}) * 2 - 1;
  const torch::Tensor previous = torch::rand({B, 3, S, S}) * 2 - 1;
  const torch::Tensor action = torch::randn({B, action_dim});
  const torch::Tensor actions = torch::randn({B, H, action_dim});
  std::vector<std::pair<std::string, torch::Tensor>> tensors = {
      {"input/current", current},
      {"input/previous", previous},
      {"input/action", action},
      {"input/actions", actions},
      {"output/imagined", Imagine(net, current, actions)}};
  torch::NoGradGuard no_grad;
  if (net.posed()) {
    PoseNet& pose = net.pose();
    const torch::Tensor p = pose->encoder()->forward(current);
    const Drawn drawn = pose->renderer()->forward(p);
    tensors.insert(tensors.end(), {{"output/pose", p},
                                   {"output/rgb", drawn.rgb},
                                   {"output/alpha", drawn.alpha},
                                   {"output/background", pose->Background(current)}});
  } else if (net.layered()) {
    const Sprites sprites = net.layers()->sprites(current);
    tensors.insert(tensors.end(), {{"output/masks", sprites.masks}, {"output/fill", sprites.fill}});
  } else {
    const WarpStep out = net.warp()->forward(current, previous, action);
    tensors.insert(
        tensors.end(),
        {{"output/next", out.next}, {"output/flow", out.flow}, {"output/gate", out.gate}});
  }
  wm::TensorArchiveWriter w;
  wm::trainkit::AddModule(w, "model/", net.module());
  for (const auto& [name, t] : tensors) wm::trainkit::AddTensor(w, name, t);
  w.SetMeta({{"config", ConfigToJson(c)}, {"action_dim", action_dim}});
  w.Write(path);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"motion_test_tool: fixtures for the motion model's Python checks"};
  app.require_subcommand(1);
  std::string out;
  uint64_t seed = 3;
  bool no_jacobian = false, layers = false, pose = false;
  int action_dim = 7, episodes = 24, steps = 12;
  CLI::App* ref = app.add_subcommand("reference", "Weights, inputs and C++ outputs");
  ref->add_option("--out", out)->required();
  ref->add_option("--seed", seed);
  ref->add_flag("--no-jacobian", no_jacobian);
  ref->add_option("--action-dim", action_dim);
  ref->add_flag("--layers", layers);
  ref->add_flag("--pose", pose)->excludes("--layers");
  CLI::App* data = app.add_subcommand("make-data", "A moving-square shard dataset");
  data->add_option("--out", out)->required();
  data->add_option("--episodes", episodes);
  data->add_option("--steps", steps);
  data->add_option("--seed", seed);
  CLI11_PARSE(app, argc, argv);
  try {
    if (ref->parsed())
      WriteReference(out, seed, !no_jacobian, action_dim,
                     pose     ? "pose"
                     : layers ? "layers"
                              : "warp");
    if (data->parsed()) test::WriteMovingSquares(out, episodes, steps, seed);
  } catch (const std::exception& e) {
    std::cerr << "motion_test_tool: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
