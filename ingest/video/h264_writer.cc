#include "ingest/video/h264_writer.h"

#include <algorithm>
#include <cstring>
#include <mutex>
#include <vector>

#include "core/error.h"
#include "ingest/video/av_handles.h"

extern "C" {
#include <libavutil/cpu.h>
}

namespace wm::ingest {
namespace {

struct OutputCloser {
  void operator()(AVFormatContext* c) const {
    avio_closep(&c->pb);
    avformat_free_context(c);
  }
};

int Even(int n) { return n + (n & 1); }

// Copies a frame into `out` at even size, repeating the last column/row (yuv420p has one chroma
// sample per 2x2 pixels), with slack after the last row: swscale's SIMD reads up to 16 bytes past
// a row's end, which made the bytes depend on whatever followed the caller's frame in memory.
const uint8_t* Stage(const uint8_t* bgr, size_t stride, int width, int height,
                     std::vector<uint8_t>& out) {
  const int w = Even(width), h = Even(height);
  out.resize(static_cast<size_t>(w) * h * 3 + 64);
  for (int y = 0; y < h; ++y) {
    const uint8_t* src = bgr + static_cast<size_t>(std::min(y, height - 1)) * stride;
    uint8_t* dst = out.data() + static_cast<size_t>(y) * w * 3;
    std::memcpy(dst, src, static_cast<size_t>(width) * 3);
    if (w != width) std::memcpy(dst + width * 3, src + (width - 1) * 3, 3);
  }
  return out.data();
}

// x264 settings fixed here, not left to the library's defaults for this machine's core count:
// one thread (x264 splits frames by thread count, so more threads change the bytes).
av::Codec OpenEncoder(const AVCodec& codec, const H264Options& o, bool global_header,
                      const ErrorContext& where) {
  av::Codec c(avcodec_alloc_context3(&codec));
  Check(c != nullptr, "cannot allocate the H.264 encoder", where);
  c->width = Even(o.width);
  c->height = Even(o.height);
  c->pix_fmt = AV_PIX_FMT_YUV420P;
  c->framerate = av_d2q(o.fps, 100000);
  c->time_base = av_inv_q(c->framerate);
  c->thread_count = 1;
  // swscale's RGB -> YUV is BT.601, limited range; say so instead of leaving players to guess.
  c->color_range = AVCOL_RANGE_MPEG;
  c->colorspace = AVCOL_SPC_SMPTE170M;
  c->color_primaries = AVCOL_PRI_SMPTE170M;
  c->color_trc = AVCOL_TRC_SMPTE170M;
  if (global_header) c->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
  AVDictionary* settings = nullptr;  // libx264's own options; other encoders ignore them
  av_dict_set(&settings, "preset", "medium", 0);
  av_dict_set_int(&settings, "crf", o.crf, 0);
  // Measured on an AVX-512 machine (Debian 12's x264 r3095): the same frames gave different
  // bytes from one writer to the next; capped at AVX2 they are identical (and match AVX2-only
  // machines).
  if (av_get_cpu_flags() & AV_CPU_FLAG_AVX512) av_dict_set(&settings, "x264-params", "asm=AVX2", 0);
  const int rc = avcodec_open2(c.get(), &codec, &settings);
  av_dict_free(&settings);
  Check(rc >= 0, std::string("cannot open encoder ") + codec.name + ": " + av::ErrorText(rc),
        where);
  return c;
}

}  // namespace

struct H264Writer::Impl {
  ErrorContext where;
  int width = 0, height = 0;
  std::unique_ptr<AVFormatContext, OutputCloser> format;
  AVStream* stream = nullptr;
  av::Codec encoder;
  av::Scale scale;
  av::Frame frame{av_frame_alloc()};
  av::Packet packet{av_packet_alloc()};
  std::vector<uint8_t> staged;  // the caller's frame, padded (Stage)
  int64_t next_pts = 0;

  // Sends `f` (nullptr: end of stream) and writes every packet the encoder has ready.
  void Encode(const AVFrame* f) {
    int rc = avcodec_send_frame(encoder.get(), f);
    Check(rc >= 0, "H.264 encoding failed: " + av::ErrorText(rc), where);
    while ((rc = avcodec_receive_packet(encoder.get(), packet.get())) >= 0) {
      // libx264 leaves durations at 0; the MP4 edit list then ended before the last frame and
      // players (and our decoder) dropped it.
      if (packet->duration == 0) packet->duration = 1;
      av_packet_rescale_ts(packet.get(), encoder->time_base, stream->time_base);
      packet->stream_index = stream->index;
      rc = av_interleaved_write_frame(format.get(), packet.get());
      Check(rc >= 0, "cannot write the video: " + av::ErrorText(rc) + " (disk full?)", where);
    }
    Check(rc == AVERROR(EAGAIN) || rc == AVERROR_EOF, "H.264 encoding failed: " + av::ErrorText(rc),
          where);
  }
};

H264Writer::H264Writer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
H264Writer::~H264Writer() = default;

std::unique_ptr<H264Writer> H264Writer::Open(const std::string& path, const H264Options& o) {
  static std::once_flag quiet;  // x264's banner and statistics would interleave with the log
  std::call_once(quiet, [] { av_log_set_level(AV_LOG_ERROR); });
  const AVCodec* codec = avcodec_find_encoder_by_name(o.encoder.c_str());
  if (codec == nullptr || codec->id != AV_CODEC_ID_H264) return nullptr;
  auto impl = std::make_unique<Impl>();
  impl->where = {.file = path};
  impl->width = o.width;
  impl->height = o.height;
  Check(o.width > 0 && o.height > 0 && o.fps > 0, "video size and frame rate must be positive",
        impl->where);
  AVFormatContext* raw = nullptr;
  int rc = avformat_alloc_output_context2(&raw, nullptr, "mp4", path.c_str());
  Check(rc >= 0, "cannot set up the MP4 muxer: " + av::ErrorText(rc), impl->where);
  impl->format.reset(raw);
  impl->format->flags |= AVFMT_FLAG_BITEXACT;  // no FFmpeg version or creation time in the file
  impl->encoder =
      OpenEncoder(*codec, o, impl->format->oformat->flags & AVFMT_GLOBALHEADER, impl->where);
  impl->stream = avformat_new_stream(impl->format.get(), nullptr);
  Check(impl->stream != nullptr, "cannot add the video stream", impl->where);
  impl->stream->time_base = impl->encoder->time_base;
  avcodec_parameters_from_context(impl->stream->codecpar, impl->encoder.get());
  rc = avio_open(&impl->format->pb, path.c_str(), AVIO_FLAG_WRITE);
  Check(rc >= 0, "cannot create the video: " + av::ErrorText(rc), impl->where);
  AVDictionary* raw_mux = nullptr;
  av_dict_set(&raw_mux, "movflags", "+faststart", 0);  // moov first: plays while downloading
  rc = avformat_write_header(impl->format.get(), &raw_mux);
  av_dict_free(&raw_mux);
  Check(rc >= 0, "cannot write the MP4 header: " + av::ErrorText(rc), impl->where);
  AVFrame& f = *impl->frame;
  f.format = AV_PIX_FMT_YUV420P;
  f.width = impl->encoder->width;
  f.height = impl->encoder->height;
  Check(av_frame_get_buffer(&f, 0) >= 0, "cannot allocate a video frame", impl->where);
  impl->scale.reset(
      sws_getContext(f.width, f.height, AV_PIX_FMT_BGR24, f.width, f.height, AV_PIX_FMT_YUV420P,
                     SWS_BILINEAR | SWS_ACCURATE_RND | SWS_BITEXACT, nullptr, nullptr, nullptr));
  Check(impl->scale != nullptr, "cannot convert BGR to yuv420p", impl->where);
  return std::unique_ptr<H264Writer>(new H264Writer(std::move(impl)));
}

void H264Writer::Write(const uint8_t* bgr, size_t stride) {
  Impl& m = *impl_;
  const uint8_t* src[4] = {Stage(bgr, stride, m.width, m.height, m.staged), nullptr, nullptr,
                           nullptr};
  const int src_stride[4] = {Even(m.width) * 3, 0, 0, 0};
  Check(av_frame_make_writable(m.frame.get()) >= 0, "cannot allocate a video frame", m.where);
  sws_scale(m.scale.get(), src, src_stride, 0, m.frame->height, m.frame->data, m.frame->linesize);
  m.frame->pts = m.next_pts++;
  m.Encode(m.frame.get());
}

void H264Writer::Finish() {
  Impl& m = *impl_;
  m.Encode(nullptr);
  int rc = av_write_trailer(m.format.get());  // rewrites the file with moov first (faststart)
  Check(rc >= 0, "cannot write the video: " + av::ErrorText(rc) + " (disk full?)", m.where);
  rc = avio_closep(&m.format->pb);
  Check(rc >= 0, "cannot close the video: " + av::ErrorText(rc) + " (disk full?)", m.where);
}

}  // namespace wm::ingest
