#pragma once
// Checks a loaded episode before it is written: consistent lengths, finite numbers, images
// that decode to one shape. Errors name the key and step.
#include "core/episode.h"

namespace wm::ingest {

// `full_image_check`: decode every frame (catches corrupt JPEG/PNG); else first frame + magic.
void ValidateEpisode(Episode& episode, bool full_image_check);

}  // namespace wm::ingest
