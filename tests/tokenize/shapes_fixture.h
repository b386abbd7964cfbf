#pragma once
// A tiny shard dataset of moving shapes and a matching small tokenizer config, shared by the
// tokenizer tests.
#include <string>

#include "tokenize/config.h"

namespace wm::tokenize {

// A 48x48 PNG: a coloured background with a rectangle and a circle that move with `t`.
std::string ShapeFrame(int episode, int t);

// 3 episodes x 6 steps of ShapeFrame PNGs, index.json "dataset" = `name`.
void WriteShapesDataset(const std::string& dir, const std::string& name = "shapes");

// 32x32 frames -> 8x8 tokens of 64 codes, 16 channels: trains in seconds on one core.
TokenizerConfig TestConfig();

}  // namespace wm::tokenize
