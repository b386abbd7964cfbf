#pragma once
// The segmentation config (configs/segmentation/*.yaml): a dataset's label -> region map and the
// parameters of the motion and depth mask sources. Every field, its meaning and default:
// docs/metrics-segmentation.md, "Config".
#include <string>

#include "metrics/segmentation/mask_source.h"

namespace wm::metrics::seg {

struct SegConfig {
  LabelMap labels;  // empty unless the config lists `labels`
  MotionMaskOptions motion;
  DepthMaskOptions depth;
};

// Parses YAML of the form
//   labels: {0: background, 1: arm, 2: object}   unlisted: error|arm|object|background|none
//   arm_borders: top                             (both sources)
//   motion: {change_threshold: 0.12, ...}        depth: {depth_scale: 0.001, intrinsics: [...]}
// Unknown keys, wrong types and out-of-range values throw wm::Error naming `file` and the key.
SegConfig ParseSegConfig(const std::string& yaml_text, const std::string& file);
SegConfig LoadSegConfig(const std::string& path);

// "0=background,1=arm,2=object" (the --labels flag); throws wm::Error naming the bad pair.
LabelMap ParseLabelList(const std::string& text);

}  // namespace wm::metrics::seg
