#include "ingest/video/video_decoder.h"

extern "C" {
#include <libavutil/imgutils.h>
}

#include <memory>
#include <mutex>
#include <vector>

#include "core/error.h"
#include "ingest/video/av_handles.h"

namespace wm::ingest {
namespace {

using av::ErrorText;
struct FormatCloser {
  void operator()(AVFormatContext* c) const { avformat_close_input(&c); }
};

// Converts decoded frames (any pixel format) to packed RGB24 and passes them on.
class RgbConverter {
 public:
  void Emit(const AVFrame& f, double timestamp_s,
            const std::function<void(const RgbFrame&)>& on_frame) {
    scale_.reset(sws_getCachedContext(scale_.release(), f.width, f.height,
                                      static_cast<AVPixelFormat>(f.format), f.width, f.height,
                                      AV_PIX_FMT_RGB24, SWS_BILINEAR, nullptr, nullptr, nullptr));
    Check(scale_ != nullptr,
          "cannot convert pixel format " +
              std::string(av_get_pix_fmt_name(static_cast<AVPixelFormat>(f.format))) + " to RGB");
    rgb_.resize(static_cast<size_t>(f.width) * f.height * 3);
    uint8_t* dst[4] = {rgb_.data(), nullptr, nullptr, nullptr};
    int dst_stride[4] = {f.width * 3, 0, 0, 0};
    sws_scale(scale_.get(), f.data, f.linesize, 0, f.height, dst, dst_stride);
    on_frame({timestamp_s, rgb_.data(), f.height, f.width});
  }

 private:
  av::Scale scale_;
  std::vector<uint8_t> rgb_;
};

}  // namespace

VideoStreamInfo DecodeVideo(const std::string& path,
                            const std::function<void(const RgbFrame&)>& on_frame,
                            const DecodeRange& range) {
  static std::once_flag quiet;  // decoders' banners and notes would interleave with the log
  std::call_once(quiet, [] { av_log_set_level(AV_LOG_ERROR); });
  const ErrorContext where{.file = path};
  AVFormatContext* raw_format = nullptr;
  int rc = avformat_open_input(&raw_format, path.c_str(), nullptr, nullptr);
  Check(rc >= 0, "cannot open video: " + ErrorText(rc), where);
  std::unique_ptr<AVFormatContext, FormatCloser> format(raw_format);
  rc = avformat_find_stream_info(format.get(), nullptr);
  Check(rc >= 0, "cannot read the video's stream info: " + ErrorText(rc), where);
  const AVCodec* codec = nullptr;
  const int stream = av_find_best_stream(format.get(), AVMEDIA_TYPE_VIDEO, -1, -1, &codec, 0);
  Check(stream >= 0 && codec != nullptr,
        stream == AVERROR_DECODER_NOT_FOUND ? "no decoder for the video stream's codec"
                                            : "the file has no video stream",
        where);
  const AVStream* st = format->streams[stream];
  av::Codec decoder(avcodec_alloc_context3(codec));
  Check(decoder && avcodec_parameters_to_context(decoder.get(), st->codecpar) >= 0,
        "cannot set up the decoder", where);
  decoder->thread_count = 1;
  rc = avcodec_open2(decoder.get(), codec, nullptr);
  Check(rc >= 0, std::string("cannot open decoder ") + codec->name + ": " + ErrorText(rc), where);

  VideoStreamInfo info{avcodec_get_name(st->codecpar->codec_id), codec->name, st->codecpar->width,
                       st->codecpar->height, 0};
  const double time_base = av_q2d(st->time_base);
  if (range.from_s > 0) {
    // A failed seek leaves the file at its start: slower, same frames.
    av_seek_frame(format.get(), stream, static_cast<int64_t>(range.from_s / time_base),
                  AVSEEK_FLAG_BACKWARD);
  }
  bool past_range = false;
  av::Packet packet(av_packet_alloc());
  av::Frame frame(av_frame_alloc());
  RgbConverter converter;
  auto drain = [&]() {
    while ((rc = avcodec_receive_frame(decoder.get(), frame.get())) >= 0) {
      const int64_t pts = frame->best_effort_timestamp;
      Check(pts != AV_NOPTS_VALUE, "frame " + std::to_string(info.frames) + " has no timestamp",
            where);
      info.last_timestamp_s = static_cast<double>(pts) * time_base;
      if (!past_range) converter.Emit(*frame, info.last_timestamp_s, on_frame);
      past_range = past_range || info.last_timestamp_s > range.to_s;
      ++info.frames;
      av_frame_unref(frame.get());
    }
    Check(rc == AVERROR(EAGAIN) || rc == AVERROR_EOF,
          "frame " + std::to_string(info.frames) + " does not decode: " + ErrorText(rc), where);
  };
  while (!past_range && (rc = av_read_frame(format.get(), packet.get())) >= 0) {
    if (packet->stream_index == stream) {
      const int sent = avcodec_send_packet(decoder.get(), packet.get());
      Check(sent >= 0,
            "packet after frame " + std::to_string(info.frames) +
                " does not decode: " + ErrorText(sent),
            where);
      drain();
    }
    av_packet_unref(packet.get());
  }
  Check(
      past_range || rc == AVERROR_EOF,
      "reading the video failed after frame " + std::to_string(info.frames) + ": " + ErrorText(rc),
      where);
  avcodec_send_packet(decoder.get(), nullptr);  // flush: frames the decoder still holds
  drain();
  return info;
}

}  // namespace wm::ingest
