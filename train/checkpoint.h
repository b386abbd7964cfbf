#pragma once
// Dynamics checkpoints: RUN_DIR/checkpoint.wmt (wmkit tensor archive: "model/<param>",
// "adamw/exp_avg/<param>", "adamw/exp_avg_sq/<param>"; header meta below) and the manifest
// RUN_DIR/checkpoint.json. Both written atomically, archive first. Internal header (torch).
#include <nlohmann/json.hpp>
#include <string>

#include "core/paths.h"  // kCheckpointFile
#include "tokenize/adamw.h"
#include "train/config.h"
#include "train/world_model.h"

namespace wm::train {

inline constexpr const char* kManifestFile = "checkpoint.json";
inline constexpr const char* kRewardTargetFrame = "frame";

// What the archive's meta holds besides the tensors. The config and action statistics make the
// archive self-contained for the public model API (train/dynamics_model.h).
struct CheckpointMeta {
  int64_t step = 0, adamw_step = 0;
  nlohmann::json config;  // ConfigToJson
  std::string config_hash;
  nlohmann::json action_norms;  // {dataset: {mean, std}}
  nlohmann::json tokenizer;     // {checkpoint_sha256, config_hash, num_codes, grid_h, grid_w}
  nlohmann::json rng;           // counter-based: {"scheme", "seed"}
  // Which step the reward head of position j predicts: "frame" = step j (RLDS's reward logged
  // with frame j). Checkpoints without the key predicted step j-1 and never saw a final reward.
  std::string reward_target = kRewardTargetFrame;
};

nlohmann::json MetaToJson(const CheckpointMeta& meta);
CheckpointMeta MetaFromJson(const nlohmann::json& j, const std::string& file);

// Writes checkpoint.wmt and checkpoint.json into `run_dir`. `data` is the manifest's data
// provenance (SegmentSampler::DataProvenance).
void SaveCheckpoint(const std::string& run_dir, WorldModel& model, tokenize::AdamW& adamw,
                    const CheckpointMeta& meta, const nlohmann::json& data);

// Writes checkpoint.json for the checkpoint.wmt in `run_dir`, whose meta is `meta`. It is written
// after the archive, so a kill between the two leaves it describing the previous checkpoint:
// resuming calls this again to make it describe the archive it resumed from.
void WriteManifest(const std::string& run_dir, const CheckpointMeta& meta,
                   const nlohmann::json& data);

// Restores model, AdamW moments (when `adamw` is given) and returns the meta. With
// `expected_config` (resuming) refuses a checkpoint trained with another config, naming the keys
// that differ.
CheckpointMeta LoadCheckpoint(const std::string& path, WorldModel& model, tokenize::AdamW* adamw,
                              const nlohmann::json* expected_config = nullptr);

// Reads only the meta (to build the model before loading it).
CheckpointMeta ReadCheckpointMeta(const std::string& path);

}  // namespace wm::train
