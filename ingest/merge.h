#pragma once
// Joins the dataset directories written by `wm-ingest --shard-index i --num-shards n` jobs
// (in part order) into one dataset: shards renumbered, indexes combined, action statistics
// recomputed over all episodes. Episode order equals a single-job run's.
#include <string>
#include <vector>

#include "core/shard/dataset_index.h"

namespace wm::ingest {

shard::DatasetIndex MergeDatasets(const std::vector<std::string>& parts, const std::string& output);

}  // namespace wm::ingest
