#pragma once
// PNG and JPEG pixels through libpng and libjpeg(-turbo) alone. Builds without OpenCV
// (WM_MODEL_ONLY, docs/gpu.md) decode shard frames and label maps with these; full builds test
// them against OpenCV's codecs, which wrap the same two libraries.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace wm {

struct DecodedImage {
  int height = 0;
  int width = 0;
  int channels = 0;           // 1 (grey) or 3 (RGB); alpha is dropped, palettes become RGB
  int bit_depth = 8;          // 8 or 16 (16-bit PNG only)
  std::vector<uint8_t> data;  // HxWxC interleaved; 16-bit samples as native-endian uint16

  const uint16_t* samples16() const { return reinterpret_cast<const uint16_t*>(data.data()); }
};

// "png", "jpeg" or "" from the magic bytes.
std::string SniffImageFormat(std::string_view encoded);

// Decodes a PNG (grey, grey+alpha, RGB, RGBA, palette; 1-16 bits) or a baseline/progressive
// JPEG (grey or colour). Sub-byte grey is expanded to 8 bits. Throws wm::Error naming `source`
// when the bytes are neither format or are damaged.
DecodedImage DecodePngOrJpeg(std::string_view encoded, const std::string& source);

// PNG of interleaved 8-bit pixels (1 = grey, 3 = RGB). Throws wm::Error on bad arguments.
std::string EncodePng(const uint8_t* pixels, int height, int width, int channels);

}  // namespace wm
