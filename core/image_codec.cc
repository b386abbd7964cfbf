#include "core/image_codec.h"

#include <jpeglib.h>
#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>

#include "core/error.h"

// libpng and libjpeg report fatal errors by longjmp back into the function that set up the
// read (their documented pattern). Every C++ object those functions touch is constructed before
// setjmp and its storage reserved up front, so the jump skips no destructor.
namespace wm {
namespace {

struct PngReadState {
  std::string_view bytes;
  size_t offset = 0;
  char message[200] = {};
};

void PngRead(png_structp png, png_bytep out, png_size_t length) {
  auto* s = static_cast<PngReadState*>(png_get_io_ptr(png));
  if (length > s->bytes.size() - s->offset) png_error(png, "truncated PNG data");
  std::memcpy(out, s->bytes.data() + s->offset, length);
  s->offset += length;
}

void PngError(png_structp png, png_const_charp message) {
  auto* s = static_cast<PngReadState*>(png_get_error_ptr(png));
  std::snprintf(s->message, sizeof(s->message), "%s", message);
  png_longjmp(png, 1);
}

void PngWarning(png_structp, png_const_charp) {}  // benign (e.g. a bad sRGB profile)

DecodedImage DecodePng(std::string_view encoded, const std::string& source) {
  PngReadState state{encoded};
  DecodedImage image;
  std::vector<png_bytep> rows;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &state, PngError, PngWarning);
  Check(png != nullptr, "cannot start the PNG decoder", {.file = source});
  png_infop info = png_create_info_struct(png);
  if (info == nullptr || setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw Error(std::string("cannot decode PNG: ") + state.message, {.file = source});
  }
  png_set_read_fn(png, &state, PngRead);
  png_read_info(png, info);
  const int colour = png_get_color_type(png, info);
  const int depth = png_get_bit_depth(png, info);
  if (colour == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (colour == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
  png_set_strip_alpha(png);
  if (depth == 16) png_set_swap(png);  // PNG stores big-endian samples
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  image.height = static_cast<int>(png_get_image_height(png, info));
  image.width = static_cast<int>(png_get_image_width(png, info));
  image.channels = png_get_channels(png, info);
  image.bit_depth = png_get_bit_depth(png, info);
  const size_t row_bytes = png_get_rowbytes(png, info);
  image.data.resize(row_bytes * image.height);
  rows.resize(image.height);
  for (int y = 0; y < image.height; ++y) rows[y] = image.data.data() + row_bytes * y;
  png_read_image(png, rows.data());
  png_destroy_read_struct(&png, &info, nullptr);
  return image;
}

struct JpegErrorState {
  jpeg_error_mgr manager;
  jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = {};
};

void JpegError(j_common_ptr info) {
  auto* s = reinterpret_cast<JpegErrorState*>(info->err);
  info->err->format_message(info, s->message);
  longjmp(s->jump, 1);
}

DecodedImage DecodeJpeg(std::string_view encoded, const std::string& source) {
  jpeg_decompress_struct info;
  JpegErrorState error;
  DecodedImage image;
  info.err = jpeg_std_error(&error.manager);
  error.manager.error_exit = JpegError;
  if (setjmp(error.jump)) {
    jpeg_destroy_decompress(&info);
    throw Error(std::string("cannot decode JPEG: ") + error.message, {.file = source});
  }
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, reinterpret_cast<const unsigned char*>(encoded.data()), encoded.size());
  jpeg_read_header(&info, TRUE);
  Check(info.num_components == 1 || info.num_components == 3,
        "JPEG has " + std::to_string(info.num_components) + " components (expected grey or colour)",
        {.file = source});
  info.out_color_space = info.num_components == 1 ? JCS_GRAYSCALE : JCS_RGB;
  jpeg_start_decompress(&info);
  image.height = static_cast<int>(info.output_height);
  image.width = static_cast<int>(info.output_width);
  image.channels = info.output_components;
  const size_t row_bytes = static_cast<size_t>(image.width) * image.channels;
  image.data.resize(row_bytes * image.height);
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = image.data.data() + row_bytes * info.output_scanline;
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  jpeg_destroy_decompress(&info);
  return image;
}

void PngWrite(png_structp png, png_bytep data, png_size_t length) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<char*>(data), length);
}

}  // namespace

std::string SniffImageFormat(std::string_view encoded) {
  static constexpr unsigned char kPng[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (encoded.size() >= sizeof(kPng) && std::memcmp(encoded.data(), kPng, sizeof(kPng)) == 0)
    return "png";
  if (encoded.size() >= 3 && static_cast<unsigned char>(encoded[0]) == 0xff &&
      static_cast<unsigned char>(encoded[1]) == 0xd8 &&
      static_cast<unsigned char>(encoded[2]) == 0xff)
    return "jpeg";
  return "";
}

DecodedImage DecodePngOrJpeg(std::string_view encoded, const std::string& source) {
  const std::string format = SniffImageFormat(encoded);
  if (format == "png") return DecodePng(encoded, source);
  if (format == "jpeg") return DecodeJpeg(encoded, source);
  throw Error("not a PNG or JPEG image (" + std::to_string(encoded.size()) + " bytes)",
              {.file = source});
}

std::string EncodePng(const uint8_t* pixels, int height, int width, int channels) {
  Check(height > 0 && width > 0 && (channels == 1 || channels == 3),
        "EncodePng needs a positive size and 1 or 3 channels");
  PngReadState state;  // only its message buffer: writing has no input
  std::string out;
  std::vector<png_const_bytep> rows(height);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &state, PngError, PngWarning);
  Check(png != nullptr, "cannot start the PNG encoder");
  png_infop info = png_create_info_struct(png);
  if (info == nullptr || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw Error(std::string("cannot encode PNG: ") + state.message);
  }
  png_set_write_fn(png, &out, PngWrite, nullptr);
  png_set_IHDR(png, info, width, height, 8,
               channels == 1 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  const size_t row_bytes = static_cast<size_t>(width) * channels;
  for (int y = 0; y < height; ++y) rows[y] = pixels + row_bytes * y;
  png_write_info(png, info);
  png_write_image(png, const_cast<png_bytepp>(rows.data()));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

}  // namespace wm
