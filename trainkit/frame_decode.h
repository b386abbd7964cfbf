#pragma once
// Shard frames (encoded JPEG/PNG) -> the planar float images every model trains on. Torch-free;
// with OpenCV (full builds) or libjpeg/libpng and an area resampler of the same rounding
// (WM_MODEL_ONLY builds, docs/gpu.md).
#include <cstdint>
#include <string>

namespace wm::trainkit {

// Decodes an encoded JPEG/PNG frame, converts BGR->RGB, resizes (INTER_AREA) to size x size
// and writes planar floats in [-1, 1] to out[3 * size * size] ([3, H, W]).
void DecodeFrame(const std::string& encoded, int size, float* out);
// The same from interleaved RGB uint8 [height, width, 3] already in memory.
void Rgb8ToPlanar(const uint8_t* rgb, int height, int width, int size, float* out);

}  // namespace wm::trainkit
