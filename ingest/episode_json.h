#pragma once
// An episode as JSON, the same fields scripts/wmshard.py prints, so the two readers can be
// compared key by key (images as SHA-256 of their encoded bytes).
#include <nlohmann/json.hpp>

#include "core/episode.h"

namespace wm::ingest {

nlohmann::json EpisodeToJson(const Episode& episode);

}  // namespace wm::ingest
