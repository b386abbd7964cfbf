#include "evaluate/evaluator.h"

#include <cmath>
#include <filesystem>
#include <optional>
#include <spdlog/spdlog.h>

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
#include "evaluate/manifest.h"
#include "evaluate/motion_scores.h"
#include "evaluate/rollout_export.h"
#include "metrics/frechet.h"
#include "metrics/lpips/lpips.h"
#include "metrics/value/correlation.h"
#include "metrics/value/value_metrics.h"
#include "tokenize/tokenizer.h"
#include "train/dynamics_model.h"

namespace wm::evaluate {
namespace fs = std::filesystem;
namespace {

double FiniteMean(const std::vector<double>& v) {
  double s = 0;
  int64_t n = 0;
  for (double x : v) {
    if (std::isfinite(x)) s += x, ++n;
  }
  return n ? s / n : NAN;
}

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

// Rolls out and scores `episodes` (positions `positions` in the whole evaluated list, for
// the videos): one record per episode, nothing aggregated yet.
std::vector<EpisodeRecord> ScoreEpisodes(const EvalOptions& o, const std::string& name,
                                         const std::string& dir,
                                         const train::DynamicsModel& model,
                                         const tokenize::Tokenizer& tok,
                                         const tokens::TokenDataset& data,
                                         const shard::DatasetReader& shards,
                                         const std::vector<int64_t>& episodes,
                                         const std::vector<size_t>& positions,
                                         metrics::Lpips* lpips) {
  const std::string image_key = data.index().tokenizer.image_key;
  const RegionMasks masks(o.masks);
  std::map<RolloutMode, std::vector<EpisodeRollout>> rollouts;
  for (RolloutMode mode : o.modes) rollouts[mode] = Rollout(model, data, episodes, mode, o.rollout);
  std::vector<EpisodeRollout> perturbed;  // controllability: plain with perturbed actions
  if (rollouts.contains(RolloutMode::kPlain) && o.controllability != Perturbation::kOff) {
    perturbed = PerturbedRollout(model, data, episodes, o.rollout, o.controllability);
  }
  std::vector<EpisodeRecord> records;
  const RolloutExporter exporter(o, name, model.checkpoint_file(), tok.checkpoint_sha256());
  std::optional<Progress> progress;
  if (o.show_progress) progress.emplace("score " + name, episodes.size(), "episodes");
  for (size_t i = 0; i < episodes.size(); ++i) {
    const tokens::TokenEpisode& e = data.episode(episodes[i]);
    const int64_t h = rollouts.begin()->second[i].steps;
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
    auto add_clip = [&](const std::string& kind, const Clip& pred) {
      pictures[kind] = pred;
      if (kind != "real") {  // the real clip's scores would all be perfect
        rec.scores[kind] = ScoreFrames(target, pred, tok, lpips);
        rec.scores[kind]["moved_error_ratio"] = MovedErrorRatio(real, target, pred);
        if (!maps.empty()) rec.scores[kind].merge(ScoreRegions(target, pred, maps));
      }
      rec.clip_descriptors[kind] = tok.ClipDescriptor(pred.pixels.data(), pred.frames);
    };
    add_clip("real", target);
    add_clip("copy_last", RepeatFrame(real, 0, h));
    std::vector<int64_t> true_tokens(static_cast<size_t>((h + 1) * data.tokens_per_frame()));
    data.CopyTokens(episodes[i], 0, h + 1, true_tokens.data());
    const Clip given = SubClip(real, 0, 1);
    add_clip("tokenizer_recon", DecodeClip(tok, true_tokens, 1, h, given));
    add_clip("copy_last_tokens", RepeatFrame(DecodeClip(tok, true_tokens, 0, 1, given), 0, h));
    // A copy reads no action: with perturbed ones it is the same clip, ΔtPSNR 0 by construction,
    // the static reference beside plain's row (and in wm-report's vs copy_last).
    for (const char* copy : {"copy_last", "copy_last_tokens"}) {
      const auto& psnr = rec.scores[copy].at("psnr");
      if (!perturbed.empty()) rec.scores[copy]["delta_tpsnr"] = DeltaPsnr(psnr, psnr);
    }
    // Imagined frames are 1..h; each carries its step's reward, as the logged frames do.
    for (int64_t s = 1; s <= h; ++s) rec.real_return += ep.rewards.at(s);
    std::map<std::string, Clip> first_samples;
    for (RolloutMode mode : o.modes) {
      const std::string kind = RolloutName(mode);
      const EpisodeRollout& r = rollouts[mode][i];
      std::vector<Clip> samples;
      for (const auto& s : r.tokens) samples.push_back(DecodeClip(tok, s, 1, h, given));
      add_clip(kind, samples[0]);
      first_samples[kind] = samples[0];
      if (mode == RolloutMode::kPlain && !perturbed.empty()) {
        rec.scores[kind]["delta_tpsnr"] =
            DeltaPsnr(rec.scores[kind].at("psnr"),
                      FramePsnr(target, DecodeClip(tok, perturbed[i].tokens[0], 1, h, given)));
      }
      double model_return = 0;
      for (int64_t s = 0; s < h; ++s) model_return += r.rewards[0][s];
      rec.model_return[kind] = model_return;
      for (size_t t = 0; t < r.contexts.size(); ++t) {
        for (size_t slot = 0; slot < r.contexts[t].size(); ++slot) {
          const ContextSlot& c = r.contexts[t][slot];
          std::vector<double> row = {static_cast<double>(t), static_cast<double>(slot),
                                     static_cast<double>(c.frame)};
          row.insert(row.end(), c.action.begin(), c.action.end());
          rec.contexts[kind].push_back(std::move(row));
        }
      }
      if (samples.size() >= 2) {
        rec.spread[kind] = SampleDisagreement(samples);
        rec.sample_mse[kind] = ScoreFrames(target, samples[0], tok).at("mse");
      }
    }
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
      for (const auto& row : rec.contexts.at(RolloutName(mode))) {
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
                 const train::DynamicsModel& model, const tokenize::Tokenizer& tok,
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
      returns[mode].push_back({std::to_string(rec.episode), rec.policy_id, rec.real_return,
                               rec.model_return.at(kind)});
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
    values += AddValues(t, name, RolloutName(mode), returns[mode], o.resamples, o.rollout.seed);
    if (!uncertainty[mode].first.empty()) {
      t.whole_set[RolloutName(mode)]["uncertainty_error_corr"] = {
          metrics::Pearson(uncertainty[mode].first, uncertainty[mode].second), NAN, NAN,
          static_cast<int64_t>(uncertainty[mode].first.size())};
    }
  }
  WriteStripOverview((fs::path(dir) / "strips").string(), t.episodes, o.strips,
                     tok.image_size());
  WriteScoreCsvs(dir, name, t, o.resamples, o.rollout.seed);
  WriteFileAtomically((fs::path(dir) / "values.csv").string(), values);
  WriteFileAtomically((fs::path(dir) / "contexts.csv").string(),
                      ContextsCsv(name, o.modes, records, data.action_dim()));
  WriteEvalManifest(dir, name, checkpoint, o, model, tok, data, shards);
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

std::string PartPath(const std::string& dir, int index, int count) {
  return (fs::path(dir) / "parts" /
          ("part-" + std::to_string(index) + "-of-" + std::to_string(count) + ".json"))
      .string();
}

// Every part's records in episode order once all `num_shards` parts exist; empty otherwise.
// Parts of other settings, checkpoints or data, and overlapping or missing episodes, are errors.
std::optional<std::vector<EpisodeRecord>> GatherParts(const std::string& dir,
                                                      const nlohmann::json& identity,
                                                      const std::vector<int64_t>& episodes,
                                                      int num_shards) {
  std::map<int64_t, EpisodeRecord> by_episode;
  for (int i = 0; i < num_shards; ++i) {
    const std::string path = PartPath(dir, i, num_shards);
    if (!fs::exists(path)) return std::nullopt;
    EvalPart part = ReadEvalPart(path);
    Check(part.identity == identity && part.shard_index == i,
          "part was written by a run with other settings, checkpoint or data than this one "
          "(remove the parts folder to start over)",
          {.file = path, .key = "identity"});
    for (EpisodeRecord& r : part.records) {
      const int64_t k = r.episode;
      Check(by_episode.emplace(k, std::move(r)).second,
            "episode " + std::to_string(k) + " is in more than one part", {.file = path});
    }
  }
  std::vector<EpisodeRecord> records;
  for (int64_t k : episodes) {
    auto it = by_episode.find(k);
    Check(it != by_episode.end(), "no part holds episode " + std::to_string(k), {.file = dir});
    records.push_back(std::move(it->second));
  }
  return records;
}

}  // namespace

std::unique_ptr<train::DynamicsModel> LoadModelFor(const EvalOptions& o,
                                                   const std::string& checkpoint,
                                                   const tokens::TokenDataset& data) {
  const std::string& dataset = data.index().dataset;
  return train::DynamicsModel::Load(
      checkpoint, o.device,
      train::DynamicsModel::HasActionDataset(checkpoint, dataset) ? dataset : "", o.threads);
}

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
  std::vector<std::string> written;
  for (size_t c = 0; c < o.checkpoints.size(); ++c) {
    const std::string name = ReportName(o, c);
    const std::string dir = (fs::path(o.out_dir) / name).string();
    fs::create_directories(dir);
    // manifest.json is written last and marks a complete report: a killed run leaves none, so
    // wm-report refuses the folder instead of mixing old and new files.
    fs::remove(fs::path(dir) / "manifest.json");
    auto model = LoadModelFor(o, o.checkpoints[c], data);
    if (o.rollout.samples >= 2 && model->DecodeTemperature(o.rollout.temperature) == 0) {
      spdlog::warn("{}: --samples {} with argmax decoding (temperature 0) imagines {} identical "
                   "rollouts: uncertainty is 0 and uncertainty_error_corr undefined; pass "
                   "--temperature > 0 to sample", name, o.rollout.samples, o.rollout.samples);
    }
    auto score = [&] {
      return ScoreEpisodes(o, name, dir, *model, tok, data, shards, mine, positions,
                           lpips ? &*lpips : nullptr);
    };
    if (o.num_shards == 1) {
      WriteReport(o, name, o.checkpoints[c], dir, score(), *model, tok, data, shards);
      written.push_back(dir);
      continue;
    }
    const nlohmann::json identity =
        PartIdentity(o, model->checkpoint_file(), tok, data, episodes);
    const std::string part_path = PartPath(dir, o.shard_index, o.num_shards);
    if (fs::exists(part_path) && ReadEvalPart(part_path).identity == identity) {
      spdlog::info("{}: part {} of {} already scored", name, o.shard_index, o.num_shards);
    } else {
      fs::create_directories(fs::path(part_path).parent_path());
      WriteEvalPart(part_path, {identity, o.shard_index, score()});
    }
    // The job that completes the set writes the report (several at once write the same bytes).
    if (auto records = GatherParts(dir, identity, episodes, o.num_shards)) {
      WriteReport(o, name, o.checkpoints[c], dir, *records, *model, tok, data, shards);
      written.push_back(dir);
    } else {
      spdlog::info("{}: waiting for the other parts in {}", name,
                   fs::path(part_path).parent_path().string());
    }
  }
  return written;
}

}  // namespace wm::evaluate
