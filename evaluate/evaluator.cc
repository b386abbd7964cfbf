#include "evaluate/evaluator.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <functional>
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
#include "evaluate/clip_video.h"
#include "evaluate/episode_record.h"
#include "evaluate/episode_strip.h"
#include "evaluate/frame_scores.h"
#include "evaluate/imagination.h"
#include "evaluate/manifest.h"
#include "evaluate/motion_scores.h"
#include "evaluate/rollout_export.h"
#include "evaluate/uncertainty_report.h"
#include "metrics/frechet.h"
#include "metrics/lpips/lpips.h"
#include "metrics/value/correlation.h"
#include "metrics/value/value_metrics.h"
#include "tokenize/tokenizer.h"

namespace wm::evaluate {
namespace fs = std::filesystem;
namespace {

// Adds one clip's per-step scores to the table under `kind`.
void AddScores(ScoreTable& t, const std::string& kind,
               const std::map<std::string, std::vector<double>>& scores, int64_t horizon) {
  for (const auto& [metric, values] : scores) {
    t.per_episode[kind][metric].push_back(FiniteMean(values));
    auto& steps = t.per_step[kind][metric];
    steps.resize(static_cast<size_t>(std::max<int64_t>(horizon, steps.size())));
    for (size_t s = 0; s < values.size(); ++s) steps[s].push_back(values[s]);
  }
}

MeanCi Whole(const metrics::Estimate& e, int64_t n) { return {e.value, e.ci_low, e.ci_high, n}; }

// Value metrics of one rollout mode: summary entries, per-episode return error, values.csv rows.
std::string AddValues(ScoreTable& t, const std::string& checkpoint, const std::string& mode,
                      const std::vector<metrics::EpisodeReturn>& returns, int resamples,
                      uint64_t seed) {
  metrics::ValueMetrics v =
      metrics::ComputeValueMetrics(returns, {.resamples = resamples, .seed = seed});
  const auto policies = static_cast<int64_t>(v.policies.size());
  auto& whole = t.whole_set[mode];
  whole["value_gap"] = Whole(v.value_gap, policies);
  whole["pearson"] = Whole(v.policy_correlation.pearson, policies);
  whole["spearman"] = Whole(v.policy_correlation.spearman, policies);
  whole["kendall"] = Whole(v.policy_correlation.kendall_tau_b, policies);
  whole["ranking_accuracy"] = Whole(v.pairwise_accuracy, policies);
  for (const auto& r : returns) {
    t.per_episode[mode]["return_error"].push_back(std::abs(r.model_return - r.real_return));
  }
  std::string rows;
  for (const auto& p : v.policies) {
    rows += checkpoint + "," + mode + "," + p.policy_id + "," + std::to_string(p.episodes) + "," +
            Cell(p.real_value.value) + "," + Cell(p.model_value.value) + "," +
            Cell(p.value_gap.value) + "\n";
  }
  return rows;
}

using AddClip = std::function<void(const std::string& kind, const Clip& pred)>;

// The baselines of one episode (`real`: frames 0..h): copy_last, and the tokenizer's
// tokenizer_recon and copy_last_tokens; a copy's delta_tpsnr is 0 when controllability is scored.
void AddBaselines(EpisodeRecord& rec, const Clip& real, const tokenize::Tokenizer& tok,
                  const tokens::TokenDataset& data, bool controllability, const AddClip& add_clip) {
  const int64_t h = rec.steps;
  add_clip("copy_last", RepeatFrame(real, 0, h));
  std::vector<int64_t> true_tokens(static_cast<size_t>((h + 1) * data.tokens_per_frame()));
  data.CopyTokens(rec.episode, 0, h + 1, true_tokens.data());
  const Clip given = SubClip(real, 0, 1);
  // Frames 0..h in one batch, as `wm-tokenize decode` does: a batch of one frame rounds
  // differently on some CPUs (AMD EPYC without AVX-512), so copy_last_tokens' frame 0 decoded
  // alone could differ by a level from the frame a user decodes with the tool.
  const Clip decoded = DecodeClip(tok, true_tokens, 0, h + 1, given);
  add_clip("tokenizer_recon", SubClip(decoded, 1, h));
  add_clip("copy_last_tokens", RepeatFrame(decoded, 0, h));
  // A copy reads no action: with perturbed ones it is the same clip, ΔtPSNR 0 by construction,
  // the static reference beside plain's row (and in wm-report's vs copy_last).
  for (const char* copy : {"copy_last", "copy_last_tokens"}) {
    const auto& psnr = rec.scores[copy].at("psnr");
    if (controllability) rec.scores[copy]["delta_tpsnr"] = DeltaPsnr(psnr, psnr);
  }
}

// The model's rollouts of one episode: scores, controllability, return, contexts, the samples'
// disagreement; `first_samples` gets each rollout's sample 0 (for the videos).
void AddImagined(EpisodeRecord& rec, const ImaginedEpisode& imagined, const Clip& target,
                 const tokenize::Tokenizer& tok, const AddClip& add_clip,
                 std::map<std::string, Clip>& first_samples) {
  for (const auto& [kind, r] : imagined) {
    add_clip(kind, r.samples[0]);
    first_samples[kind] = r.samples[0];
    if (r.perturbed) {
      rec.scores[kind]["delta_tpsnr"] =
          DeltaPsnr(rec.scores[kind].at("psnr"), FramePsnr(target, *r.perturbed));
    }
    if (r.model_return) rec.model_return[kind] = *r.model_return;
    if (!r.contexts.empty()) rec.contexts[kind] = r.contexts;
    for (const auto& [signal, values] : r.uncertainty) rec.scores[kind][signal] = values;
    if (r.samples.size() >= 2) {
      rec.spread[kind] = SampleDisagreement(r.samples);
      rec.sample_mse[kind] = ScoreFrames(target, r.samples[0], tok).at("mse");
    }
  }
}

// Imagines and scores `episodes` (positions `positions` in the whole evaluated list, for
// the videos and strips): one record per episode, nothing aggregated yet.
std::vector<EpisodeRecord> ScoreEpisodes(
    const CheckpointUnderEval& checkpoint, const std::string& name, const std::string& dir,
    const tokenize::Tokenizer& tok, const tokens::TokenDataset& data,
    const shard::DatasetReader& shards, const std::vector<int64_t>& episodes,
    const std::vector<size_t>& positions, metrics::Lpips* lpips) {
  const EvalOptions& o = checkpoint.options;
  const std::string image_key = data.index().tokenizer.image_key;
  const RegionMasks masks(o.masks);
  const Imagination imagine = checkpoint.start(episodes);
  std::vector<EpisodeRecord> records;
  const RolloutExporter exporter(o, name, checkpoint.info.file, tok.checkpoint_sha256());
  std::optional<Progress> progress;
  if (o.show_progress) progress.emplace("score " + name, episodes.size(), "episodes");
  for (size_t i = 0; i < episodes.size(); ++i) {
    const tokens::TokenEpisode& e = data.episode(episodes[i]);
    const int64_t h = std::min(o.rollout.horizon, e.num_frames - 1);
    EpisodeRecord rec{.episode = episodes[i],
                      .policy_id = e.policy_id.empty() ? "unknown" : e.policy_id,
                      .steps = h};
    const Episode ep = shards.ReadEpisode(static_cast<size_t>(e.source_episode));
    const Clip real = RealClip(ep, image_key, tok.image_size(), h + 1);
    const Clip target = SubClip(real, 1, h);
    std::vector<metrics::seg::RegionMap> maps;
    if (masks.enabled()) {
      maps = masks.Maps(ep, image_key, 1, h, tok.image_size(),
                        o.data_dir + "#episode " + std::to_string(e.source_episode));
    }
    std::map<std::string, Clip> pictures;  // every clip scored, for the strip and the export
    const AddClip add_clip = [&](const std::string& kind, const Clip& pred) {
      pictures[kind] = pred;
      if (kind != "real") {  // the real clip's scores would all be perfect
        rec.scores[kind] = ScoreFrames(target, pred, tok, lpips);
        rec.scores[kind]["moved_error_ratio"] = MovedErrorRatio(real, target, pred);
        if (!maps.empty()) rec.scores[kind].merge(ScoreRegions(target, pred, maps));
      }
      rec.clip_descriptors[kind] = tok.ClipDescriptor(pred.pixels.data(), pred.frames);
    };
    add_clip("real", target);
    AddBaselines(rec, real, tok, data, ScoresControllability(o), add_clip);
    // Imagined frames are 1..h; each carries its step's reward, as the logged frames do.
    for (int64_t s = 1; s <= h; ++s) rec.real_return += ep.rewards.at(s);
    const Clip given = SubClip(real, 0, 1);
    const EpisodeToImagine episode{
        .position = i, .episode = episodes[i], .given = given, .shard_episode = ep, .steps = h};
    std::map<std::string, Clip> first_samples;
    AddImagined(rec, imagine(episode), target, tok, add_clip, first_samples);
    if (static_cast<int>(positions[i]) < o.videos) {
      WriteClipVideo((fs::path(dir) / "videos").string(), episodes[i], target, first_samples);
    }
    if (static_cast<int>(positions[i]) < o.strips) {
      WriteEpisodeStrip((fs::path(dir) / "strips").string(), episodes[i], real, pictures);
    }
    exporter.Write(episodes[i], e.source_episode, ep, real, pictures);
    records.push_back(std::move(rec));
    if (progress) progress->Add(1);
  }
  if (progress) progress->Finish();
  return records;
}

// contexts.csv: the frames and actions the model was given at every step of sample 0.
std::string ContextsCsv(const std::string& name, const std::vector<RolloutMode>& modes,
                        const std::vector<EpisodeRecord>& records, int64_t action_dim) {
  std::string csv = "checkpoint,rollout,episode,step,slot,frame";
  for (int64_t d = 0; d < action_dim; ++d) csv += ",a" + std::to_string(d);
  csv += "\n";
  for (RolloutMode mode : modes) {
    for (const EpisodeRecord& rec : records) {
      const auto rows = rec.contexts.find(RolloutName(mode));  // none for a motion model
      if (rows == rec.contexts.end()) continue;
      for (const auto& row : rows->second) {
        const auto step = static_cast<int64_t>(row[0]) + 1;  // from 1, as in per_step.csv
        csv += name + "," + RolloutName(mode) + "," + std::to_string(rec.episode) + "," +
               std::to_string(step) + "," + std::to_string(static_cast<int64_t>(row[1])) + "," +
               std::to_string(static_cast<int64_t>(row[2]));
        for (size_t i = 3; i < row.size(); ++i) csv += "," + Cell(row[i]);
        csv += "\n";
      }
    }
  }
  return csv;
}

// The report of one checkpoint from the records of every evaluated episode, in episode order.
// `checkpoint` is the path given for it (the manifest records its basename).
void WriteReport(const EvalOptions& o, const std::string& name, const std::string& checkpoint,
                 const std::string& dir, const std::vector<EpisodeRecord>& records,
                 const CheckpointInfo& info, const tokenize::Tokenizer& tok,
                 const tokens::TokenDataset& data, const shard::DatasetReader& shards) {
  ScoreTable t;
  std::map<std::string, metrics::FeatureSet> clips;
  std::map<RolloutMode, std::vector<metrics::EpisodeReturn>> returns;
  std::map<RolloutMode, std::pair<std::vector<double>, std::vector<double>>> uncertainty;
  for (const EpisodeRecord& rec : records) {
    t.episodes.push_back(rec.episode);
    t.policy_ids.push_back(rec.policy_id);
    for (const auto& [kind, scores] : rec.scores) AddScores(t, kind, scores, rec.steps);
    for (const auto& [kind, d] : rec.clip_descriptors) {
      clips[kind].dim = static_cast<int64_t>(d.size());
      clips[kind].rows += 1;
      clips[kind].values.insert(clips[kind].values.end(), d.begin(), d.end());
    }
    for (RolloutMode mode : o.modes) {
      const std::string kind = RolloutName(mode);
      // Value metrics need a reward head (a motion model has none: no value rows).
      if (const auto r = rec.model_return.find(kind); r != rec.model_return.end()) {
        returns[mode].push_back(
            {std::to_string(rec.episode), rec.policy_id, rec.real_return, r->second});
      }
      if (!rec.spread.count(kind)) continue;
      const auto& spread = rec.spread.at(kind);
      const auto& mse = rec.sample_mse.at(kind);
      t.per_episode[kind]["uncertainty"].push_back(FiniteMean(spread));
      uncertainty[mode].first.insert(uncertainty[mode].first.end(), spread.begin(), spread.end());
      uncertainty[mode].second.insert(uncertainty[mode].second.end(), mse.begin(), mse.end());
    }
  }
  for (const auto& [kind, set] : clips) {
    if (kind == "real") continue;
    // A Gaussian fit needs two clips; one episode leaves fvd_style undefined (empty cell).
    const double fvd = set.rows >= 2 ? metrics::FrechetDistance(clips["real"], set) : NAN;
    t.whole_set[kind]["fvd_style"] = {fvd, NAN, NAN, set.rows};
  }
  std::string values = "checkpoint,rollout,policy_id,n_episodes,real_value,model_value,value_gap\n";
  for (RolloutMode mode : o.modes) {
    if (!returns[mode].empty()) {
      values += AddValues(t, name, RolloutName(mode), returns[mode], o.resamples, o.rollout.seed);
    }
    if (!uncertainty[mode].first.empty()) {
      t.whole_set[RolloutName(mode)]["uncertainty_error_corr"] = {
          metrics::Pearson(uncertainty[mode].first, uncertainty[mode].second), NAN, NAN,
          static_cast<int64_t>(uncertainty[mode].first.size())};
    }
  }
  if (!o.retrace_ks.empty()) {  // before the summary, which gets the signals' scores
    WriteFileAtomically((fs::path(dir) / "uncertainty.csv").string(),
                        AddUncertaintyScores(t, name, records));
  }
  WriteStripOverview((fs::path(dir) / "strips").string(), t.episodes, o.strips, tok.image_size());
  WriteScoreCsvs(dir, name, t, o.resamples, o.rollout.seed);
  WriteFileAtomically((fs::path(dir) / "values.csv").string(), values);
  WriteFileAtomically((fs::path(dir) / "contexts.csv").string(),
                      ContextsCsv(name, o.modes, records, data.action_dim()));
  WriteEvalManifest(dir, name, checkpoint, o, info, tok, data, shards);
}

// What every part of one report must share: settings, checkpoint, tokenizer, data, split.
nlohmann::json PartIdentity(const EvalOptions& o, const std::string& checkpoint_file,
                            const tokenize::Tokenizer& tok, const tokens::TokenDataset& data,
                            const std::vector<int64_t>& episodes) {
  nlohmann::json parts = nlohmann::json::array();
  for (const auto& p : data.index().parts) parts.push_back(p.sha256);
  return {{"eval_config", EvalConfigJson(o)},
          {"checkpoint_sha256", Sha256File(checkpoint_file)},
          {"tokenizer_sha256", tok.checkpoint_sha256()},
          {"token_parts_sha256", parts},
          {"episodes", episodes},
          {"num_shards", o.num_shards}};
}

// What every checkpoint is scored on: the data, and this job's share of the evaluated episodes.
struct EvalInputs {
  const tokens::TokenDataset& data;
  const tokenize::Tokenizer& tok;
  const shard::DatasetReader& shards;
  std::vector<int64_t> episodes;  // every evaluated episode
  std::vector<int64_t> mine;      // this shard job's, at `positions` in `episodes`
  std::vector<size_t> positions;
  metrics::Lpips* lpips = nullptr;
};

// Scores checkpoint `c` and writes its report, or this job's part of a sharded one (the job that
// completes the set writes the report). Returns the report directory, "" while parts are missing.
std::string EvaluateCheckpoint(const EvalOptions& all, size_t c, const EvalInputs& in) {
  const std::string name = ReportName(all, c);
  std::string dir = (fs::path(all.out_dir) / name).string();
  // Loading checks that the checkpoint fits the data, so a misfit leaves no directory behind.
  const CheckpointUnderEval checkpoint = LoadCheckpointUnderEval(all, c, name, in.tok, in.data);
  fs::create_directories(dir);
  // manifest.json is written last and marks a complete report: a killed run leaves none, so
  // wm-report refuses the folder instead of mixing old and new files.
  fs::remove(fs::path(dir) / "manifest.json");
  const EvalOptions& o = checkpoint.options;
  auto score = [&] {
    return ScoreEpisodes(checkpoint, name, dir, in.tok, in.data, in.shards, in.mine, in.positions,
                         in.lpips);
  };
  auto write = [&](const std::vector<EpisodeRecord>& records) {
    WriteReport(o, name, all.checkpoints[c], dir, records, checkpoint.info, in.tok, in.data,
                in.shards);
  };
  if (o.num_shards == 1) {
    write(score());
    return dir;
  }
  const nlohmann::json identity =
      PartIdentity(o, checkpoint.info.file, in.tok, in.data, in.episodes);
  const std::string part_path = PartPath(dir, o.shard_index, o.num_shards);
  if (fs::exists(part_path) && ReadEvalPart(part_path).identity == identity) {
    spdlog::info("{}: part {} of {} already scored", name, o.shard_index, o.num_shards);
  } else {
    fs::create_directories(fs::path(part_path).parent_path());
    WriteEvalPart(part_path, {identity, o.shard_index, score()});
  }
  // The job that completes the set writes the report (several at once write the same bytes).
  if (auto records = GatherParts(dir, identity, in.episodes, o.num_shards)) {
    write(*records);
    return dir;
  }
  spdlog::info("{}: waiting for the other parts in {}", name,
               fs::path(part_path).parent_path().string());
  return "";
}

}  // namespace

std::vector<std::string> EvaluateCheckpoints(const EvalOptions& o) {
  Check(o.num_shards >= 1 && o.shard_index >= 0 && o.shard_index < o.num_shards,
        "--shard-index must be in [0, --num-shards)", {.key = "--shard-index"});
  tokens::TokenDataset data(o.tokens_dir);
  tokenize::Tokenizer tok(o.tokenizer, o.device);
  shard::DatasetReader shards(o.data_dir);
  CheckInputsBelongTogether(data, tok, shards);
  for (RolloutMode mode : o.modes) CheckRolloutModeFits(mode, data);
  std::vector<int64_t> episodes, mine;
  std::vector<size_t> positions;
  for (int64_t k = 0; k < data.num_episodes(); ++k) {
    if (o.max_episodes > 0 && k >= o.max_episodes) break;
    if (static_cast<int>(episodes.size() % o.num_shards) == o.shard_index) {
      mine.push_back(k);
      positions.push_back(episodes.size());
    }
    episodes.push_back(k);
  }
  Check(!episodes.empty(), "no episodes to evaluate", {.file = o.tokens_dir});
  std::optional<metrics::Lpips> lpips;
  if (!o.lpips_weights.empty()) lpips.emplace(o.lpips_weights, o.device);
  const EvalInputs in{data, tok, shards, episodes, mine, positions, lpips ? &*lpips : nullptr};
  std::vector<std::string> written;
  for (size_t c = 0; c < o.checkpoints.size(); ++c) {
    if (std::string dir = EvaluateCheckpoint(o, c, in); !dir.empty()) written.push_back(dir);
  }
  return written;
}

}  // namespace wm::evaluate
