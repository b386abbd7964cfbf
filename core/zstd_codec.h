#pragma once
// zstd for numeric arrays in shards. Single-threaded compression, so bytes are reproducible.
#include <string>
#include <string_view>

namespace wm {

inline constexpr int kDefaultZstdLevel = 3;
std::string ZstdCompress(std::string_view raw, int level = kDefaultZstdLevel);
// Throws wm::Error when the data is corrupt or does not decompress to exactly `raw_length`.
std::string ZstdDecompress(std::string_view compressed, size_t raw_length);

}  // namespace wm
