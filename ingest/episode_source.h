#pragma once
// The interface every input format implements (RLDS, HDF5, image folders): list the episodes
// cheaply and in a fixed order, then load any of them, from any thread.
#include <memory>
#include <string>
#include <vector>

#include "core/episode.h"
#include "core/error.h"
#include "core/shard/dataset_index.h"

namespace wm::ingest {

struct EpisodeRef {
  std::string path;      // absolute or as given: what to open
  std::string rel_path;  // relative to the input root: what outputs record
  int64_t record = 0;    // record / demo / folder index within `path`
  uint64_t offset = 0;   // byte offset of the record, for formats that have one (TFRecord)
};

// Fills an episode's identity from its ref (key "<rel_path>#<record>") and, for T steps, the
// flags of a single-episode source: is_first at step 0, is_last at T-1, is_terminal at T-1 when
// `terminal`; discounts 1. Shared by the sources that have no per-step flags of their own.
void StartEpisode(Episode& episode, const EpisodeRef& ref);
void SetBoundaryFlags(Episode& episode, bool terminal);

// Sets the actions of a source without a mapping (HDF5, image folders), `width` values per step:
// their space is `requested` when given (--action-space), else eef_delta when 7 wide (the
// canonical Δxyz, Δrpy, gripper) and "other" otherwise. Throws wm::Error naming `where` when
// eef_delta is asked of another width.
void SetActions(Episode& episode, std::vector<float> actions, int64_t width,
                const std::string& requested, const ErrorContext& where);

class EpisodeSource {
 public:
  virtual ~EpisodeSource() = default;
  virtual std::string format() const = 0;        // "rlds", "hdf5", "folder", "lerobot"
  virtual std::string dataset_name() const = 0;  // used when --dataset is not given
  // Every episode in a deterministic order. A damaged container (e.g. a truncated TFRecord
  // file) throws wm::Error, unless `damaged` is given: then what can be read is listed and the
  // damage is appended there (for --on-error skip).
  virtual std::vector<EpisodeRef> ListEpisodes(std::vector<shard::SkippedEpisode>* damaged) = 0;
  // Episodes the input's own metadata lists whose files are not there (a partial download);
  // recorded in index.json's `skipped` in every --on-error mode. Valid after ListEpisodes.
  virtual std::vector<shard::SkippedEpisode> Absent() const { return {}; }
  // Loads one episode; thread-safe. Throws wm::Error naming file, record and key.
  virtual Episode Load(const EpisodeRef& ref) const = 0;
  // The source's settings that shape the output (mapping etc.), for the config hash.
  virtual nlohmann::json Describe() const = 0;
};

}  // namespace wm::ingest
