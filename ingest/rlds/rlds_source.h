#pragma once
// EpisodeSource over a TFDS RLDS directory: one tf.train.Example per episode, mapped to the
// canonical episode by a DatasetMapping (configs/datasets/<name>.yaml).
#include <memory>

#include "ingest/episode_source.h"
#include "ingest/rlds/dataset_mapping.h"
#include "ingest/rlds/tfds_dataset.h"

namespace wm::ingest {

class RldsSource : public EpisodeSource {
 public:
  // `mapping_file` empty: looked up as <configs_dir>/datasets/<dataset name>.yaml.
  RldsSource(const std::string& path, const std::string& split, const std::string& mapping_file,
             const std::string& configs_dir);
  std::string format() const override { return "rlds"; }
  std::string dataset_name() const override { return dataset_.name; }
  std::vector<EpisodeRef> ListEpisodes(std::vector<shard::SkippedEpisode>* damaged) override;
  Episode Load(const EpisodeRef& ref) const override;
  nlohmann::json Describe() const override;

  // Maps one parsed Example (exposed for tests).
  Episode MapExample(const std::string& bytes) const;

 private:
  rlds::TfdsDataset dataset_;
  rlds::DatasetMapping mapping_;
  int64_t action_width_ = 0;  // the action parts' widths summed
  std::string split_;
};

}  // namespace wm::ingest
