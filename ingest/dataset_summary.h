#pragma once
#include <string>

#include "core/shard/dataset_index.h"

namespace wm::ingest {

// A few human-readable lines about a dataset: counts, size, streams, action statistics,
// skipped episodes and provenance (`wm-shard info`).
std::string FormatSummary(const shard::DatasetIndex& index);

}  // namespace wm::ingest
