// WM_MODEL_ONLY builds have no OpenCV (docs/gpu.md): `wm-tokenize decode` and the MP4 writer
// behind it and wm-eval's videos say so instead of being missing symbols.
#include "core/error.h"
#include "tokenize/decode.h"
#include "tokenize/mp4_writer.h"

namespace wm::tokenize {

const char kNeedsOpenCv[] = " needs OpenCV; this wmkit build has none (WM_MODEL_ONLY)";

int64_t DecodeEpisode(const DecodeOptions& o) {
  throw Error(std::string("wm-tokenize decode") + kNeedsOpenCv, {.file = o.out});
}

struct Mp4Writer::Impl {};

Mp4Writer::Mp4Writer(std::string path, double, int, int, const std::string&) {
  throw Error(std::string("writing MP4 videos") + kNeedsOpenCv, {.file = path});
}
Mp4Writer::~Mp4Writer() = default;
void Mp4Writer::Write(const cv::Mat&) {}
void Mp4Writer::Commit() {}

}  // namespace wm::tokenize
