// wm-metrics-full: the whole wm-metrics program, with LPIPS (LibTorch), a wmkit tokenizer as the
// lpips_style / fvd_style feature network, OpenCV's decoders and the PCL-based `seg`. The light
// wm-metrics starts it, with its own arguments, for the commands that need these; run directly
// it behaves exactly as wm-metrics (tools/wm_metrics_cli.h).
#include <memory>

#include "metrics/lpips/lpips.h"
#include "metrics/tools/seg_command.h"
#include "metrics/tools/tokenizer_feature_net.h"
#include "metrics/tools/wm_metrics_cli.h"

namespace {

wm::metrics::LpipsDistance OpenLpips(const std::string& weights_file,
                                     const wm::metrics::LpipsOptions& options) {
  auto lpips = std::make_shared<wm::metrics::Lpips>(weights_file, options);
  return [lpips](const auto& a, const auto& b, int height, int width) {
    return lpips->Distance(a, b, height, width);
  };
}

}  // namespace

int main(int argc, char** argv) {
  return wm::metrics::RunWmMetrics(argc, argv,
                                   {.lpips_loader = OpenLpips,
                                    .feature_net_loader = wm::metrics::OpenTokenizerFeatureNet,
                                    .add_seg_command = wm::metrics::AddSegCommand});
}
