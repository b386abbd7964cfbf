#include "evaluate/policy_eval.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <optional>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "core/shard/dataset_reader.h"
#include "core/tokens/token_dataset.h"
#include "evaluate/aggregate.h"
#include "evaluate/clip_decode.h"
#include "evaluate/episode_strip.h"
#include "evaluate/evaluator.h"
#include "evaluate/imagination.h"
#include "evaluate/manifest.h"
#include "evaluate/wpe_report.h"
#include "motion/motion_model.h"
#include "policy/policy_process.h"
#include "policy/policy_value.h"
#include "success/success_model.h"
#include "tokenize/tokenizer.h"
#include "train/dynamics_model.h"
#include "trainkit/torch_runtime.h"

namespace wm::evaluate {
namespace {

namespace fs = std::filesystem;

// Files of a finished report: removed before a run, written only when every policy succeeded.
constexpr const char* kReportFiles[] = {"manifest.json", "wpe_summary.json", "wpe.csv",
                                        "wm_values.csv", "wm_episodes.csv"};

struct PolicyRun {
  policy::PolicySpec spec;
  std::vector<ClosedLoopRollout> rollouts;  // start-major: starts[i]'s rollouts r = 0..R-1
};

// The held-out episodes' first frames; `logged` gets the real frames 0..horizon of the first
// `strips` of them (the strips' reference row).
std::vector<ClosedLoopStart> LoadStarts(const EvalOptions& o, const tokens::TokenDataset& data,
                                        const tokenize::Tokenizer& tok,
                                        const shard::DatasetReader& shards,
                                        std::vector<Clip>* logged) {
  const std::string image_key = data.index().tokenizer.image_key;
  std::vector<ClosedLoopStart> starts;
  for (int64_t k = 0; k < data.num_episodes(); ++k) {
    if (o.max_episodes > 0 && k >= o.max_episodes) break;
    const tokens::TokenEpisode& e = data.episode(k);
    const Episode ep = shards.ReadEpisode(static_cast<size_t>(e.source_episode));
    ClosedLoopStart s{.episode = k,
                      .episode_seed = e.episode_seed ? static_cast<uint64_t>(*e.episode_seed)
                                                     : MixSeed(o.rollout.seed, k),
                      .instruction = e.language_instruction,
                      .first_tokens = std::vector<int64_t>(data.tokens_per_frame()),
                      .first_frame = RealClip(ep, image_key, tok.image_size(), 1)};
    data.CopyTokens(k, 0, 1, s.first_tokens.data());
    starts.push_back(std::move(s));
    if (k < o.strips) {
      const int64_t frames = std::min(e.num_frames, o.policy_eval.loop.horizon + 1);
      logged->push_back(RealClip(ep, image_key, tok.image_size(), frames));
    }
  }
  Check(!starts.empty(), "no episodes to start from", {.file = o.tokens_dir});
  return starts;
}

// A checkpoint's world in closed loop: how to imagine, and what its manifests say of it.
struct ClosedLoopModel {
  WorldsFactory worlds;
  int64_t action_dim = 0;
  CheckpointInfo info;
  std::shared_ptr<const void> keep;  // the models `worlds` refers to
};

// Runs one policy from every start; keeps the decoded frames of rollout 0 of the first `strips`
// starts only.
PolicyRun RunPolicy(const EvalOptions& o, const policy::PolicySpec& spec,
                    const ClosedLoopModel& model, const tokenize::Tokenizer& tok,
                    const std::vector<ClosedLoopStart>& starts) {
  const PolicyEvalOptions& p = o.policy_eval;
  policy::PolicyProcess process({.name = spec.name,
                                 .command = spec.command,
                                 .action_dim = static_cast<int>(model.action_dim),
                                 .image_height = tok.image_size(),
                                 .image_width = tok.image_size(),
                                 .start_timeout_s = p.start_timeout_s,
                                 .step_timeout_s = p.step_timeout_s});
  PolicyRun run{spec, {}};
  std::optional<Progress> progress;
  if (o.show_progress) progress.emplace("imagine " + spec.name, starts.size(), "starts");
  run.rollouts.resize(starts.size() * p.loop.rollouts);
  const auto batch = static_cast<size_t>(std::max(1, p.loop.batch));
  for (size_t first = 0; first < starts.size(); first += batch) {
    std::vector<const ClosedLoopStart*> group;  // starts[first, first + batch): one batch
    for (size_t i = first; i < std::min(first + batch, starts.size()); ++i) {
      group.push_back(&starts[i]);
    }
    // The rollouts of a start share its episode id, so they go in separate batches.
    for (int r = 0; r < p.loop.rollouts; ++r) {
      std::vector<ClosedLoopRollout> rollouts =
          RunClosedLoops(*model.worlds(group, r), process, group, r, p.loop);
      for (size_t k = 0; k < rollouts.size(); ++k) {
        const size_t i = first + k;
        if (r > 0 || static_cast<int>(i) >= o.strips) rollouts[k].frames = {};
        run.rollouts[i * p.loop.rollouts + r] = std::move(rollouts[k]);
      }
    }
    if (progress) progress->Add(group.size());
  }
  if (progress) progress->Finish();
  process.Close();
  return run;
}

PolicyEstimate Estimate(const PolicyRun& run) {
  int64_t successes = 0;
  for (const ClosedLoopRollout& r : run.rollouts) successes += r.success;
  const auto n = static_cast<int64_t>(run.rollouts.size());
  const policy::SuccessRate rate = policy::WilsonInterval(successes, n);
  return {run.spec.name, run.spec.in_distribution, n, rate.rate, rate.low, rate.high};
}

std::string EpisodesCsv(const std::vector<PolicyRun>& runs) {
  std::string csv =
      "policy,episode,rollout,episode_seed,policy_seed,success,return,steps,end,max_reward\n";
  for (const PolicyRun& run : runs) {
    for (const ClosedLoopRollout& r : run.rollouts) {
      double max_reward = r.rewards.empty() ? 0 : r.rewards[0];
      for (float x : r.rewards) max_reward = std::max<double>(max_reward, x);
      csv += run.spec.name + "," + std::to_string(r.episode) + "," + std::to_string(r.rollout) +
             "," + std::to_string(r.episode_seed) + "," + std::to_string(r.policy_seed) + "," +
             (r.success ? "1" : "0") + "," + Cell(r.episode_return) + "," +
             std::to_string(r.steps) + "," + r.end + "," + Cell(max_reward) + "\n";
    }
  }
  return csv;
}

std::string ValuesCsv(const std::vector<PolicyRun>& runs) {
  std::string csv =
      "policy,in_distribution,episodes,successes,wm_value,ci_low,ci_high,mean_return,mean_steps\n";
  for (const PolicyRun& run : runs) {
    const PolicyEstimate e = Estimate(run);
    double returns = 0, steps = 0;
    for (const ClosedLoopRollout& r : run.rollouts) returns += r.episode_return, steps += r.steps;
    const double n = static_cast<double>(e.episodes);
    csv += e.policy + "," + (e.in_distribution ? "true" : "false") + "," +
           std::to_string(e.episodes) + "," + std::to_string(std::lround(e.value * n)) + "," +
           Cell(e.value) + "," + Cell(e.ci_low) + "," + Cell(e.ci_high) + "," + Cell(returns / n) +
           "," + Cell(steps / n) + "\n";
  }
  return csv;
}

// `clip`'s frames [first, clip.frames), then its last frame repeated up to `count` frames: an
// episode that ended early holds its last frame in the strip.
Clip HoldLastFrame(const Clip& clip, int64_t first, int64_t count) {
  Clip out = SubClip(clip, first, std::min(count, clip.frames - first));
  const Clip hold = RepeatFrame(clip, clip.frames - 1, count - out.frames);
  out.pixels.insert(out.pixels.end(), hold.pixels.begin(), hold.pixels.end());
  out.frames = count;
  return out;
}

// strips/episode_K.png per start: the logged real episode on top (the data's own actions, for
// reference), then each policy's first imagined rollout: exactly the frames it was shown.
void WriteStrips(const std::string& dir, const std::vector<PolicyRun>& runs,
                 const std::vector<ClosedLoopStart>& starts, const std::vector<Clip>& logged) {
  const int rollouts = static_cast<int>(runs.front().rollouts.size() / starts.size());
  for (size_t i = 0; i < logged.size(); ++i) {
    int64_t steps = logged[i].frames - 1;
    for (const PolicyRun& run : runs) steps = std::max(steps, run.rollouts[i * rollouts].steps);
    std::map<std::string, Clip> clips;
    for (const PolicyRun& run : runs) {
      clips[run.spec.name] = HoldLastFrame(run.rollouts[i * rollouts].frames, 1, steps);
    }
    WriteEpisodeStrip((fs::path(dir) / "strips").string(), starts[i].episode,
                      HoldLastFrame(logged[i], 0, steps + 1), clips);
  }
}

void WriteWpe(const EvalOptions& o, const std::string& dir, const std::string& checkpoint_file,
              const std::string& success_file, const std::vector<PolicyRun>& runs) {
  std::vector<PolicyEstimate> model;
  for (const PolicyRun& run : runs) model.push_back(Estimate(run));
  const std::vector<WpeRow> rows =
      PairWithTruth(model, ReadTrueValues(o.policy_eval.true_values), o.policy_eval.true_values);
  nlohmann::json provenance =
      MakeProvenance("wm-eval", EvalConfigJson(o), trainkit::TorchLibraryVersions());
  provenance["inputs"] = {{"checkpoint_sha256", Sha256File(checkpoint_file)},
                          {"true_values_sha256", Sha256File(o.policy_eval.true_values)}};
  if (!success_file.empty())
    provenance["inputs"]["success_model_sha256"] = Sha256File(success_file);
  const WpeSummary s = SummarizeWpe(rows);
  WriteWpeReport(dir, rows, s, provenance);
  spdlog::info(
      "WPE over {} policies: Spearman {:.3f}, Kendall {:.3f}, pairwise accuracy {:.3f}, "
      "mean |gap| {:.3f}",
      s.num_policies, s.spearman, s.kendall, s.pairwise_accuracy, s.mean_abs_gap);
}

// Refuses a classifier of another frame size than the model imagines; what the report records
// of it.
nlohmann::json DescribeSuccessModel(const success::SuccessModel& success, int64_t image_size,
                                    const std::string& imagines) {
  Check(success.image_size() == image_size,
        "the success classifier scores " + std::to_string(success.image_size()) + " px frames, " +
            imagines + " imagines " + std::to_string(image_size) +
            " px ones (train both at one image_size)",
        {.file = success.checkpoint_file(), .key = "model.image_size"});
  return {{"sha256", Sha256File(success.checkpoint_file())},
          {"step", success.step()},
          {"config_hash", ConfigHash(success::ConfigToJson(success.config()))}};
}

// One keep-alive handle for two models a closed loop refers to.
template <typename A, typename B>
std::shared_ptr<const void> KeepBoth(std::shared_ptr<A> a, std::shared_ptr<B> b) {
  return std::make_shared<std::pair<std::shared_ptr<A>, std::shared_ptr<B>>>(std::move(a),
                                                                             std::move(b));
}

// The token model of `checkpoint`: its reward and terminal heads score each step, or the success
// classifier `success` when there is one (the motion model's judge, so the two are comparable).
ClosedLoopModel LoadTokenModel(const EvalOptions& o, const std::string& checkpoint,
                               const std::shared_ptr<const success::SuccessModel>& success,
                               const tokenize::Tokenizer& tok, const tokens::TokenDataset& data) {
  std::shared_ptr<const train::DynamicsModel> model = LoadModelFor(o, checkpoint, data);
  CheckModelFitsTokens(*model, data);
  ClosedLoopModel loaded{.worlds = TokenWorldBatches(*model, tok, o.policy_eval.loop),
                         .action_dim = model->action_dim(),
                         .info = DescribeDynamicsCheckpoint(*model),
                         .keep = model};
  if (success) {
    loaded.info.extra["success_model"] =
        DescribeSuccessModel(*success, tok.image_size(), "the token model");
    loaded.worlds = ScoredBySuccess(std::move(loaded.worlds), *success);
    loaded.keep = KeepBoth(model, success);
  }
  return loaded;
}

// The motion model of `checkpoint` with the success classifier `success` (not null) scoring its
// frames.
ClosedLoopModel LoadMotionModel(const EvalOptions& o, const std::string& checkpoint,
                                const std::shared_ptr<const success::SuccessModel>& success,
                                const tokenize::Tokenizer& tok, const tokens::TokenDataset& data) {
  LoadedMotionModel motion = LoadMotionModelFor(o, checkpoint, tok, data);
  motion.info.extra["success_model"] =
      DescribeSuccessModel(*success, motion.model->image_size(), "the motion model");
  return {.worlds = MotionWorldBatches(*motion.model, *success),
          .action_dim = motion.model->action_dim(),
          .info = std::move(motion.info),
          .keep = KeepBoth(motion.model, success)};
}

}  // namespace

std::vector<std::string> EvaluatePolicies(const EvalOptions& o) {
  // Before any work: a motion checkpoint has no reward head to read success from.
  for (const std::string& checkpoint : o.checkpoints) {
    Check(!o.policy_eval.success_model.empty() ||
              !motion::MotionModel::IsMotionCheckpoint(checkpoint),
          "a motion checkpoint has no reward head: closed-loop policy evaluation (--policy) of it "
          "needs --success-model RUN_DIR (a success classifier from wm-success train)",
          {.file = checkpoint, .key = "--success-model"});
  }
  tokens::TokenDataset data(o.tokens_dir);
  tokenize::Tokenizer tok(o.tokenizer, o.device);
  shard::DatasetReader shards(o.data_dir);
  CheckInputsBelongTogether(data, tok, shards);
  Check(
      !o.policy_eval.loop.clamp_tabletop ||
          shard::IsCanonicalAction(data.action_dim(), data.index().action_space),
      "--clamp-actions tabletop clamps the tabletop world's 7-dim eef_delta action, but dataset '" +
          data.index().dataset + "' has " + std::to_string(data.action_dim()) + "-dim " +
          data.index().action_space + " actions (pass --clamp-actions none)",
      {.file = data.dir(), .key = "--clamp-actions"});
  Check(o.policy_eval.loop.horizon >= 1 && o.policy_eval.loop.rollouts >= 1,
        "--policy-horizon and --policy-rollouts must be at least 1", {.key = "--policy-horizon"});
  std::shared_ptr<const success::SuccessModel> success;
  if (!o.policy_eval.success_model.empty()) {
    success = success::SuccessModel::Load(o.policy_eval.success_model, o.device, o.threads);
  }
  std::vector<Clip> logged;
  const std::vector<ClosedLoopStart> starts = LoadStarts(o, data, tok, shards, &logged);
  std::vector<std::string> written;
  for (size_t c = 0; c < o.checkpoints.size(); ++c) {
    const std::string name = ReportName(o, c);
    const std::string dir = (fs::path(o.out_dir) / name).string();
    fs::create_directories(dir);
    for (const char* f : kReportFiles) fs::remove(fs::path(dir) / f);
    const bool is_motion = motion::MotionModel::IsMotionCheckpoint(o.checkpoints[c]);
    const ClosedLoopModel model = is_motion
                                      ? LoadMotionModel(o, o.checkpoints[c], success, tok, data)
                                      : LoadTokenModel(o, o.checkpoints[c], success, tok, data);
    std::vector<PolicyRun> runs;
    for (const policy::PolicySpec& spec : o.policy_eval.policies) {
      runs.push_back(RunPolicy(o, spec, model, tok, starts));
      const PolicyEstimate e = Estimate(runs.back());
      spdlog::info("{}: {} in the world model: value {:.3f} [{:.3f}, {:.3f}] over {} episodes",
                   name, spec.name, e.value, e.ci_low, e.ci_high, e.episodes);
    }
    WriteFileAtomically((fs::path(dir) / "wm_episodes.csv").string(), EpisodesCsv(runs));
    WriteFileAtomically((fs::path(dir) / "wm_values.csv").string(), ValuesCsv(runs));
    WriteStrips(dir, runs, starts, logged);
    if (!o.policy_eval.true_values.empty()) {
      WriteWpe(o, dir, model.info.file, success ? success->checkpoint_file() : "", runs);
    }
    WriteEvalManifest(dir, name, o.checkpoints[c], o, model.info, tok, data, shards);
    written.push_back(dir);
  }
  return written;
}

}  // namespace wm::evaluate
