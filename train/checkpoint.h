#pragma once
// Dynamics checkpoints: RUN_DIR/checkpoint.wmt (wmkit tensor archive: "model/<param>",
// "adamw/exp_avg/<param>", "adamw/exp_avg_sq/<param>"; header meta below) and the manifest
// RUN_DIR/checkpoint.json. Both written atomically, archive first. Internal header (torch).
#include <nlohmann/json.hpp>
#include <string>

#include "train/config.h"
#include "train/world_model.h"
#include "trainkit/adamw.h"
#include "trainkit/run_dir.h"

namespace wm::train {

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
  // --init-from: the parent (trainkit::Parent::record), also hashed into config_hash; null when
  // the run started from a random init (and then absent from the meta and checkpoint.json).
  nlohmann::json init_from;
};

nlohmann::json MetaToJson(const CheckpointMeta& meta);
CheckpointMeta MetaFromJson(const nlohmann::json& j, const std::string& file);

// Writes checkpoint.wmt and then checkpoint.json into `run`. `data` is the manifest's data
// provenance (SegmentSampler::DataProvenance).
void SaveCheckpoint(const trainkit::RunDir& run, WorldModel& model, const trainkit::AdamW& adamw,
                    const CheckpointMeta& meta, const nlohmann::json& data);

// checkpoint.json for the checkpoint.wmt in `run`, whose meta is `meta`. A kill between the
// archive and its manifest leaves the manifest describing the previous archive, so resuming
// writes this again (trainkit::RunDir::Resumed) for the archive it resumed from.
nlohmann::json Manifest(const trainkit::RunDir& run, const CheckpointMeta& meta,
                        const nlohmann::json& data);

// Restores model, AdamW moments (when `adamw` is given) and returns the meta. With
// `expected_config` (resuming: trainkit::HashedConfig of the config and init_from) refuses a
// checkpoint trained with another config or parent, naming the keys that differ.
CheckpointMeta LoadCheckpoint(const std::string& path, WorldModel& model, trainkit::AdamW* adamw,
                              const nlohmann::json* expected_config = nullptr);

// Reads only the meta (to build the model before loading it).
CheckpointMeta ReadCheckpointMeta(const std::string& path);

}  // namespace wm::train
