#include "drivers/image/bounded_decode.h"

#include <limits>
#include <stdexcept>
#include <utility>

#include "drivers/image/png_decoder.h"

namespace tsc {
namespace {

std::string SizeText(const cv::Size& s) {
  return std::to_string(s.width) + "x" + std::to_string(s.height);
}

bool SameOrTurned(const cv::Size& a, int width, int height) {
  return (a.width == width && a.height == height) || (a.width == height && a.height == width);
}

}  // namespace

void ImageLimits::Validate() const {
  if (max_pixels < 1) {
    throw std::invalid_argument("image limits: max_pixels " + std::to_string(max_pixels) +
                                " must be at least 1");
  }
  if (exact_size && (exact_size->width < 1 || exact_size->height < 1)) {
    throw std::invalid_argument("image limits: exact size " + SizeText(*exact_size) +
                                " must be at least 1x1");
  }
}

std::optional<std::string> CheckImageHeader(const ImageHeader& header, const ImageLimits& limits) {
  const std::string claim = "its header claims " + header.SizeText() + " pixels";
  if (header.pixels() > limits.max_pixels) {
    return claim + ", more than the limit of " + std::to_string(limits.max_pixels) +
           " (camera.max_image_pixels)";
  }
  if (limits.exact_size && !SameOrTurned(*limits.exact_size, header.width, header.height)) {
    return claim + ", not the expected " + SizeText(*limits.exact_size);
  }
  return std::nullopt;
}

DecodedImage DecodeBounded(std::span<const uint8_t> bytes, PixelLayout layout,
                           const ImageLimits& limits) {
  DecodedImage out;
  std::string why;
  out.header = ParseImageHeader(bytes, &why);
  if (!out.header) {
    out.error = why;
    return out;
  }
  if (std::optional<std::string> refused = CheckImageHeader(*out.header, limits)) {
    out.error = *refused;
    return out;
  }
  if (bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max())) {
    out.error = "a file of " + std::to_string(bytes.size()) + " bytes is too large to decode";
    return out;
  }
  DecoderResult decoded = out.header->format == ImageFormat::kPng ? DecodePng(bytes, layout)
                                                                  : DecodeJpeg(bytes, layout);
  if (decoded.image.empty()) {
    out.error = "not a decodable " +
                std::string(out.header->format == ImageFormat::kPng ? "PNG" : "JPEG") +
                " (its header claims " + out.header->SizeText() + ")" +
                (decoded.error.empty() ? "" : ": " + decoded.error);
    return out;
  }
  out.image = std::move(decoded.image);
  // The decoder read the same header: anything else is a decoder we did not expect.
  if (!SameOrTurned(out.image.size(), out.header->width, out.header->height)) {
    out.error = "decoded as " + SizeText(out.image.size()) + " but its header claims " +
                out.header->SizeText();
    out.image.release();
  }
  return out;
}

}  // namespace tsc
