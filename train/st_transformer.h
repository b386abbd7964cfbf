#pragma once
// The spatial-temporal transformer block shared by the dynamics model and the policy embedding
// model (WHALE Sec. 3.1, after Genie): a token attends to the tokens of its own frame (spatial)
// and to the tokens at the same grid position in earlier frames (temporal, causal), which costs
// O(T N^2 + N T^2) instead of O((T N)^2). Internal header (includes torch).
#include <torch/torch.h>

#include <array>
#include <string>
#include <utility>
#include <vector>

namespace wm::train {

// While one lives on a thread, the ST blocks' linear layers there run on oneDNN (LibTorch's
// MKLDNN) instead of LibTorch's BLAS: about 2x the GEMM speed where that BLAS is a generic one
// (Debian's LibTorch uses ATLAS), other float rounding. For inference paths that are compared
// with a tolerance (train/imagine_step.h); training and the reference forward keep the BLAS, which
// the PyTorch twin matches bit for bit. Without MKLDNN it changes nothing.
class OneDnnLinearScope {
 public:
  OneDnnLinearScope();
  ~OneDnnLinearScope();
  OneDnnLinearScope(const OneDnnLinearScope&) = delete;
  OneDnnLinearScope& operator=(const OneDnnLinearScope&) = delete;
};

// F::linear(x, weight, bias), through oneDNN while a OneDnnLinearScope lives on this thread.
torch::Tensor ApplyLinear(const torch::Tensor& x, const torch::Tensor& weight,
                          const torch::Tensor& bias);

// Pre-norm: LayerNorm (with bias) or RMSNorm (x / rms(x) * weight, eps 1e-6).
struct NormImpl : torch::nn::Module {
  NormImpl(int64_t dim, bool rms);
  torch::Tensor forward(const torch::Tensor& x);
  bool rms;
  torch::Tensor weight, bias;  // bias undefined for RMSNorm
};
TORCH_MODULE(Norm);

// Queries, keys and values of one attention, [M, H, L, hd] each.
struct AttentionInputs {
  torch::Tensor q, k, v;
};

// Multi-head self-attention over the second-to-last axis of x: [M, L, D] -> [M, L, D].
// `causal` masks attention to later positions (strictly upper triangle).
struct AttentionImpl : torch::nn::Module {
  AttentionImpl(int64_t dim, int64_t heads);
  torch::Tensor forward(const torch::Tensor& x, bool causal);
  AttentionInputs Project(const torch::Tensor& x);  // [M, L, D] -> 3x [M, H, L, hd]
  // Queries [M, H, Lq, hd] over keys/values [M, H, Lk, hd] -> [M, Lq, D]; `causal` needs Lq == Lk.
  // `span` > 0 (with `causal`) also hides keys `span` or more positions back (a band).
  torch::Tensor Attend(const AttentionInputs& in, bool causal, int64_t span = 0);
  int64_t heads;
  torch::nn::Linear qkv{nullptr}, proj{nullptr};
};
TORCH_MODULE(Attention);

// Each block's temporal keys and values over the frames of one context window, [B*N, H, T, hd]
// per block. The temporal attention is causal, so a frame appended to the window attends to these
// instead of recomputing the window (StTransformerImpl::ForwardAppended). With learned positions
// (the caller adds them to the input) the cache is only valid for that window: once the window
// slides, every frame's keys change. With rotary time (StBlockOptions::rope_time) a key depends on
// its frame's index, not on its slot in the window, so a rolling cache stays valid
// (train/rolling_imagination.h).
struct TemporalCache {
  std::vector<torch::Tensor> keys, values;
};

// Where a forward's frames sit in time: frame i of the input is frame `first` + i of the episode
// (the rotary angle's index; learned positions ignore it), and its temporal attention sees at most
// the `span` newest frames up to itself (0 = every earlier frame of the input: plain causal).
struct TimeAxis {
  int64_t first = 0, span = 0;
};

// The transformer's input: x [B, T, N, D], and each frame's conditioning cond [B, T, D], which
// only blocks with adaptive norm read (they require it; others ignore it, and it may be
// undefined for them). Converts from a bare x.
struct StInput {
  StInput(torch::Tensor x, torch::Tensor cond = {}) : x(std::move(x)), cond(std::move(cond)) {}
  torch::Tensor x, cond;
};

// How a block's sublayers take a frame's conditioning (DiT's adaLN): off; `identity`: a shift,
// scale and gate per sublayer from Linear(SiLU(cond)), all starting at zero with the gate added to
// 1, so every block starts as the unconditioned one; `zero` (DiT's adaLN-Zero): the same with the
// gate itself starting at zero, so every block starts as the identity.
enum class AdaptiveNorm { kOff, kIdentity, kZero };

struct StBlockOptions {
  int64_t dim = 128, heads = 4, mlp_ratio = 4;
  bool rms_norm = false;
  bool causal_time = true;  // false only for the posterior q(z | tau_H), which sees the segment
  // Rotary position embedding (RoFormer) on the temporal attention's queries and keys, by frame
  // index: attention then depends on how far apart two frames are, not where they sit.
  bool rope_time = false;
  AdaptiveNorm adaptive_norm = AdaptiveNorm::kOff;
};

// Queries or keys [M, H, L, hd] rotated by frame index first + l (RoFormer's rotation, applied to
// the two halves of each head: GPT-NeoX's layout, base 10000).
torch::Tensor RotateByFrame(const torch::Tensor& x, int64_t first);

// One sublayer's adaptive-norm terms, shaped to broadcast over its input (undefined: none):
// sublayer(norm(x) * (1 + scale) + shift) * gate.
struct Modulation {
  torch::Tensor shift, scale, gate;
};

// x + spatial(norm(x)); x + temporal(norm(x)); x + mlp(norm(x)). x: [B, T, N, D]; with adaptive
// norm each sublayer modulated by the frame's conditioning (StBlockOptions::adaptive_norm).
struct StBlockImpl : torch::nn::Module {
  explicit StBlockImpl(const StBlockOptions& options);
  torch::Tensor forward(const torch::Tensor& x) { return Forward(x, nullptr, {}); }
  // forward() that also appends this block's temporal keys and values to `cache` (when not null).
  torch::Tensor Forward(const StInput& in, TemporalCache* cache, const TimeAxis& time);
  // One frame x [B, 1, N, D] (cond [B, 1, D]), frame `index` of the episode, after the frames
  // whose temporal keys/values are `past_k`/`past_v` (all of them visible). `new_k`/`new_v`, when
  // not null, receive the frame's own.
  torch::Tensor ForwardAppended(const StInput& in, const torch::Tensor& past_k,
                                const torch::Tensor& past_v, int64_t index,
                                torch::Tensor* new_k = nullptr, torch::Tensor* new_v = nullptr);
  // Sets the adaptive norm's layer to zero (the constructors' InitWeights draws it first).
  void ZeroModulation();
  StBlockOptions options;
  // The temporal attention's inputs for x [B*N, T, D] whose first frame has index `first`.
  AttentionInputs TemporalInputs(const torch::Tensor& x, int64_t first, const Modulation& mod);
  // The spatial, temporal and MLP sublayers' terms for cond [B, T, D] and N tokens a frame.
  std::array<Modulation, 3> Modulations(const torch::Tensor& cond, int64_t N);
  torch::Tensor MlpBranch(const torch::Tensor& x, const Modulation& mod);  // x: [B, T, N, D]
  Norm norm1{nullptr}, norm2{nullptr}, norm3{nullptr};
  Attention spatial{nullptr}, temporal{nullptr};
  torch::nn::Linear fc1{nullptr}, fc2{nullptr};
  torch::nn::Linear modulation{nullptr};  // D -> 9 D; null without adaptive norm
};
TORCH_MODULE(StBlock);

// A stack of StBlocks followed by a final norm.
struct StTransformerImpl : torch::nn::Module {
  StTransformerImpl(const StBlockOptions& options, int64_t layers);
  torch::Tensor forward(torch::Tensor x) { return Forward(x, {}); }  // [B,T,N,D] -> [B,T,N,D]
  torch::Tensor Forward(const StInput& in, const TimeAxis& time);
  // forward() that fills `cache` (emptied first) with the window's temporal keys and values.
  torch::Tensor ForwardCaching(const StInput& in, TemporalCache& cache);
  // The output for one frame x [B, 1, N, D] appended to the window `cache` holds: what forward()
  // of the window extended by it gives at the new frame, up to float rounding. `index`: the new
  // frame's index in the episode (rotary time; the cache's keys carry their own). `appended`,
  // when not null, receives each block's keys/values of the new frame ([B*N, H, 1, hd]).
  torch::Tensor ForwardAppended(const StInput& in, const TemporalCache& cache, int64_t index = 0,
                                TemporalCache* appended = nullptr);
  void ZeroModulation();  // every block's (StBlockImpl::ZeroModulation)
  torch::nn::ModuleList blocks{nullptr};
  Norm norm{nullptr};
};
TORCH_MODULE(StTransformer);

// GPT-2 style init used by every module here: N(0, 0.02) Linear/Embedding weights, zero biases.
void InitWeights(torch::nn::Module& module);

}  // namespace wm::train
