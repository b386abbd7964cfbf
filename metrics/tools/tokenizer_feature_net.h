#pragma once
// The feature network wm-metrics wires into lpips_style / fvd_style: a wmkit tokenizer's encoder
// (tokenize::Tokenizer's PerceptualDistance and ClipDescriptor, docs/metrics.md).
#include <memory>
#include <string>

#include "metrics/feature_net.h"

namespace wm::metrics {

// `run`: a wm-tokenize run directory or checkpoint; throws wm::Error naming it when unreadable.
std::unique_ptr<FeatureNet> OpenTokenizerFeatureNet(const std::string& run,
                                                    const std::string& device);

}  // namespace wm::metrics
