#pragma once
// PNG decoding with libpng directly, laid out as cv::imdecode lays it out (BGR, 16-bit
// samples cut to 8 for kBgr; kept, in host byte order, for kUnchanged), without OpenCV's
// image codecs module (drivers/image/jpeg_decoder.h says why). Called by DecodeBounded once
// the header has passed its limits.

#include <cstdint>
#include <span>

#include "drivers/image/jpeg_decoder.h"

namespace tsc {

/// Decodes the PNG in `bytes`. Never throws for bad input: a corrupt or truncated stream
/// gives an error (libpng's message).
DecoderResult DecodePng(std::span<const uint8_t> bytes, PixelLayout layout);

}  // namespace tsc
