#pragma once
// Reads robomimic / LIBERO demonstration files: HDF5 with data/demo_N/{actions, rewards, dones,
// obs/<camera>}. docs/hdf5-layout.md lists every dataset read and the dtype rules. The HDF5 C
// headers stay inside hdf5_source.cc.
#include <string>
#include <vector>

#include "ingest/episode_source.h"

namespace wm::ingest {

class Hdf5Source : public EpisodeSource {
 public:
  // `input`: one .hdf5 / .h5 file, or a directory searched recursively for them.
  // `camera`: the dataset under obs/ holding the RGB frames, uint8 [T, H, W, 3]. Empty: per demo,
  // the first existing of agentview_rgb, agentview_image, image, then the first key (sorted)
  // ending in _rgb or _image.
  // `depth`: read obs/<camera>_depth (uint16 [T, H, W] or [T, H, W, 1]) as the "depth" stream
  // when it exists; false never reads it (e.g. for files whose depth is stored as float).
  explicit Hdf5Source(std::string input, std::string camera = "", bool depth = true);

  std::string format() const override { return "hdf5"; }
  // The file stem, or the directory name.
  std::string dataset_name() const override;
  // Files in path order, within a file demo_N by N. A file that cannot be opened or has no
  // data group is damaged: listed in `damaged` when given, thrown otherwise.
  std::vector<EpisodeRef> ListEpisodes(std::vector<shard::SkippedEpisode>* damaged) override;
  // ref.record is the demo number N. HDF5 calls are serialised on one process-wide mutex
  // (Debian's libhdf5 is not thread-safe); PNG encoding runs outside it.
  Episode Load(const EpisodeRef& ref) const override;
  nlohmann::json Describe() const override;

 private:
  std::string input_;
  std::string camera_;
  bool depth_;
};

// A crash inside libhdf5 on a damaged file exits 1 with "<tool>: error: libhdf5 crashed ...
// reading FILE, demo K" instead of a bare segfault (h5::ReportCrashesInsideHdf5). Call once at
// the start of an executable; fuzz targets must not.
void ReportHdf5CrashesAs(const char* tool);

}  // namespace wm::ingest
