#include "core/zstd_codec.h"

#include <zstd.h>

#include <algorithm>
#include <memory>

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
  // raw_length comes from metadata that damage can set to anything, so the output grows with
  // what the frames really hold (at most raw_length + 1 bytes) instead of being allocated first.
  std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> dctx(ZSTD_createDCtx(), ZSTD_freeDCtx);
  Check(dctx != nullptr, "cannot create a zstd decompression context");
  ZSTD_inBuffer in{compressed.data(), compressed.size(), 0};
  std::string out;
  size_t pending = 0;  // 0 once the last frame is complete
  while (out.size() <= raw_length) {
    const size_t have = out.size();
    out.resize(std::min(raw_length + 1, std::max<size_t>(2 * have, ZSTD_DStreamOutSize())));
    ZSTD_outBuffer o{out.data(), out.size(), have};
    pending = ZSTD_decompressStream(dctx.get(), &o, &in);
    if (ZSTD_isError(pending)) {
      throw Error(std::string("corrupt zstd data: ") + ZSTD_getErrorName(pending));
    }
    out.resize(o.pos);
    if (in.pos == in.size && o.pos < o.size) break;  // all input used, nothing left to flush
  }
  Check(pending == 0 || compressed.empty(), "corrupt zstd data: truncated frame");
  Check(out.size() == raw_length, "zstd data decompressed to " +
                                      std::string(out.size() > raw_length ? "more than " : "") +
                                      std::to_string(std::min(out.size(), raw_length)) +
                                      " bytes, expected " + std::to_string(raw_length));
  return out;
}

}  // namespace wm
