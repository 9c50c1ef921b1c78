#include "drivers/image/png_decoder.h"

#include <png.h>

#include <cstring>
#include <string>
#include <vector>

namespace tsc {
namespace {

struct Reader {
  std::span<const uint8_t> bytes;
  size_t at = 0;
  std::string error;
};

void ReadBytes(png_structp png, png_bytep out, png_size_t length) {
  auto* r = static_cast<Reader*>(png_get_io_ptr(png));
  if (length > r->bytes.size() - r->at) png_error(png, "the PNG stream is cut short");
  std::memcpy(out, r->bytes.data() + r->at, length);
  r->at += length;
}

// libpng reports a fatal error here and expects no return: the message is kept and libpng's
// own longjmp (png_jmpbuf) takes the decoder back.
void Error(png_structp png, png_const_charp message) {
  static_cast<Reader*>(png_get_error_ptr(png))->error = message;
  png_longjmp(png, 1);
}

void Warning(png_structp, png_const_charp) {}

// The decode proper: setjmp here, where nothing with a destructor is made after it (the image
// and the row pointers are the caller's). False after a libpng error, its message in the
// reader; the caller destroys the read structures either way.
bool Read(png_structp png, png_infop info, PixelLayout layout, cv::Mat* image,
          std::vector<png_bytep>* rows) {
  if (setjmp(png_jmpbuf(png)) != 0) return false;
  png_read_info(png, info);
  const int color_type = png_get_color_type(png, info);
  const int bit_depth = png_get_bit_depth(png, info);
  const bool has_trns = png_get_valid(png, info, PNG_INFO_tRNS) != 0;
  const bool alpha = (color_type & PNG_COLOR_MASK_ALPHA) != 0 || has_trns;
  const bool color = (color_type & PNG_COLOR_MASK_COLOR) != 0;
  // cv::imdecode's layout: kBgr is 8-bit BGR; kUnchanged keeps the depth and gives 1 channel
  // for grey, 3 for colour, 4 (BGRA) for anything with transparency.
  const int channels = layout == PixelLayout::kBgr ? 3 : alpha ? 4 : color ? 3 : 1;
  const bool sixteen = layout == PixelLayout::kUnchanged && bit_depth == 16;
  if (bit_depth == 16) {
    if (sixteen) {
      png_set_swap(png);  // PNG is big-endian, cv::Mat holds host (little-endian) samples
    } else {
      png_set_strip_16(png);
    }
  }
  if (channels == 4) {
    png_set_tRNS_to_alpha(png);
  } else {
    png_set_strip_alpha(png);
  }
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (!color && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (channels >= 3) {
    if (color) {
      png_set_bgr(png);
    } else {
      png_set_gray_to_rgb(png);
    }
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  const png_uint_32 width = png_get_image_width(png, info);
  const png_uint_32 height = png_get_image_height(png, info);
  if (png_get_channels(png, info) != static_cast<png_byte>(channels)) {
    png_error(png, "unexpected channel layout after conversion");
  }
  image->create(static_cast<int>(height), static_cast<int>(width),
                CV_MAKETYPE(sixteen ? CV_16U : CV_8U, channels));
  rows->resize(height);
  for (png_uint_32 y = 0; y < height; ++y) (*rows)[y] = image->ptr<png_byte>(static_cast<int>(y));
  png_read_image(png, rows->data());
  png_read_end(png, nullptr);
  return true;
}

}  // namespace

DecoderResult DecodePng(std::span<const uint8_t> bytes, PixelLayout layout) {
  DecoderResult result;
  Reader reader{bytes, 0, {}};
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &reader, Error, Warning);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  if (info == nullptr) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    result.error = "libpng cannot start";
    return result;
  }
  png_set_read_fn(png, &reader, ReadBytes);
  cv::Mat image;
  std::vector<png_bytep> rows;
  const bool ok = Read(png, info, layout, &image, &rows);
  png_destroy_read_struct(&png, &info, nullptr);
  if (!ok) {
    result.error = reader.error.empty() ? "libpng failed" : reader.error;
    return result;
  }
  result.image = image;
  return result;
}

}  // namespace tsc
