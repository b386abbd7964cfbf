#include "train/checkpoint.h"

#include "core/error.h"
#include "core/provenance.h"
#include "core/tensor_archive.h"
#include "trainkit/init_from.h"
#include "trainkit/module_archive.h"

namespace wm::train {

nlohmann::json MetaToJson(const CheckpointMeta& m) {
  nlohmann::json j = {{"step", m.step},
                      {"adamw_step", m.adamw_step},
                      {"config", m.config},
                      {"config_hash", m.config_hash},
                      {"action_norms", m.action_norms},
                      {"tokenizer", m.tokenizer},
                      {"rng", m.rng},
                      {"reward_target", m.reward_target},
                      {"model", "wm-dynamics"}};
  if (!m.init_from.is_null()) j["init_from"] = m.init_from;
  return j;
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
    m.init_from = j.value("init_from", nlohmann::json());
    return m;
  } catch (const nlohmann::json::exception& e) {
    throw Error("bad checkpoint meta: " + std::string(e.what()), {.file = file});
  }
}

void SaveCheckpoint(const trainkit::RunDir& run, WorldModel& model, const trainkit::AdamW& adamw,
                    const CheckpointMeta& meta, const nlohmann::json& data) {
  TensorArchiveWriter w;
  trainkit::AddModule(w, "model/", *model);
  trainkit::AddAdamW(w, adamw);
  w.SetMeta(MetaToJson(meta));
  run.WriteCheckpoint(w, [&] { return Manifest(run, meta, data); });
}

nlohmann::json Manifest(const trainkit::RunDir& run, const CheckpointMeta& meta,
                        const nlohmann::json& data) {
  nlohmann::json manifest = run.Manifest("wm-train", meta.config, meta.step, meta.init_from);
  manifest["data"] = data;
  manifest["tokenizer"] = meta.tokenizer;
  manifest["action_norms"] = meta.action_norms;
  manifest["rng"] = meta.rng;
  manifest["reward_target"] = meta.reward_target;
  return manifest;
}

CheckpointMeta ReadCheckpointMeta(const std::string& path) {
  TensorArchiveReader r(path);
  return MetaFromJson(r.meta(), path);
}

CheckpointMeta LoadCheckpoint(const std::string& path, WorldModel& model, trainkit::AdamW* adamw,
                              const nlohmann::json* expected_config) {
  TensorArchiveReader r(path);
  CheckpointMeta meta = MetaFromJson(r.meta(), path);
  try {
    if (expected_config != nullptr) {
      CheckResumeConfig(
          meta.config_hash,
          trainkit::HashedConfig(ConfigToJson(ConfigFromJson(meta.config)), meta.init_from),
          *expected_config);
    }
    trainkit::LoadModule(r, "model/", *model);
    if (adamw) trainkit::LoadAdamW(r, meta.adamw_step, *adamw);
  } catch (const Error& e) {
    throw e.WithFile(path);
  }
  return meta;
}

}  // namespace wm::train
