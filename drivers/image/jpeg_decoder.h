#pragma once
// JPEG decoding with libjpeg(-turbo) directly, as cv::imdecode does it (BGR through the
// library's own colour conversion, the EXIF orientation applied), without OpenCV's image
// codecs module: Debian builds that against GDAL, GDCM, Poppler and a hundred more libraries,
// 48 MB of every tscd's resident set (docs/reliability.md, "What a memory costs tscd").
// Called by DecodeBounded once the header has passed its limits.

#include <cstdint>
#include <opencv2/core.hpp>
#include <span>
#include <string>

namespace tsc {

/// What a decoder gives back: the image (empty on failure) or why there is none.
struct DecoderResult {
  cv::Mat image;
  std::string error;  ///< the library's message when `image` is empty
};

/// How a decoder lays out its pixels (the cv::IMREAD_ modes tscd uses).
enum class PixelLayout {
  kBgr,        ///< 8-bit BGR whatever the file holds; EXIF orientation applied (IMREAD_COLOR)
  kUnchanged,  ///< as stored: 1, 3 (BGR) or 4 (BGRA) channels, 8 or 16 bits (IMREAD_UNCHANGED)
};

/// Decodes the JPEG in `bytes`. Never throws for bad input: a corrupt or truncated stream
/// gives an error (libjpeg's message), as does a CMYK JPEG (not supported).
DecoderResult DecodeJpeg(std::span<const uint8_t> bytes, PixelLayout layout);

/// The EXIF orientation (1..8, TIFF tag 0x0112) in a JPEG APP1 segment's payload ("Exif\0\0"
/// and a TIFF header), 1 when it has none or the payload is malformed.
int ExifOrientation(std::span<const uint8_t> app1);

/// `image` turned as EXIF `orientation` says (as OpenCV's imdecode turns it).
cv::Mat Oriented(const cv::Mat& image, int orientation);

}  // namespace tsc
