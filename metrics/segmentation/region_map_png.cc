// PNG output of region maps (`wm-metrics seg --save-masks`).
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_codec.h"
#include "metrics/segmentation/region_map.h"

namespace wm::metrics::seg {

void WriteRegionMapPng(const std::string& path, const RegionMap& map) {
  std::vector<uint8_t> labels(map.pixels.size());
  for (size_t i = 0; i < map.pixels.size(); ++i) labels[i] = static_cast<uint8_t>(map.pixels[i]);
  try {
    WriteFileAtomically(path, EncodePng(labels.data(), map.height, map.width, 1));
  } catch (const Error& e) {
    throw e.WithFile(path);
  }
}

}  // namespace wm::metrics::seg
