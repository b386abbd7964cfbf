#pragma once
#include <memory>

#include "ingest/episode_source.h"
#include "ingest/ingest_options.h"

namespace wm::ingest {

// The EpisodeSource for options.format; throws wm::Error for an unknown format.
std::unique_ptr<EpisodeSource> OpenSource(const IngestOptions& options);

}  // namespace wm::ingest
