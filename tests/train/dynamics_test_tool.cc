// dynamics_test_tool: fixtures for the Python checks of the dynamics model.
//   make-tokens --out DIR ...        a moving-block token dataset (tests/train/moving_block.h)
//   reference --out FILE [--rmsnorm] [--no-policy] [--tied] [--copy-prior] [--next-frame] [--rope]
//             [--action-dim D] [--padded K] [--levels L] [--adaptive-norm none|identity|zero]
//                                    (--padded: row 1 is a K-dim dataset's, padded to D and
//                                    masked, its padding filled with noise that must not matter)
//                                    a tensor archive with random weights ("model/..."), inputs
//                                    ("input/...") and the C++ outputs ("output/...") of one
//                                    forward + losses, for the PyTorch twin (dynamics_twin.py)
//   eval-next-frame --run DIR --tokens DIR [--frames K] [--max-windows N]
//                                    next-frame token accuracy of MaskGIT decoding (argmax) through
//                                    the public API vs copying the last context frame
#include <CLI/CLI.hpp>
#include <iostream>

#include "core/error.h"
#include "core/tensor_archive.h"
#include "core/tokens/token_dataset.h"
#include "tests/train/moving_block.h"
#include "tests/train/test_config.h"
#include "train/dynamics_model.h"
#include "train/world_model.h"
#include "trainkit/module_archive.h"

namespace {
using namespace wm::train;

struct ReferenceFlags {
  bool rmsnorm = false, no_policy = false, tied = false, copy_prior = false, next_frame = false,
       rope = false;
  int action_dim = 7, padded = 0, levels = 1;
  std::string adaptive_norm = "none";
};

void WriteReference(const std::string& path, const ReferenceFlags& f, uint64_t seed) {
  const bool policy = !f.no_policy;
  DynamicsConfig c = test::TinyConfig(policy);
  c.model.norm = f.rmsnorm ? "rmsnorm" : "layernorm";
  c.model.tied_token_head = f.tied;
  c.model.copy_prior = f.copy_prior;
  c.model.objective = f.next_frame ? "next_frame" : "masked";
  c.model.temporal_positions = f.rope ? "rope" : "learned";
  c.model.action_dim = f.action_dim;
  c.model.levels = f.levels;
  c.model.adaptive_norm = f.adaptive_norm;
  c.train.reward_weight = 0.7;
  c.train.terminal_weight = 0.3;
  c.train.policy_weight = 0.9;
  torch::manual_seed(seed);
  WorldModel m(c);
  {
    torch::NoGradGuard no_grad;  // non-trivial norm weights and biases, so the twin checks them
    for (auto& p : m->named_parameters()) {
      if (p.key().find("norm") != std::string::npos || p.key().ends_with("token_bias") ||
          p.key().find("copy_gate") != std::string::npos ||
          p.key().find("modulation") != std::string::npos)
        p.value().add_(torch::randn_like(p.value()) * 0.1);
    }
  }
  const int64_t B = 2, T = c.model.context_frames, N = c.model.tokens_per_frame();
  SegmentBatch b;
  b.tokens = torch::randint(c.model.num_codes, {B, T, N}, torch::kInt64);
  b.actions = torch::randn({B, T, f.action_dim});
  if (f.padded > 0) {  // row 1 comes from a narrower dataset
    b.action_mask = torch::ones({B, 1, f.action_dim});
    b.action_mask[1].slice(-1, f.padded).fill_(0);
  }
  b.rewards = torch::rand({B, T});
  b.terminals = (torch::rand({B, T}) > 0.7).to(torch::kFloat);
  b.mask = TrainingMask(torch::rand({B, T}), torch::rand({B, T, N}), torch::rand({B, T}), 0.7);
  if (f.next_frame) {  // the targets: every token of frames 1..T-1 (as MakeSegmentBatch)
    b.mask = torch::ones({B, T, N}, torch::kBool);
    b.mask.select(1, 0).fill_(false);
  }
  b.z_noise = torch::rand({B, c.policy.categories, c.policy.classes});
  WorldModelLosses l = m->Losses(b);
  wm::TensorArchiveWriter w;
  wm::trainkit::AddModule(w, "model/", *m);
  wm::trainkit::AddTensor(w, "input/tokens", b.tokens);
  wm::trainkit::AddTensor(w, "input/actions", b.actions);
  wm::trainkit::AddTensor(w, "input/rewards", b.rewards);
  wm::trainkit::AddTensor(w, "input/terminals", b.terminals);
  wm::trainkit::AddTensor(w, "input/mask", b.mask.to(torch::kInt64));
  wm::trainkit::AddTensor(w, "input/z_noise", b.z_noise);
  if (b.action_mask.defined()) wm::trainkit::AddTensor(w, "input/action_mask", b.action_mask);
  torch::NoGradGuard no_grad;
  torch::Tensor masked = f.next_frame ? b.tokens : b.tokens.masked_fill(b.mask, c.model.num_codes);
  torch::Tensor z = m->DynamicsZ(b.tokens, b.actions);
  DynamicsOutput out = m->Dynamics(masked, b.actions, z);
  wm::trainkit::AddTensor(w, "output/logits", out.logits);
  wm::trainkit::AddTensor(w, "output/reward", out.reward);
  wm::trainkit::AddTensor(w, "output/terminal_logit", out.terminal_logit);
  nlohmann::json losses = {{"token_ce", l.token_ce.item<double>()},
                           {"reward_mse", l.reward_mse.item<double>()},
                           {"terminal_bce", l.terminal_bce.item<double>()},
                           {"total", l.total.item<double>()}};
  if (policy) {
    PolicyOutput po = m->policy->forward(m->PolicyTokens(b.tokens), b.actions, b.z_noise);
    wm::trainkit::AddTensor(w, "output/z", z);
    wm::trainkit::AddTensor(w, "output/prior_logits", po.prior_logits);
    wm::trainkit::AddTensor(w, "output/posterior_logits", po.posterior_logits);
    wm::trainkit::AddTensor(w, "output/action_mean", po.action_mean);
    wm::trainkit::AddTensor(w, "output/action_log_std", po.action_log_std);
    losses["policy_nll"] = l.policy->nll.item<double>();
    losses["policy_kl"] = l.policy->kl.item<double>();
  }
  w.SetMeta({{"config", ConfigToJson(c)}, {"losses", losses}});
  w.Write(path);
}

void EvalNextFrame(const std::string& run, const std::string& dir, int frames, int max_windows) {
  auto model = DynamicsModel::Load(run, "cpu", "", 1);
  wm::tokens::TokenDataset data(dir);
  const int64_t N = data.tokens_per_frame();
  int64_t hits = 0, copy_hits = 0, total = 0, windows = 0, changed_hits = 0, flipped = 0;
  for (int64_t k = 0; k < data.num_episodes() && windows < max_windows; ++k) {
    const int64_t F = data.episode(k).num_frames;
    for (int64_t t = frames; t < F && windows < max_windows; t += frames, ++windows) {
      FrameContext c{.batch = 1, .frames = frames};
      std::vector<int64_t> all((frames + 1) * N);
      data.CopyTokens(k, t - frames, frames + 1, all.data());
      c.tokens.assign(all.begin(), all.begin() + frames * N);
      const int64_t A = data.action_dim();
      c.actions.assign(data.actions(k) + (t - frames) * A, data.actions(k) + t * A);
      const auto next = model->PredictNextFrame(c, 0, 0, 0.0);
      // Action sensitivity: the same context with the last move's x/y direction reversed.
      FrameContext mirrored = c;
      for (int d : {0, 1}) mirrored.actions[(frames - 1) * A + d] *= -1;
      const auto other = model->PredictNextFrame(mirrored, 0, 0, 0.0);
      for (int64_t i = 0; i < N; ++i) flipped += next[i] != other[i];
      for (int64_t i = 0; i < N; ++i) {
        const bool right = next[i] == all[frames * N + i];
        const bool same = all[(frames - 1) * N + i] == all[frames * N + i];
        hits += right;
        copy_hits += same;
        changed_hits += right && !same;
      }
      total += N;
    }
  }
  std::cout << "windows " << windows << ", next-frame token accuracy: model "
            << double(hits) / total << ", copy-last-frame " << double(copy_hits) / total
            << "; tokens that change: " << changed_hits << " of " << total - copy_hits
            << " predicted; " << flipped << " tokens differ when the last move is reversed\n";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dynamics_test_tool: fixtures for the dynamics model's Python checks"};
  app.require_subcommand(1);
  test::MovingBlockOptions mb;
  std::string tokens_out;
  auto* make = app.add_subcommand("make-tokens", "Write a moving-block token dataset");
  make->add_option("--out", tokens_out)->required();
  make->add_option("--dataset", mb.dataset);
  make->add_option("--episodes", mb.episodes);
  make->add_option("--steps", mb.steps);
  make->add_option("--grid", mb.grid_h);
  make->add_option("--codes", mb.num_codes);
  make->add_option("--seed", mb.seed);
  make->add_flag("--uniform-moves", mb.uniform_moves);
  make->add_option("--levels", mb.levels);
  std::string ref_out;
  ReferenceFlags flags;
  uint64_t seed = 0;
  auto* ref = app.add_subcommand("reference", "Write weights, inputs and C++ outputs");
  ref->add_option("--out", ref_out)->required();
  ref->add_flag("--rmsnorm", flags.rmsnorm);
  ref->add_flag("--no-policy", flags.no_policy);
  ref->add_flag("--tied", flags.tied);
  ref->add_flag("--copy-prior", flags.copy_prior);
  ref->add_flag("--next-frame", flags.next_frame);
  ref->add_flag("--rope", flags.rope);
  ref->add_option("--action-dim", flags.action_dim);
  ref->add_option("--padded", flags.padded);
  ref->add_option("--levels", flags.levels);
  ref->add_option("--adaptive-norm", flags.adaptive_norm);
  ref->add_option("--seed", seed);
  std::string eval_run, eval_tokens;
  int eval_frames = 5, eval_windows = 200;
  auto* eval = app.add_subcommand("eval-next-frame", "Next-frame accuracy vs copying");
  eval->add_option("--run", eval_run)->required();
  eval->add_option("--tokens", eval_tokens)->required();
  eval->add_option("--frames", eval_frames);
  eval->add_option("--max-windows", eval_windows);
  CLI11_PARSE(app, argc, argv);
  try {
    torch::set_num_threads(1);
    if (make->parsed()) {
      mb.grid_w = mb.grid_h;
      test::WriteMovingBlockTokens(tokens_out, mb);
    } else if (ref->parsed()) {
      WriteReference(ref_out, flags, seed);
    } else {
      EvalNextFrame(eval_run, eval_tokens, eval_frames, eval_windows);
    }
  } catch (const std::exception& e) {
    std::cerr << "dynamics_test_tool: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
