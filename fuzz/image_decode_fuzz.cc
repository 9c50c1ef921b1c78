// Fuzz target: one image from outside (a dataset frame, a folder camera's file, an Axis MJPEG
// part) through drivers/image: the header is parsed, then DecodeBounded decodes it under a small
// limit as the cameras do. Properties: ParseImageHeader never claims a zero dimension; an image
// whose header claims more than the limit, or another size than the one expected, is refused
// (nothing decoded); what decodes has the size its header claims (or turned, EXIF); no single
// allocation beyond what the limit allows (the test runs with -malloc_limit_mb, issue 18: a
// 578-byte JPEG claiming 20512x35225 asked the decoder for 2.2 GB).

#include <opencv2/imgcodecs.hpp>
#include <span>
#include <string>

#include "drivers/image/bounded_decode.h"
#include "drivers/image/image_header.h"
#include "fuzz/fuzz_target.h"

using tsc::fuzz::Require;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  std::string why;
  const std::optional<tsc::ImageHeader> header = tsc::ParseImageHeader(bytes, &why);
  if (!header) Require(!why.empty(), "a refusal says why");
  if (header) Require(header->width >= 1 && header->height >= 1, "claimed dimensions >= 1");
  if (header) Require(tsc::LooksLikePngOrJpeg(bytes), "a header only in a PNG or JPEG");

  tsc::ImageLimits limits;
  limits.max_pixels = 256 * 256;  // a 256x256 BGR image: 192 KiB
  const tsc::DecodedImage any = tsc::DecodeBounded(bytes, tsc::PixelLayout::kBgr, limits);
  Require(any.ok() == any.error.empty(), "an error exactly when nothing decoded");
  if (header && header->pixels() > limits.max_pixels) Require(!any.ok(), "over the limit refused");
  if (any.ok()) {
    Require(any.header.has_value(), "a decoded image had a header");
    Require(static_cast<int64_t>(any.image.total()) == any.header->pixels(),
            "decoded at the claimed size");
    Require(any.image.type() == CV_8UC3, "PixelLayout::kBgr gives BGR");
  }

  // As the Axis camera reads a part: only the requested size.
  limits.exact_size = cv::Size(32, 24);
  const tsc::DecodedImage axis = tsc::DecodeBounded(bytes, tsc::PixelLayout::kBgr, limits);
  if (axis.ok()) {
    Require(axis.image.size() == cv::Size(32, 24) || axis.image.size() == cv::Size(24, 32),
            "only the expected size decodes");
  }
  return 0;
}
