#pragma once
// MotionConfig: every knob of the action-conditioned warp predictor (motion/warp_net.h) and its
// training run, loaded from YAML (configs/motion/*.yaml). Each field's meaning and default is
// documented in docs/motion.md; the defaults below are the `tiny` CPU preset.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

namespace wm::motion {

struct ModelConfig {
  // "warp": a per-pixel flow resamples the last frame (warp_net.h); "layers": the start frame's
  // layers move as wholes (layer_net.h); "pose": the arm drawn from a pose the actions move
  // (pose_net.h). The default is the kind checkpoints written before this key existed hold;
  // configs/motion/tiny.yaml picks layers.
  std::string kind = "warp";
  int image_size = 64;    // frames are resized (INTER_AREA) to image_size x image_size
  int channels = 32;      // U-Net width (three stride-2 levels down to image_size / 8)
  double flow_scale = 4;  // pixels of flow per unit of the head's output
  double gate_bias = -3;  // correction gate logit offset: sigmoid(-3) = 0.05 at the start
  // Flow = bias + sum_i J_i * a_i with a per-pixel J predicted from the frames: the action acts
  // multiplicatively (docs/motion.md, "Why the flow is linear in the action"). false = the
  // action is only added to the bottleneck features.
  bool action_jacobian = true;
  int layers = 3;           // kind layers: moving layers over the static background
  int pose_dim = 16;        // kind pose: numbers in the pose
  int renderer_width = 64;  // kind pose: the renderer's widest convolution (a multiple of 4)
  // kind pose: the width of the dynamics' correction MLP (two hidden layers). 128, the width of
  // checkpoints written before this key existed; 256 in the pose configs since session 43
  // (docs/motion.md, "A wider correction for the pose's dynamics").
  int dynamics_hidden = 128;
};

struct TrainConfig {
  int batch_size = 16;
  int64_t steps = 1500;
  double max_lr = 1e-3;
  double min_lr = 1e-4;
  int64_t warmup_steps = 50;
  double beta1 = 0.9, beta2 = 0.9;
  double weight_decay = 0.01;
  double grad_clip = 1.0;  // max global L2 norm of the gradients (0 = off)
  uint64_t seed = 0;
  int threads = 1;  // LibTorch intra-op threads; fixed so CPU runs are reproducible
  int64_t checkpoint_every = 500;
  int64_t log_every = 10;
  int64_t val_every = 0;  // val.csv period in steps with --val-data (0: only at the end)
  int unroll = 1;         // imagined steps per training window (loss averaged over them)
  int val_episodes = 8;   // validation rollouts: the first episodes of the val data
  int val_horizon = 8;    // imagined frames per validation rollout
  // kind layers: the loss adds mask_l1 x the layers' mean mask (what need not move stays in the
  // background), and the mask logits get Gaussian noise of std mask_noise (masks saturate to 0
  // or 1), growing linearly from 0 over the first mask_noise_ramp of the steps (masks find
  // their objects while soft, then harden).
  double mask_l1 = 0.01;
  double mask_noise = 2.0;
  double mask_noise_ramp = 0.5;
  // kind layers: the loss adds motion_prior x the cross-entropy of the layers' union against
  // the pixels that change within the window, fading to 0 over the first motion_prior_steps of
  // the steps (motion/motion_prior.h): the layers start on what moves. 0 = off, as checkpoints
  // written before these keys were.
  double motion_prior = 0;
  double motion_prior_steps = 0.3;
  // kind layers: the frame loss weighs the pixels that change within the window 1 +
  // moved_weight, the rest 1 (a weighted mean; motion/motion_prior.h): the arm and the block are
  // a few percent of the frame, and what the model is for happens there. 0 = the plain mean.
  double moved_weight = 0;
  // kind pose: train.steps learn the autoencoder (encoder, renderer, eraser), whose frame loss
  // is squared for the first squared_until of those steps and L1 after (sharper once the pose is
  // read; an L1 from the start kills the drawn arm: its best guess at each pixel is the table);
  // moved_weight then weighs the pixels where the frame differs from the learned background by
  // over 30 levels, and mask_l1 is the weight of the drawn arm's mean alpha. Then
  // dynamics_steps learn the pose's motion on the frozen encoder's poses: batches of
  // dynamics_batch open-loop rollouts of `unroll` steps, AdamW (0.9, 0.999) peaking at
  // dynamics_lr on the same schedule's shape.
  double squared_until = 0.6;
  // kind pose: the autoencoder's two frames of a pair lie at most pair_window steps apart (0 =
  // anywhere in the episode, as checkpoints written before this key). Near pairs are what a
  // rollout of a few steps asks of the eraser: a block that the arm has not reached rarely moves
  // within 8 steps (7% of such pairs in the demo's data, 23% over the whole episode), so it keeps
  // the block instead of half-erasing it.
  int pair_window = 0;
  // kind pose: the autoencoder's loss adds edge_weight x the same norm of the image-gradient
  // difference between the drawn frame and x_t (pose_trainer.h, GradientDifference): a blurred
  // arm keeps the frame's mean colour but not its edges. 0 = off, as checkpoints written before.
  double edge_weight = 0;
  // kind pose: after the last step, the drawn alpha's logit is shifted by the one number that
  // draws the training episodes' open-loop rollouts with the least plain squared error
  // (pose_trainer.h, FitAlphaShift): the loss's moved_weight is for learning to draw the arm,
  // and leaves it too opaque where the renderer is unsure. false: as checkpoints written before
  // this key.
  bool calibrate_alpha = false;
  int64_t dynamics_steps = 3000;
  int dynamics_batch = 256;
  double dynamics_lr = 1e-3;
};

struct DataConfig {
  std::string image_key = "image";  // Episode::images stream to train on
};

struct MotionConfig {
  ModelConfig model;
  TrainConfig train;
  DataConfig data;
};

// Parses and validates a YAML file. Unknown keys, wrong types and out-of-range values throw
// wm::Error naming the file and the key (e.g. "model.channels").
MotionConfig LoadMotionConfig(const std::string& path);
MotionConfig ParseMotionConfig(const std::string& yaml_text, const std::string& file);

// The config as JSON (for manifests and wm::ConfigHash), and back.
nlohmann::json ConfigToJson(const MotionConfig& config);
MotionConfig ConfigFromJson(const nlohmann::json& j);

// Throws wm::Error (key named, `file` attached) when a value is out of range.
void ValidateConfig(const MotionConfig& config, const std::string& file);

}  // namespace wm::motion
