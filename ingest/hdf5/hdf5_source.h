#pragma once
// Reads robomimic / LIBERO demonstration files: HDF5 with data/demo_N/{actions, rewards, dones,
// obs/<camera>}. docs/hdf5-layout.md lists every dataset read and the dtype rules. The HDF5 C
// headers stay inside hdf5_source.cc.
#include <string>
#include <vector>

#include "core/child_process.h"
#include "ingest/episode_source.h"

namespace wm::ingest {

// libhdf5 1.10 can crash, allocate without bound or loop forever on a damaged file (most of its
// metadata has no checksum; tests/fuzz found all three). So each file listing and demo read runs
// in a child process under these limits, and a child that dies becomes a wm::Error naming the
// file and demo, which --on-error skip can skip (docs/failure-modes.md).
inline constexpr ChildLimits kDefaultHdf5ReadLimits{.memory_mb = 8192, .cpu_seconds = 600};
struct Hdf5Isolation {
  bool enabled = true;  // false: read in this process (the fuzz target, whose sanitizers must
                        // see libhdf5's crashes)
  ChildLimits limits = kDefaultHdf5ReadLimits;
};

class Hdf5Source : public EpisodeSource {
 public:
  // `input`: one .hdf5 / .h5 file, or a directory searched recursively for them.
  // `camera`: the dataset under obs/ holding the RGB frames, uint8 [T, H, W, 3]. Empty: per demo,
  // the first existing of agentview_rgb, agentview_image, image, then the first key (sorted)
  // ending in _rgb or _image.
  // `depth`: read obs/<camera>_depth (uint16 [T, H, W] or [T, H, W, 1]) as the "depth" stream
  // when it exists; false never reads it (e.g. for files whose depth is stored as float).
  // `action_space`: of actions [T, D] (ingest::SetActions); empty: eef_delta when D is 7, else
  // other.
  explicit Hdf5Source(std::string input, std::string camera = "", bool depth = true,
                      Hdf5Isolation isolation = {}, std::string action_space = "");

  std::string format() const override { return "hdf5"; }
  // The file stem, or the directory name.
  std::string dataset_name() const override;
  // Files in path order, within a file demo_N by N. A file that cannot be opened or has no
  // data group is damaged: listed in `damaged` when given, thrown otherwise.
  std::vector<EpisodeRef> ListEpisodes(std::vector<shard::SkippedEpisode>* damaged) override;
  // ref.record is the demo number N. Isolated reads run in parallel child processes; in-process
  // ones are serialised on one process-wide mutex (Debian's libhdf5 is not thread-safe). PNG
  // encoding runs in this process, outside it.
  Episode Load(const EpisodeRef& ref) const override;
  nlohmann::json Describe() const override;

 private:
  std::string input_;
  std::string camera_;
  bool depth_;
  Hdf5Isolation isolation_;
  std::string action_space_;
};

}  // namespace wm::ingest
