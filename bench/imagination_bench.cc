// Closed-loop imagination speed (issue 21 item 7): the reference path (one episode at a time,
// the context window recomputed for the frame and again for its reward: TokenWorlds) beside the
// batched, cached one wm-eval --policy runs (TokenWorldBatches), same model, starts and policy,
// in one run. Counts imagined frames: each is one model step (tokens + reward + terminal
// probability), its tokenizer decode, and the policy's answer to it (one policy process).
// Also times the reference path's parts, and checks that both paths imagine the same. A model
// with rotary time also runs the rolling cache (wm-eval --rolling-cache), compared with the
// batched path: the same until the window slides, its own semantics after.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <limits>

#include "bench/closed_loop_runs.h"
#include "core/malloc_tuning.h"
#include "core/tokens/token_dataset.h"
#include "evaluate/closed_loop.h"
#include "evaluate/retrace.h"
#include "policy/policy_process.h"
#include "tokenize/tokenizer.h"
#include "train/dynamics_model.h"

namespace {
namespace ev = wm::evaluate;
using wm::bench::Batched;
using wm::bench::Clock;
using wm::bench::Compare;
using wm::bench::OneAtATime;
using wm::bench::PrintSpeed;
using wm::bench::Run;
using wm::bench::Seconds;

struct BenchOptions {
  std::string checkpoint, tokenizer, tokens, policy = "scripts/tabletop_colour_policy.py";
  int episodes = 16, threads = 2, batch = 16, decode_steps = 0;
  int64_t horizon = 40;
  bool skip_reference = false;  // for profiling the new path alone
};

// The first `count` episodes' first frames (decoded from their tokens: no shards needed).
std::vector<ev::ClosedLoopStart> Starts(const wm::tokens::TokenDataset& data,
                                        const wm::tokenize::Tokenizer& tok, int count) {
  std::vector<ev::ClosedLoopStart> starts;
  const int64_t n = data.tokens_per_frame();
  for (int64_t k = 0; k < std::min<int64_t>(count, data.num_episodes()); ++k) {
    ev::ClosedLoopStart s{.episode = k, .episode_seed = ev::MixSeed(7, k)};
    s.instruction = data.episode(k).language_instruction;
    s.first_tokens.resize(static_cast<size_t>(n));
    data.CopyTokens(k, 0, 1, s.first_tokens.data());
    const std::vector<uint32_t> codes(s.first_tokens.begin(), s.first_tokens.end());
    s.first_frame = {1, tok.image_size(), tok.Decode(codes.data(), 1)};
    starts.push_back(std::move(s));
  }
  return starts;
}

// The reference path's parts per imagined frame: model step, tokenizer decode, policy answer.
void TimeParts(const wm::train::DynamicsModel& model, const wm::tokenize::Tokenizer& tok,
               wm::policy::PolicyProcess& policy, const ev::ClosedLoopStart& s,
               const ev::ClosedLoopOptions& o, int64_t steps) {
  const int64_t dim = model.action_dim();
  const std::vector<float> actions(static_cast<size_t>(steps * dim), 0.f);
  std::vector<int64_t> tokens = s.first_tokens;
  const int64_t context = ev::ContextFrames(model, o.imagination.context);
  auto t0 = Clock::now();
  for (int64_t t = 0; t < steps; ++t) {
    const ev::ImaginedFrame f = ev::ImagineNextFrame(
        model, tokens, ev::PlainContext(actions.data(), dim, t, context), {}, t, o.imagination);
    tokens.insert(tokens.end(), f.tokens.begin(), f.tokens.end());
  }
  const double model_s = Seconds(t0) / steps;
  const std::vector<uint32_t> codes(tokens.begin(), tokens.begin() + s.first_tokens.size());
  t0 = Clock::now();
  for (int64_t t = 0; t < steps; ++t) tok.Decode(codes.data(), 1, s.first_frame.pixels.data());
  const double decode_s = Seconds(t0) / steps;
  const std::vector<uint8_t> rgb =
      wm::tokenize::PlanarToRgb8(s.first_frame.frame(0), s.first_frame.size);
  policy.Reset(s.episode, 1, s.instruction);
  t0 = Clock::now();
  for (int64_t t = 0; t < steps; ++t) {
    policy.Act({rgb.data(), s.first_frame.size, s.first_frame.size, s.instruction, s.episode, t});
  }
  const double policy_s = Seconds(t0) / steps;
  std::printf("reference parts per frame: model %.2f ms, decode %.2f ms, policy %.2f ms\n",
              model_s * 1e3, decode_s * 1e3, policy_s * 1e3);
}

}  // namespace

int main(int argc, char** argv) {
  wm::KeepLargeAllocationsInHeap();  // as wm-eval
  BenchOptions b;
  CLI::App app{
      "imagination_bench: closed-loop imagined frames/s, reference vs batched+cached\n"
      "  e.g. imagination_bench --checkpoint data/demo/run/dynamics --tokenizer "
      "data/demo/run/tokenizer --tokens data/demo/run/tokens/val"};
  app.add_option("--checkpoint", b.checkpoint, "Dynamics RUN_DIR")->required();
  app.add_option("--tokenizer", b.tokenizer, "Tokenizer RUN_DIR")->required();
  app.add_option("--tokens", b.tokens, "Token dataset of the starts")->required();
  app.add_option("--policy", b.policy, "Policy command")->capture_default_str();
  app.add_option("--episodes", b.episodes, "Starts")->capture_default_str();
  app.add_option("--horizon", b.horizon, "Steps per episode (none ends early)")
      ->capture_default_str();
  app.add_option("--batch", b.batch, "Starts per batch (new path)")->capture_default_str();
  app.add_option("--decode-steps", b.decode_steps, "MaskGIT rounds; 0: the checkpoint's")
      ->capture_default_str();
  app.add_option("--threads", b.threads, "LibTorch intra-op threads")->capture_default_str();
  app.add_flag("--skip-reference", b.skip_reference, "Time the new path only (for profiling)");
  CLI11_PARSE(app, argc, argv);

  const wm::tokens::TokenDataset data(b.tokens);
  const auto model = wm::train::DynamicsModel::Load(b.checkpoint, "cpu", "", b.threads);
  const wm::tokenize::Tokenizer tok(b.tokenizer);
  const std::vector<ev::ClosedLoopStart> starts = Starts(data, tok, b.episodes);
  ev::ClosedLoopOptions o{.horizon = b.horizon, .batch = b.batch};
  // Every episode runs the whole horizon, so both paths imagine the same number of frames.
  o.success_threshold = o.terminal_threshold = std::numeric_limits<double>::infinity();
  o.imagination.decode_steps = b.decode_steps;
  wm::policy::PolicyProcess policy({.name = "bench",
                                    .command = b.policy,
                                    .action_dim = static_cast<int>(model->action_dim()),
                                    .image_height = tok.image_size(),
                                    .image_width = tok.image_size()});
  const bool one_pass = model->config().model.objective == "next_frame";
  std::printf(
      "%s (%s, %d decoding pass(es) per frame), %zu episodes x %lld steps, %d threads, "
      "batch %d\n",
      b.checkpoint.c_str(), model->config().model.objective.c_str(),
      one_pass ? 1 : (b.decode_steps > 0 ? b.decode_steps : model->config().model.decode_steps),
      starts.size(), static_cast<long long>(b.horizon), b.threads, b.batch);
  const Run fast = Batched(ev::TokenWorldBatches(*model, tok, o), policy, starts, o);
  std::printf("batched+cached: %lld frames in %.2f s = %.1f frames/s\n",
              static_cast<long long>(fast.frames), fast.seconds, fast.frames / fast.seconds);
  if (!b.skip_reference) {
    TimeParts(*model, tok, policy, starts.front(), o, std::min<int64_t>(b.horizon, 20));
    const Run ref = OneAtATime(ev::TokenWorlds(*model, tok, o), policy, starts, o);
    PrintSpeed("reference", ref, "batched+cached / reference", fast.Rate() / ref.Rate());
    Compare(ref, fast, "batched+cached vs reference");
  }
  if (model->CanRoll()) {
    o.rolling_cache = true;
    const Run rolling = Batched(ev::TokenWorldBatches(*model, tok, o), policy, starts, o);
    PrintSpeed("batched+rolling cache", rolling, "/ batched+cached", rolling.Rate() / fast.Rate());
    Compare(fast, rolling, "rolling vs batched+cached (equal until the window slides)");
  }
  policy.Close();
  return 0;
}
