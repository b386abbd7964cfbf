#pragma once
// The JSON metadata TFDS writes next to an RLDS dataset's TFRecords, reproduced key for key:
// features.json (FeaturesDict / Dataset / Tensor / Image / Text / Scalar nesting, in field
// order, 2-space indent) and dataset_info.json (sorted keys), both without a trailing newline.
#include <cstdint>
#include <string>
#include <vector>

namespace wm::tabletop {

// Every flattened key EncodeEpisode writes, sorted.
std::vector<std::string> TabletopFeatureKeys();

// features.json for a tabletop dataset rendered at size x size.
std::string TabletopFeaturesJson(int size);

struct SplitInfo {
  std::string name;                     // "train", "val"
  uint64_t num_bytes = 0;               // total size of the split's TFRecord files
  std::vector<uint64_t> shard_lengths;  // examples (episodes) per shard file, in file order
};

// dataset_info.json; shard files are named by TfdsShardFileName.
std::string DatasetInfoJson(const std::string& name, const std::string& version,
                            const std::string& description, const std::vector<SplitInfo>& splits);

// "{DATASET}-{SPLIT}.{FILEFORMAT}-{SHARD_X_OF_Y}": `name-train.tfrecord-00000-of-00002`.
std::string TfdsShardFileName(const std::string& name, const std::string& split, int shard,
                              int num_shards);

}  // namespace wm::tabletop
