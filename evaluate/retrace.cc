#include "evaluate/retrace.h"

#include <algorithm>

#include "core/error.h"

namespace wm::evaluate {
namespace {

Action ActionAt(const float* actions, int64_t dim, int64_t i) {
  return Action(actions + i * dim, actions + (i + 1) * dim);
}

}  // namespace

Action RetraceAction(const float* actions, int64_t dim, int64_t n) {
  Check(n >= 1 && dim >= 1, "retrace needs at least one action of at least one value");
  Action out(static_cast<size_t>(dim), 0.f);
  for (int64_t i = 0; i < n; ++i) {
    for (int64_t d = 0; d < dim - 1; ++d) out[d] += actions[i * dim + d];
  }
  out[dim - 1] = actions[(n - 1) * dim + dim - 1];
  return out;
}

std::vector<ContextSlot> PlainContext(const float* actions, int64_t dim, int64_t t,
                                      int64_t context) {
  Check(context >= 1 && t >= 0, "context must be >= 1 and t >= 0");
  std::vector<ContextSlot> slots;
  for (int64_t f = std::max<int64_t>(0, t - context + 1); f <= t; ++f) {
    slots.push_back({f, ActionAt(actions, dim, f)});
  }
  return slots;
}

std::vector<ContextSlot> RetraceContext(const float* actions, int64_t dim, int64_t t,
                                        int64_t context) {
  if (t < context || context < 2) return PlainContext(actions, dim, t, context);
  return AnchoredContext(actions, dim, t, context - 1);
}

std::vector<ContextSlot> AnchoredContext(const float* actions, int64_t dim, int64_t t,
                                         int64_t kept) {
  Check(kept >= 0 && t >= 0, "kept frames and t must be >= 0");
  if (kept >= t) return PlainContext(actions, dim, t, t + 1);
  // Frame 0, then frames t-kept+1..t; the retrace action bridges frame 0 to t-kept+1.
  std::vector<ContextSlot> slots = {{0, RetraceAction(actions, dim, t - kept + 1)}};
  for (int64_t f = t - kept + 1; f <= t; ++f) slots.push_back({f, ActionAt(actions, dim, f)});
  return slots;
}

}  // namespace wm::evaluate
