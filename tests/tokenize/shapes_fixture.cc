#include "tests/tokenize/shapes_fixture.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/shard/dataset_writer.h"
#include "tests/core/test_util.h"

namespace wm::tokenize {

// A 48x48 PNG: a coloured background with a rectangle and a circle that move with `t`.
std::string ShapeFrame(int episode, int t) {
  cv::Mat img(48, 48, CV_8UC3, cv::Scalar(40 + 30 * episode, 90, 160 - 20 * episode));
  cv::rectangle(img, cv::Rect(4 + 3 * t, 6, 14, 10), cv::Scalar(20, 220, 240), cv::FILLED);
  cv::circle(img, cv::Point(30, 14 + 3 * t), 7, cv::Scalar(230, 40, 60 * episode), cv::FILLED);
  std::vector<uchar> png;
  cv::imencode(".png", img, png);
  return std::string(png.begin(), png.end());
}

void WriteShapesDataset(const std::string& dir, const std::string& name) {
  shard::DatasetWriter writer({.dir = dir, .config_hash = "tokenize-test"});
  for (int e = 0; e < 3; ++e) {
    Episode ep = test::MakeEpisode(6, e, "shapes" + std::to_string(e));
    EncodedFrames& f = ep.images["image"];
    f.encoding = "png";
    f.height = f.width = 48;
    f.channels = 3;
    f.frames.clear();
    for (int t = 0; t < 6; ++t) f.frames.push_back(ShapeFrame(e, t));
    writer.Add(ep, e);
  }
  shard::DatasetIndex meta;
  meta.dataset = name;
  meta.split = "train";
  writer.Finish(meta);
}

TokenizerConfig TestConfig() {
  TokenizerConfig c;
  c.model = {.image_size = 32,
             .patch_size = 4,
             .encoder_channels = 16,
             .encoder_layers = 1,
             .decoder_channels = 16,
             .decoder_layers = 1,
             .latent_dim = 8,
             .num_codes = 64,
             .l2_normalize = true,
             .beta = 0.25,
             .dead_code_steps = 5};
  c.train.batch_size = 4;
  c.train.steps = 30;
  c.train.max_lr = 3e-3;
  c.train.min_lr = 3e-4;
  c.train.warmup_steps = 3;
  c.train.threads = 1;
  c.train.checkpoint_every = 10;
  c.train.log_every = 5;
  c.train.seed = 11;
  return c;
}

}  // namespace wm::tokenize
