// The motion nets' upsampling (motion/unet_blocks.h, UpConv): a 4x4 stride-2 transposed
// convolution computed as four 2x2 convolutions, one per output pixel phase, against ATen's own
// conv_transpose2d on the same weights and input, forward and backward, in one run. Shapes: the
// eraser U-Net's three upsamplings in the pose kind's autoencoder step (batch 8, channels 16, at
// 64x64). Each path runs --repeats times in turn with the other; its fastest run counts.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <limits>

#include "motion/unet_blocks.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Shape {
  const char* name;
  int64_t in, out, size;  // channels in and out, input height = width
};

// Seconds of `iterations` forward + backward passes of `up` on `x` (as the training step runs).
template <typename Forward>
double Time(Forward forward, const torch::Tensor& x, int iterations) {
  const auto start = Clock::now();
  for (int i = 0; i < iterations; ++i) forward(x).square().sum().backward();
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void Compare(const Shape& s, int64_t batch, int iterations, int repeats) {
  torch::manual_seed(0);
  wm::motion::UpConv up(s.in, s.out);
  const torch::Tensor x = torch::randn({batch, s.in, s.size, s.size}, torch::requires_grad());
  auto phases = [&](const torch::Tensor& in) { return up->forward(in); };
  auto aten = [&](const torch::Tensor& in) { return up->TransposedConvolution(in); };
  double best_phases = std::numeric_limits<double>::infinity(), best_aten = best_phases;
  Time(phases, x, 2), Time(aten, x, 2);  // warm-up
  for (int r = 0; r < repeats; ++r) {
    best_phases = std::min(best_phases, Time(phases, x, iterations));
    best_aten = std::min(best_aten, Time(aten, x, iterations));
  }
  torch::NoGradGuard no_grad;
  const double diff = (phases(x) - aten(x)).abs().max().item<double>();
  std::printf(
      "%-28s [%ld, %ld, %ld, %ld] -> %ld: UpConv %.2f ms, conv_transpose2d %.2f ms: %.2fx "
      "(max |difference| %.1e)\n",
      s.name, static_cast<long>(batch), static_cast<long>(s.in), static_cast<long>(s.size),
      static_cast<long>(s.size), static_cast<long>(s.out), 1e3 * best_phases / iterations,
      1e3 * best_aten / iterations, best_aten / best_phases, diff);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"UpConv vs ATen's conv_transpose2d, forward + backward"};
  int threads = 1, iterations = 20, repeats = 3;
  int64_t batch = 8;
  app.add_option("--threads", threads, "intra-op threads (the demo trains motion on 1)");
  app.add_option("--batch", batch, "batch size (pose_demo.yaml: 8)");
  app.add_option("--iterations", iterations, "passes per timed run");
  app.add_option("--repeats", repeats, "timed runs per path; the fastest counts");
  CLI11_PARSE(app, argc, argv);
  torch::set_num_threads(threads);
  const Shape shapes[] = {{"eraser up1 (32 -> 64 px)", 32, 16, 32},
                          {"eraser up2 (16 -> 32 px)", 32, 16, 16},
                          {"eraser up3 (8 -> 16 px)", 16, 16, 8}};
  for (const Shape& s : shapes) Compare(s, batch, iterations, repeats);
}
