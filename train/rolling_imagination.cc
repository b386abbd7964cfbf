#include "train/rolling_imagination.h"

#include "core/error.h"
#include "train/batch.h"

namespace wm::train {
namespace {

// The last `count` entries of x along `dim` (frames along axis 1 unless told).
torch::Tensor Newest(const torch::Tensor& x, int64_t count, int64_t dim = 1) {
  const int64_t n = std::min(count, x.size(dim));
  return x.slice(dim, x.size(dim) - n, x.size(dim));
}

// `part` [R, ...] written into rows `rows` of a zero tensor of `batch` rows: the ended episodes'
// slots of a step, never read again.
torch::Tensor Scatter(const torch::Tensor& part, const torch::Tensor& rows, int64_t batch) {
  auto shape = part.sizes().vec();
  shape[0] = batch;
  return torch::zeros(shape, part.options()).index_copy_(0, rows, part);
}

// `past` with the frame `added` encoded after it: what PastOf gives one frame later, without
// selecting the rows' kept keys/values again.
TemporalCache Appended(const TemporalCache& past, const TemporalCache& added) {
  TemporalCache out;
  for (size_t i = 0; i < past.keys.size(); ++i) {
    out.keys.push_back(torch::cat({past.keys[i], added.keys[i]}, 2));  // [R*N, H, S + 1, hd]
    out.values.push_back(torch::cat({past.values[i], added.values[i]}, 2));
  }
  return out;
}

}  // namespace

RollingWindow::RollingWindow(WorldModel& model, const torch::Tensor& first,
                             const torch::Tensor& unknown_action)
    : model_(model), context_(model->config.model.context_frames) {
  const ModelConfig& m = model->config.model;
  Check(model->dynamics->can_roll(),
        "rolling imagination needs a next_frame model with model.temporal_positions rope");
  const int64_t B = first.size(0), N = first.size(1), H = m.num_heads, hd = m.d_model / H;
  tokens_ = first.unsqueeze(1);
  actions_ = torch::zeros({B, 0, m.action_dim}, torch::TensorOptions().device(first.device()));
  unknown_action_ = unknown_action.defined()
                        ? unknown_action.reshape({1, 1, m.action_dim}).to(actions_.options())
                        : torch::zeros({1, 1, m.action_dim}, actions_.options());
  const torch::Tensor empty = torch::zeros({B, N, H, 0, hd}, actions_.options());
  keys_.assign(m.num_layers, empty);
  values_.assign(m.num_layers, empty);
  ended_.assign(B, false);
}

TemporalCache RollingWindow::PastOf(const torch::Tensor& rows, int64_t keep) const {
  TemporalCache past;
  for (size_t i = 0; i < keys_.size(); ++i) {
    for (auto [from, to] : {std::pair{&keys_[i], &past.keys}, {&values_[i], &past.values}}) {
      const torch::Tensor x = from->index_select(0, rows);  // [R, N, H, S, hd]
      to->push_back(Newest(x, keep, 3).flatten(0, 1));      // [R*N, H, <= keep, hd]
    }
  }
  return past;
}

void RollingWindow::Keep(const torch::Tensor& rows, const TemporalCache& added) {
  const int64_t B = tokens_.size(0), R = rows.size(0);
  for (size_t i = 0; i < keys_.size(); ++i) {
    for (auto [kept, add] :
         {std::pair{&keys_[i], &added.keys[i]}, {&values_[i], &added.values[i]}}) {
      const torch::Tensor part = add->view({R, -1, add->size(1), 1, add->size(3)});  // [R,N,H,1,hd]
      *kept = torch::cat({Newest(*kept, context_ - 2, 3), Scatter(part, rows, B)}, 3);
    }
  }
}

torch::Tensor RollingWindow::LastZ(const torch::Tensor& tokens, const torch::Tensor& actions) {
  if (!model_->policy) return {};
  const torch::Tensor z = model_->DynamicsZ(tokens, actions);  // [R, T, Z]
  return z.slice(1, z.size(1) - 1, z.size(1));
}

torch::Tensor RollingWindow::Encode(const torch::Tensor& frame, const torch::Tensor& action,
                                    const torch::Tensor& z, const TemporalCache& past,
                                    int64_t index, TemporalCache* added) {
  DynamicsNetImpl& net = *model_->dynamics;
  return net.transformer->ForwardAppended(net.Embed(frame, action, z), past, index, added);
}

torch::Tensor RollingWindow::Step(const torch::Tensor& rows, const torch::Tensor& actions,
                                  double temperature, const std::vector<uint64_t>& row_seeds,
                                  DynamicsOutput& reward, torch::Tensor* log_probs_out) {
  torch::NoGradGuard no_grad;
  const int64_t B = tokens_.size(0), R = rows.size(0);
  Check(static_cast<int64_t>(row_seeds.size()) == R && actions.size(0) == R,
        "RollingWindow: one action and one seed per row");
  const torch::Tensor rows_cpu = rows.to(torch::kCPU);
  std::vector<bool> stepping(B, false);
  for (int64_t r = 0; r < R; ++r) {
    const int64_t b = rows_cpu[r].item<int64_t>();
    Check(b >= 0 && b < B && !ended_[b], "RollingWindow: row " + std::to_string(b) +
                                             " is outside the batch or its episode has ended");
    stepping[b] = true;
  }
  for (int64_t b = 0; b < B; ++b) ended_[b] = ended_[b] || !stepping[b];
  DynamicsNetImpl& net = *model_->dynamics;
  // The newest frame with its action, seen as the window path sees it (the newest
  // context_frames - 1 frames): its output predicts the next frame.
  const torch::Tensor window = Newest(tokens_.index_select(0, rows), context_ - 1);  // [R, W, N]
  const torch::Tensor acts =
      torch::cat({Newest(actions_.index_select(0, rows), window.size(1) - 1), actions.unsqueeze(1)},
                 1);  // [R, W, D]
  const torch::Tensor newest = Newest(window, 1), action = Newest(acts, 1);
  TemporalCache added;
  const TemporalCache past = PastOf(rows, context_ - 2);
  const torch::Tensor h = Encode(newest, action, LastZ(window, acts), past, newest_, &added);
  const torch::Tensor log_probs = torch::log_softmax(
      net.TokenLogits(h, newest).select(1, 0).to(torch::kCPU, torch::kFloat), -1);  // [R, N, K]
  const torch::Tensor next =
      SampleFrame([&log_probs](const torch::Tensor&) { return log_probs; }, window.size(2),
                  net.config.num_codes, /*one_pass=*/true, 1, temperature, row_seeds);  // [R, N]
  if (log_probs_out) *log_probs_out = log_probs;
  Keep(rows, added);
  // The reward of the step to the new frame: the new frame with the unknown action after the kept
  // frames (its window: the newest context_frames - 1 and itself), as PredictRewards sees it;
  // the kept ones are `past` and the frame just encoded (PastOf(rows, context_ - 1) after Keep).
  const torch::Tensor next_dev = next.to(window.device()).unsqueeze(1);  // [R, 1, N]
  const torch::Tensor unknown = unknown_action_.expand_as(action);
  const torch::Tensor h_new = Encode(
      next_dev, unknown, LastZ(torch::cat({window, next_dev}, 1), torch::cat({acts, unknown}, 1)),
      Appended(past, added), newest_ + 1, nullptr);
  net.RewardHead(h_new, reward);
  reward.reward = reward.reward.select(1, 0);
  reward.terminal_logit = reward.terminal_logit.select(1, 0);
  // The new frame becomes the newest; ended episodes get zeros they never read.
  tokens_ = Newest(torch::cat({tokens_, Scatter(next_dev, rows, B)}, 1), context_);
  actions_ = Newest(torch::cat({actions_, Scatter(action, rows, B)}, 1), context_ - 1);
  ++newest_;
  return next;
}

}  // namespace wm::train
