// PNG output of region maps (`wm-metrics seg --save-masks`); OpenCV's codecs stay in this file.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "metrics/segmentation/region_map.h"

namespace wm::metrics::seg {

void WriteRegionMapPng(const std::string& path, const RegionMap& map) {
  cv::Mat image(map.height, map.width, CV_8U);
  for (size_t i = 0; i < map.pixels.size(); ++i)
    image.data[i] = static_cast<uint8_t>(map.pixels[i]);
  std::vector<uint8_t> png;
  Check(cv::imencode(".png", image, png), "cannot encode the region map as PNG", {.file = path});
  WriteFileAtomically(path,
                      std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace wm::metrics::seg
