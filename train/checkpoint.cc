#include "train/checkpoint.h"

#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "core/tensor_archive.h"
#include "tokenize/module_archive.h"
#include "tokenize/trainer.h"

namespace wm::train {
namespace fs = std::filesystem;

nlohmann::json MetaToJson(const CheckpointMeta& m) {
  return {{"step", m.step},
          {"adamw_step", m.adamw_step},
          {"config", m.config},
          {"config_hash", m.config_hash},
          {"action_norms", m.action_norms},
          {"tokenizer", m.tokenizer},
          {"rng", m.rng},
          {"reward_target", m.reward_target},
          {"model", "wm-dynamics"}};
}

CheckpointMeta MetaFromJson(const nlohmann::json& j, const std::string& file) {
  try {
    CheckpointMeta m;
    Check(j.value("model", "") == "wm-dynamics", "not a wm-train dynamics checkpoint",
          {.file = file, .key = "meta.model"});
    m.step = j.at("step").get<int64_t>();
    m.adamw_step = j.at("adamw_step").get<int64_t>();
    m.config = j.at("config");
    m.config_hash = j.at("config_hash").get<std::string>();
    m.action_norms = j.at("action_norms");
    m.tokenizer = j.at("tokenizer");
    m.rng = j.at("rng");
    m.reward_target = j.value("reward_target", "previous_step");
    return m;
  } catch (const nlohmann::json::exception& e) {
    throw Error("bad checkpoint meta: " + std::string(e.what()), {.file = file});
  }
}

void SaveCheckpoint(const std::string& run_dir, WorldModel& model, tokenize::AdamW& adamw,
                    const CheckpointMeta& meta, const nlohmann::json& data) {
  TensorArchiveWriter w;
  tokenize::AddModule(w, "model/", *model);
  const auto& params = adamw.parameters();
  for (size_t i = 0; i < params.size(); ++i) {
    tokenize::AddTensor(w, "adamw/exp_avg/" + params[i].first, adamw.exp_avg()[i]);
    tokenize::AddTensor(w, "adamw/exp_avg_sq/" + params[i].first, adamw.exp_avg_sq()[i]);
  }
  w.SetMeta(MetaToJson(meta));
  w.Write((fs::path(run_dir) / kCheckpointFile).string());  // atomic
  WriteManifest(run_dir, meta, data);
}

void WriteManifest(const std::string& run_dir, const CheckpointMeta& meta,
                   const nlohmann::json& data) {
  const std::string path = (fs::path(run_dir) / kCheckpointFile).string();
  nlohmann::json manifest =
      MakeProvenance("wm-train", meta.config, {{"libtorch", tokenize::TorchVersion()}});
  manifest["step"] = meta.step;
  manifest["checkpoint"] = {
      {"file", kCheckpointFile}, {"sha256", Sha256File(path)}, {"format", kTensorArchiveFormat}};
  manifest["data"] = data;
  manifest["tokenizer"] = meta.tokenizer;
  manifest["action_norms"] = meta.action_norms;
  manifest["rng"] = meta.rng;
  manifest["reward_target"] = meta.reward_target;
  WriteFileAtomically((fs::path(run_dir) / kManifestFile).string(), manifest.dump(2) + "\n");
}

CheckpointMeta ReadCheckpointMeta(const std::string& path) {
  TensorArchiveReader r(path);
  return MetaFromJson(r.meta(), path);
}

CheckpointMeta LoadCheckpoint(const std::string& path, WorldModel& model, tokenize::AdamW* adamw,
                              const nlohmann::json* expected_config) {
  TensorArchiveReader r(path);
  CheckpointMeta meta = MetaFromJson(r.meta(), path);
  try {
    if (expected_config != nullptr) {
      CheckResumeConfig(meta.config_hash, ConfigToJson(ConfigFromJson(meta.config)),
                        *expected_config);
    }
    tokenize::LoadModule(r, "model/", *model);
    if (adamw) {
      const auto& params = adamw->parameters();
      for (size_t i = 0; i < params.size(); ++i) {
        tokenize::LoadTensor(r, "adamw/exp_avg/" + params[i].first, adamw->exp_avg()[i]);
        tokenize::LoadTensor(r, "adamw/exp_avg_sq/" + params[i].first, adamw->exp_avg_sq()[i]);
      }
      adamw->set_step_count(meta.adamw_step);
    }
  } catch (const Error& e) {
    throw e.WithFile(path);
  }
  return meta;
}

}  // namespace wm::train
