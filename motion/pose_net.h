#pragma once
// The pose kind of the motion model (model.kind: pose; docs/motion.md, "The pose kind"): the arm
// is drawn from a few numbers, its pose, over a background from which a U-Net erased it, and the
// actions move the pose:
//
//   pose_0   = encoder(first)                       4 halvings of (first, pixel x, y), an MLP
//   pose_t+1 = pose_t + A a_t + g(pose_t, a_t)      A linear, g an MLP that starts at zero
//   frame_t  = rgb(pose_t) alpha(pose_t) + (1 - alpha(pose_t)) background(first)
//   background(x) = x (1 - m) + fill m              m, fill: a one-layer LayerNet's sprites
//
// The renderer upsamples a 4x4 map of the pose by four (nearest x2, 3x3 convolution) stages.
// It is learned first as an autoencoder (trainer.cc): a frame x_t drawn from its own pose over
// the background of another frame x_s of its episode. A background that kept x_s's arm would
// show it where x_t has none, so the U-Net learns to erase what moves and only the renderer can
// draw it: no labels. The dynamics (A, g) is learned after, on the frozen encoder's poses.
// Unlike the layered kind, the arm can come into the frame and change shape; it is drawn as a
// smooth shape (bench/pose_autoencoder.py's measurements). Internal (includes torch).
#include <torch/torch.h>

#include "motion/config.h"
#include "motion/layer_net.h"

namespace wm::motion {

// What the renderer draws: colour [B, 3, S, S] in (-1, 1), alpha [B, 1, S, S] in (0, 1).
struct Drawn {
  torch::Tensor rgb, alpha;
  torch::Tensor Over(const torch::Tensor& background) const {
    return rgb * alpha + (1 - alpha) * background;
  }
};

// One open-loop rollout's state: the start frame's background and the pose now.
struct PoseRollout {
  torch::Tensor background;  // [B, 3, S, S]
  torch::Tensor pose;        // [B, P]
};

// A frame [B, 3, S, S] and each pixel's x and y in [-1, 1] -> its pose [B, P]: four 4x4 stride-2
// convolutions (the coordinates make positions easy to read out), then an MLP of 256.
class PoseEncoderImpl : public torch::nn::Module {
 public:
  PoseEncoderImpl(int64_t pose_dim, int64_t channels, int64_t image_size);
  torch::Tensor forward(const torch::Tensor& frames);

 private:
  torch::nn::Sequential cnn{nullptr}, head{nullptr};
};
TORCH_MODULE(PoseEncoder);

// A pose -> Drawn: a linear map to a 4x4 grid of `width` channels at S / 16, then four (nearest
// x2, 3x3 convolution, ReLU) stages of width, width / 2, width / 4, width / 4, and a 3x3
// convolution to colour and alpha logits (alpha's bias -2: mostly transparent at the start, but
// not dead). A DCGAN-style decoder: unlike a spatial-broadcast one it need not compute every
// pixel from the pose alone (ConvTranspose2d avoided: slow on CPUs).
class DeconvRendererImpl : public torch::nn::Module {
 public:
  DeconvRendererImpl(int64_t pose_dim, int64_t width, int64_t image_size);
  Drawn forward(const torch::Tensor& pose);
  // The colour and the alpha's logit [B, 1, S, S]: forward's alpha is its sigmoid.
  Drawn Logits(const torch::Tensor& pose);
  // Adds `shift` to the alpha's logit at every pixel (the last convolution's alpha bias): the
  // calibration fitted after training (pose_trainer.h, FitAlphaShift).
  void ShiftAlpha(double shift);

 private:
  int64_t start_, width_;
  torch::nn::Linear fc{nullptr};
  torch::nn::Sequential up{nullptr};
  torch::nn::Conv2d out_{nullptr};  // up's last module
};
TORCH_MODULE(DeconvRenderer);

// pose_t+1 = pose_t + A a_t + g(pose_t, a_t): A linear (no bias), g an MLP of two hidden layers
// of `hidden` whose last layer starts at zero.
class PoseDynamicsImpl : public torch::nn::Module {
 public:
  PoseDynamicsImpl(int64_t pose_dim, int64_t action_dim, int64_t hidden);
  torch::Tensor forward(const torch::Tensor& pose, const torch::Tensor& action);

 private:
  torch::nn::Linear action_map{nullptr};
  torch::nn::Sequential correction{nullptr};
};
TORCH_MODULE(PoseDynamics);

class PoseNetImpl : public torch::nn::Module {
 public:
  PoseNetImpl(const ModelConfig& config, int64_t action_dim);

  PoseEncoder& encoder() { return encoder_; }
  DeconvRenderer& renderer() { return renderer_; }
  PoseDynamics& dynamics() { return dynamics_; }
  // `frames` with what moves erased: frames (1 - m) + fill m, m and fill the eraser's sprites.
  torch::Tensor Background(const torch::Tensor& frames);

  PoseRollout Start(const torch::Tensor& first);
  // The next frame [B, 3, S, S] under `action` [B, D] (normalised); advances `r`.
  torch::Tensor Advance(PoseRollout& r, const torch::Tensor& action);

  // The autoencoder's parameters (encoder, renderer, eraser), then the dynamics': trained one
  // after the other, each by its own optimizer.
  std::vector<std::pair<std::string, torch::Tensor>> AutoencoderParameters() const;
  std::vector<std::pair<std::string, torch::Tensor>> DynamicsParameters() const;

 private:
  PoseEncoder encoder_{nullptr};
  DeconvRenderer renderer_{nullptr};
  // A whole one-layer LayerNet, whose motion CNN and heads are unused: the layout of the bench
  // model (bench/pose_autoencoder.py) whose results docs/motion.md records.
  LayerNet eraser_{nullptr};
  PoseDynamics dynamics_{nullptr};
};
TORCH_MODULE(PoseNet);

}  // namespace wm::motion
