#pragma once
// `wm-ingest --suggest-mapping`: a first guess at the mapping file of a dataset that has none,
// from its metadata alone (RLDS: features.json / dataset_info.json; LeRobot: meta/info.json).
// The YAML is in the format the loaders read (rlds/dataset_mapping.h, lerobot/lerobot_mapping.h),
// so it can be saved and used as it is; comments mark the guesses to check
// (docs/dataset-mapping.md, docs/lerobot-mapping.md, "Suggesting a mapping").
#include <string>

namespace wm::ingest {

// `format` is "rlds" or "lerobot"; `input` as for --input. Throws wm::Error for other formats
// and for metadata that cannot be read.
std::string SuggestMapping(const std::string& format, const std::string& input);

}  // namespace wm::ingest
