#include "evaluate/retrace.h"

#include <algorithm>

#include "core/error.h"

namespace wm::evaluate {
namespace {

Action ActionAt(const float* actions, int64_t i) {
  Action a;
  std::copy(actions + i * kActionDim, actions + (i + 1) * kActionDim, a.begin());
  return a;
}

}  // namespace

Action RetraceAction(const float* actions, int64_t n) {
  Check(n >= 1, "retrace needs at least one action");
  Action out{};
  for (int64_t i = 0; i < n; ++i) {
    for (int d = 0; d < kActionDim - 1; ++d) out[d] += actions[i * kActionDim + d];
  }
  out[kActionDim - 1] = actions[(n - 1) * kActionDim + kActionDim - 1];
  return out;
}

std::vector<ContextSlot> PlainContext(const float* actions, int64_t t, int64_t context) {
  Check(context >= 1 && t >= 0, "context must be >= 1 and t >= 0");
  std::vector<ContextSlot> slots;
  for (int64_t f = std::max<int64_t>(0, t - context + 1); f <= t; ++f) {
    slots.push_back({f, ActionAt(actions, f)});
  }
  return slots;
}

std::vector<ContextSlot> RetraceContext(const float* actions, int64_t t, int64_t context) {
  if (t < context || context < 2) return PlainContext(actions, t, context);
  // Frame 0, then the newest C-1 frames t-C+2..t; the retrace action bridges frame 0 to t-C+2.
  std::vector<ContextSlot> slots = {{0, RetraceAction(actions, t - context + 2)}};
  for (int64_t f = t - context + 2; f <= t; ++f) slots.push_back({f, ActionAt(actions, f)});
  return slots;
}

}  // namespace wm::evaluate
