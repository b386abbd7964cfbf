// Closed-loop imagination speed of the motion model (issue 21 item 7): one episode at a time
// (MotionWorlds: a model step and a success-classifier call per frame) beside the batched path
// wm-eval --policy runs (MotionWorldBatches: one step of all rows, one classifier call for them),
// same model, classifier, starts and policy, in one run. Counts imagined frames: each is one model
// step, its P(success) and the policy's answer to it (one policy process). Also times the parts
// of a frame on each path, and checks that both paths imagine the same. Each path runs --repeats
// times, taking turns with the other, and its fastest run counts (a shared machine's load).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <limits>

#include "bench/closed_loop_runs.h"
#include "core/malloc_tuning.h"
#include "core/shard/dataset_reader.h"
#include "evaluate/clip_decode.h"
#include "evaluate/closed_loop.h"
#include "evaluate/rollout.h"
#include "motion/motion_model.h"
#include "policy/policy_process.h"
#include "success/success_model.h"

namespace {
namespace ev = wm::evaluate;
using wm::bench::Clock;
using wm::bench::Run;
using wm::bench::Seconds;

struct BenchOptions {
  std::string checkpoint, success, data, policy = "scripts/tabletop_colour_policy.py";
  int episodes = 16, threads = 2, batch = 16, repeats = 3;
  int64_t horizon = 40;
};

// The first `count` episodes' real first frames, as wm-eval --policy starts from them.
std::vector<ev::ClosedLoopStart> Starts(const wm::shard::DatasetReader& shards,
                                        const wm::motion::MotionModel& model, int count) {
  std::vector<ev::ClosedLoopStart> starts;
  const auto size = static_cast<int>(model.image_size());
  for (size_t k = 0; k < std::min<size_t>(count, shards.num_episodes()); ++k) {
    const wm::Episode ep = shards.ReadEpisode(k);
    starts.push_back({.episode = static_cast<int64_t>(k),
                      .episode_seed = ev::MixSeed(7, static_cast<int64_t>(k)),
                      .instruction = ep.language_instruction,
                      .first_frame = ev::RealClip(ep, model.config().data.image_key, size, 1)});
  }
  return starts;
}

// Milliseconds per imagined frame of a model step and of its classifier call, `batch` rows of
// `first` (its frame repeated) stepped `steps` times with zero actions.
void TimeParts(const wm::motion::MotionModel& model, const wm::success::SuccessModel& success,
               const ev::Clip& first, int64_t batch, int64_t steps) {
  std::vector<float> frames;
  for (int64_t k = 0; k < batch; ++k) {
    frames.insert(frames.end(), first.pixels.begin(), first.pixels.end());
  }
  const auto rollout = model.StartRollout(frames, batch);
  const std::vector<float> actions(static_cast<size_t>(batch * model.action_dim()), 0.f);
  double model_s = 0, success_s = 0;
  for (int64_t t = 0; t < steps; ++t) {
    auto t0 = Clock::now();
    frames = rollout->Next(actions);
    model_s += Seconds(t0);
    t0 = Clock::now();
    success.Probabilities(frames, batch);
    success_s += Seconds(t0);
  }
  const double per_frame = 1e3 / static_cast<double>(steps * batch);
  std::printf("parts per frame at batch %lld: model step %.2f ms, success classifier %.2f ms\n",
              static_cast<long long>(batch), model_s * per_frame, success_s * per_frame);
}

// The run that took less time (`a` when it has none yet).
Run Faster(Run a, Run b) {
  return a.frames == 0 || b.seconds < a.seconds ? std::move(b) : std::move(a);
}

}  // namespace

int main(int argc, char** argv) {
  wm::KeepLargeAllocationsInHeap();  // as wm-eval
  BenchOptions b;
  CLI::App app{
      "motion_imagination_bench: closed-loop imagined frames/s of a motion model, one episode at "
      "a time vs batched\n"
      "  e.g. motion_imagination_bench --checkpoint data/demo/run/motion --success-model "
      "data/wpe/success --data data/demo/shards/val"};
  app.add_option("--checkpoint", b.checkpoint, "Motion RUN_DIR (wm-motion train)")->required();
  app.add_option("--success-model", b.success, "Success classifier RUN_DIR (wm-success train)")
      ->required();
  app.add_option("--data", b.data, "Shard dataset of the starts (their first frames)")->required();
  app.add_option("--policy", b.policy, "Policy command")->capture_default_str();
  app.add_option("--episodes", b.episodes, "Starts")->capture_default_str();
  app.add_option("--horizon", b.horizon, "Steps per episode (none ends early)")
      ->capture_default_str();
  app.add_option("--batch", b.batch, "Starts per batch (batched path)")->capture_default_str();
  app.add_option("--threads", b.threads, "LibTorch intra-op threads")->capture_default_str();
  app.add_option("--repeats", b.repeats, "Runs of each path, taking turns (the fastest counts)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  const auto model = wm::motion::MotionModel::Load(b.checkpoint, "cpu", b.threads);
  const auto success = wm::success::SuccessModel::Load(b.success, "cpu", b.threads);
  const std::vector<ev::ClosedLoopStart> starts =
      Starts(wm::shard::DatasetReader(b.data), *model, b.episodes);
  ev::ClosedLoopOptions o{.horizon = b.horizon, .batch = b.batch};
  // Every episode runs the whole horizon, so both paths imagine the same number of frames.
  o.success_threshold = o.terminal_threshold = std::numeric_limits<double>::infinity();
  wm::policy::PolicyProcess policy({.name = "bench",
                                    .command = b.policy,
                                    .action_dim = static_cast<int>(model->action_dim()),
                                    .image_height = static_cast<int>(model->image_size()),
                                    .image_width = static_cast<int>(model->image_size())});
  std::printf("%s (motion, %s), %zu episodes x %lld steps, %d threads, batch %d\n",
              b.checkpoint.c_str(), model->config().model.kind.c_str(), starts.size(),
              static_cast<long long>(b.horizon), b.threads, b.batch);
  // The paths take turns, so that a burst of load on a shared machine hits both alike; each
  // keeps its fastest run.
  Run fast, ref;
  for (int r = 0; r < b.repeats; ++r) {
    fast = Faster(std::move(fast),
                  wm::bench::Batched(ev::MotionWorldBatches(*model, *success), policy, starts, o));
    ref = Faster(std::move(ref),
                 wm::bench::OneAtATime(ev::MotionWorlds(*model, *success), policy, starts, o));
  }
  std::printf("batched: %lld frames in %.2f s = %.1f frames/s (fastest of %d)\n",
              static_cast<long long>(fast.frames), fast.seconds, fast.Rate(), b.repeats);
  const int64_t part_steps = std::min<int64_t>(b.horizon, 20);
  TimeParts(*model, *success, starts.front().first_frame, 1, part_steps);
  TimeParts(*model, *success, starts.front().first_frame, b.batch, part_steps);
  wm::bench::PrintSpeed("one at a time", ref, "batched / one at a time", fast.Rate() / ref.Rate());
  wm::bench::Compare(ref, fast, "batched vs one at a time");
  policy.Close();
  return 0;
}
