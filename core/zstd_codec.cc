#include "core/zstd_codec.h"

#include <zstd.h>

#include "core/error.h"

namespace wm {

std::string ZstdCompress(std::string_view raw, int level) {
  std::string out(ZSTD_compressBound(raw.size()), '\0');
  size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), level);
  Check(!ZSTD_isError(n), std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
  out.resize(n);
  return out;
}

std::string ZstdDecompress(std::string_view compressed, size_t raw_length) {
  std::string out(raw_length, '\0');
  size_t n = ZSTD_decompress(out.data(), out.size(), compressed.data(), compressed.size());
  if (ZSTD_isError(n)) {
    throw Error(std::string("corrupt zstd data: ") + ZSTD_getErrorName(n));
  }
  Check(n == raw_length, "zstd data decompressed to " + std::to_string(n) + " bytes, expected " +
                             std::to_string(raw_length));
  return out;
}

}  // namespace wm
