#include "ingest/open_source.h"

#include "core/error.h"
#include "core/paths.h"
#include "ingest/folder/folder_source.h"
#include "ingest/hdf5/hdf5_source.h"
#include "ingest/lerobot/lerobot_source.h"
#include "ingest/rlds/rlds_source.h"

namespace wm::ingest {

std::unique_ptr<EpisodeSource> OpenSource(const IngestOptions& o) {
  if (o.format == "rlds") {
    return std::make_unique<RldsSource>(
        o.input, o.split, o.mapping, o.configs_dir.empty() ? DefaultConfigsDir() : o.configs_dir);
  }
  if (o.format == "hdf5") {
    return std::make_unique<Hdf5Source>(o.input, o.camera, o.hdf5_depth,
                                        Hdf5Isolation{.limits = o.hdf5_limits}, o.action_space);
  }
  if (o.format == "folder") return std::make_unique<FolderSource>(o.input, o.action_space);
  if (o.format == "lerobot") {
    return std::make_unique<LeRobotSource>(
        o.input, o.camera, o.mapping, o.configs_dir.empty() ? DefaultConfigsDir() : o.configs_dir);
  }
  throw Error("unknown --format '" + o.format + "' (expected rlds, hdf5, folder or lerobot)");
}

}  // namespace wm::ingest
