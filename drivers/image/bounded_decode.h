#pragma once
// Decoding an image from outside (a dataset file, a folder camera's frame, an Axis MJPEG part)
// only after its header has shown that the result is of a size we accept: a decoder allocates
// what the header claims before it reads a row, so a small crafted file (a "decompression
// bomb": a 1 MB PNG of deflated zeros claiming 20000x20000, a 578-byte JPEG claiming
// 20512x35225) would otherwise cost gigabytes. Only PNG and JPEG are decoded, with libpng and
// libjpeg directly (drivers/image/png_decoder.h, jpeg_decoder.h; until session 31
// cv::imdecode, which picks a decoder by content, and some of Debian's, GDCM for DICOM, abort
// on a malformed file).

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <span>
#include <string>

#include "drivers/image/image_header.h"
#include "drivers/image/jpeg_decoder.h"

namespace tsc {

/// Default of camera.max_image_pixels: 4096x4096.
inline constexpr int64_t kDefaultMaxImagePixels = int64_t{4096} * 4096;

/// What an image must satisfy, by its header, before it is decoded.
struct ImageLimits {
  /// Largest width x height accepted (configuration key camera.max_image_pixels).
  int64_t max_pixels = kDefaultMaxImagePixels;
  /// When set, the only size accepted (a camera with a configured size, a dataset whose frame
  /// size is known): width x height, or height x width (a JPEG whose EXIF orientation turns it).
  std::optional<cv::Size> exact_size;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

/// Why `header` is refused under `limits`, naming its claimed size; nullopt when it passes.
std::optional<std::string> CheckImageHeader(const ImageHeader& header, const ImageLimits& limits);

/// A decoded image, or why there is none.
struct DecodedImage {
  cv::Mat image;                      ///< empty on failure
  std::optional<ImageHeader> header;  ///< what the header claimed, when it could be read
  std::string error;                  ///< why `image` is empty ("" on success)
  bool ok() const { return !image.empty(); }
};

/// Decodes the PNG or JPEG in `bytes` into `layout` (as cv::imdecode with IMREAD_COLOR or
/// IMREAD_UNCHANGED), but only once its header passes `limits`: nothing is allocated for a
/// refused image. Never throws for bad input (the decoder's message becomes the error); the
/// error does not name the source, the caller adds the file or camera and frame.
DecodedImage DecodeBounded(std::span<const uint8_t> bytes, PixelLayout layout,
                           const ImageLimits& limits);

}  // namespace tsc
