#pragma once
// The interface every input format implements (RLDS, HDF5, image folders): list the episodes
// cheaply and in a fixed order, then load any of them, from any thread.
#include <memory>
#include <string>
#include <vector>

#include "core/episode.h"
#include "core/shard/dataset_index.h"

namespace wm::ingest {

struct EpisodeRef {
  std::string path;      // absolute or as given: what to open
  std::string rel_path;  // relative to the input root: what outputs record
  int64_t record = 0;    // record / demo / folder index within `path`
  uint64_t offset = 0;   // byte offset of the record, for formats that have one (TFRecord)
};

class EpisodeSource {
 public:
  virtual ~EpisodeSource() = default;
  virtual std::string format() const = 0;        // "rlds", "hdf5", "folder"
  virtual std::string dataset_name() const = 0;  // used when --dataset is not given
  // Every episode in a deterministic order. A damaged container (e.g. a truncated TFRecord
  // file) throws wm::Error, unless `damaged` is given: then what can be read is listed and the
  // damage is appended there (for --on-error skip).
  virtual std::vector<EpisodeRef> ListEpisodes(std::vector<shard::SkippedEpisode>* damaged) = 0;
  // Loads one episode; thread-safe. Throws wm::Error naming file, record and key.
  virtual Episode Load(const EpisodeRef& ref) const = 0;
  // The source's settings that shape the output (mapping etc.), for the config hash.
  virtual nlohmann::json Describe() const = 0;
};

}  // namespace wm::ingest
