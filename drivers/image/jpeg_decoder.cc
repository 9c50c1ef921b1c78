#include "drivers/image/jpeg_decoder.h"

// jpeglib.h needs size_t and FILE declared before it.
#include <jpeglib.h>

#include <algorithm>
#include <csetjmp>
#include <cstddef>
#include <cstdio>

#include "drivers/image/byte_order.h"

namespace tsc {
namespace {

// libjpeg reports a fatal error by calling error_exit, which must not return: it jumps back
// to the decoder with the message.
struct ErrorManager {
  jpeg_error_mgr library;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = {};
};

void ErrorExit(j_common_ptr info) {
  auto* errors = reinterpret_cast<ErrorManager*>(info->err);
  (*info->err->format_message)(info, errors->message);
  std::longjmp(errors->jump, 1);
}

// libjpeg's state and its error manager, together so that the jump finds both.
struct Decompression {
  jpeg_decompress_struct info{};
  ErrorManager errors;
};

}  // namespace

int ExifOrientation(std::span<const uint8_t> app1) {
  static constexpr uint8_t kExif[6] = {'E', 'x', 'i', 'f', 0, 0};
  if (app1.size() < 6 + 8 || !std::equal(kExif, kExif + 6, app1.begin())) return 1;
  const std::span<const uint8_t> tiff = app1.subspan(6);
  bool little = false;
  if (tiff[0] == 'I' && tiff[1] == 'I') {
    little = true;
  } else if (!(tiff[0] == 'M' && tiff[1] == 'M')) {
    return 1;
  }
  if (ReadUnsigned(tiff, 2, 2, little) != 42) return 1;
  const size_t ifd = ReadUnsigned(tiff, 4, 4, little);
  if (ifd > tiff.size() || tiff.size() - ifd < 2) return 1;
  const size_t entries = ReadUnsigned(tiff, ifd, 2, little);
  for (size_t e = 0; e < entries; ++e) {
    const size_t at = ifd + 2 + 12 * e;
    if (at > tiff.size() || tiff.size() - at < 12) return 1;
    if (ReadUnsigned(tiff, at, 2, little) != 0x0112) continue;
    // A SHORT held in the first two bytes of the value field.
    const uint32_t value = ReadUnsigned(tiff, at + 8, 2, little);
    return value >= 1 && value <= 8 ? static_cast<int>(value) : 1;
  }
  return 1;
}

cv::Mat Oriented(const cv::Mat& image, int orientation) {
  cv::Mat out;
  switch (orientation) {
    case 2:
      cv::flip(image, out, 1);
      return out;
    case 3:
      cv::flip(image, out, -1);
      return out;
    case 4:
      cv::flip(image, out, 0);
      return out;
    case 5:
      cv::transpose(image, out);
      return out;
    case 6:
      cv::transpose(image, out);
      cv::flip(out, out, 1);
      return out;
    case 7:
      cv::transpose(image, out);
      cv::flip(out, out, -1);
      return out;
    case 8:
      cv::transpose(image, out);
      cv::flip(out, out, 0);
      return out;
    default:
      return image;
  }
}

namespace {

// The decode proper: setjmp here, where nothing with a destructor is made after it (the
// image and the orientation are the caller's). False after a libjpeg error, its message in
// d.errors.message; the caller destroys d.info either way.
bool Decompress(Decompression& d, std::span<const uint8_t> bytes, PixelLayout layout,
                cv::Mat* image, int* orientation) {
  if (setjmp(d.errors.jump) != 0) return false;
  jpeg_create_decompress(&d.info);
  jpeg_mem_src(&d.info, bytes.data(), static_cast<unsigned long>(bytes.size()));
  if (layout == PixelLayout::kBgr) jpeg_save_markers(&d.info, JPEG_APP0 + 1, 0xffff);
  jpeg_read_header(&d.info, TRUE);
  if (d.info.jpeg_color_space == JCS_CMYK || d.info.jpeg_color_space == JCS_YCCK) {
    std::snprintf(d.errors.message, sizeof d.errors.message, "a CMYK JPEG (not supported)");
    return false;
  }
  const bool gray = d.info.num_components == 1 && layout == PixelLayout::kUnchanged;
  d.info.out_color_space = gray ? JCS_GRAYSCALE : JCS_EXT_BGR;
  for (jpeg_saved_marker_ptr m = d.info.marker_list; m != nullptr; m = m->next) {
    if (m->marker != JPEG_APP0 + 1) continue;
    *orientation = ExifOrientation(std::span<const uint8_t>(m->data, m->data_length));
    if (*orientation != 1) break;
  }
  jpeg_start_decompress(&d.info);
  image->create(static_cast<int>(d.info.output_height), static_cast<int>(d.info.output_width),
                gray ? CV_8UC1 : CV_8UC3);
  while (d.info.output_scanline < d.info.output_height) {
    JSAMPROW row = image->ptr<JSAMPLE>(static_cast<int>(d.info.output_scanline));
    jpeg_read_scanlines(&d.info, &row, 1);
  }
  jpeg_finish_decompress(&d.info);
  return true;
}

}  // namespace

DecoderResult DecodeJpeg(std::span<const uint8_t> bytes, PixelLayout layout) {
  DecoderResult result;
  Decompression d;
  d.info.err = jpeg_std_error(&d.errors.library);
  d.errors.library.error_exit = ErrorExit;
  // Warnings (a corrupt but decodable stream: cv::imdecode decoded those too) go where
  // jpeg_std_error sends them: stderr, or tscd's log (daemon/jpeg_messages.cc).
  cv::Mat image;
  int orientation = 1;
  const bool ok = Decompress(d, bytes, layout, &image, &orientation);
  jpeg_destroy_decompress(&d.info);
  if (!ok) {
    result.error = d.errors.message;
    return result;
  }
  result.image = layout == PixelLayout::kBgr ? Oriented(image, orientation) : image;
  return result;
}

}  // namespace tsc
