#include "trainkit/action_norm.h"

#include "core/error.h"

namespace wm::trainkit {

void ActionNorm::Apply(const float* raw, float* out, int64_t steps, int64_t out_stride) const {
  const int64_t D = dim(), stride = out_stride > 0 ? out_stride : D;
  for (int64_t t = 0; t < steps; ++t) {
    for (int64_t i = 0; i < D; ++i) {
      const double s = std[i] < 1e-6 ? 1.0 : std[i];
      out[t * stride + i] = static_cast<float>((raw[t * D + i] - mean[i]) / s);
    }
  }
}

nlohmann::json ActionNorm::ToJson() const { return {{"mean", mean}, {"std", std}}; }

ActionNorm ActionNorm::FromJson(const nlohmann::json& j) {
  ActionNorm n{j.at("mean").get<std::vector<double>>(), j.at("std").get<std::vector<double>>()};
  Check(!n.mean.empty() && n.std.size() == n.mean.size(),
        "action statistics must have as many (>= 1) std as mean values", {.key = "action_norm"});
  return n;
}

}  // namespace wm::trainkit
