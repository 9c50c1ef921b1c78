#pragma once
// The dimensions an image file claims, read from its header before anything is decoded: PNG's
// IHDR chunk, JPEG's start-of-frame (SOFn) segment. A decoder allocates width x height pixels
// from these two numbers before it reads a single row, so a 578-byte JPEG claiming
// 20512x35225 costs 2.2 GB; callers compare the claim with their limit first
// (drivers/image/bounded_decode.h).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace tsc {

enum class ImageFormat { kPng, kJpeg };

/// What an image's header says. Invariant: width and height ≥ 1.
struct ImageHeader {
  ImageFormat format = ImageFormat::kPng;
  int width = 0;   ///< pixels, as claimed
  int height = 0;  ///< pixels, as claimed
  /// Byte offset of the dimensions in the file: PNG IHDR's width (height follows), JPEG SOF's
  /// height (width follows), both big-endian (4 bytes each in PNG, 2 in JPEG).
  size_t size_offset = 0;

  int64_t pixels() const { return int64_t{width} * int64_t{height}; }
  /// "20000x20000".
  std::string SizeText() const;
};

/// True when `bytes` start with the PNG signature or a JPEG start-of-image marker.
bool LooksLikePngOrJpeg(std::span<const uint8_t> bytes);

/// The header of the PNG or JPEG in `bytes` (the file's first bytes suffice: everything up to
/// the IHDR chunk or the SOF segment). Never throws; nullopt when `bytes` are not a PNG or
/// JPEG, or their header is cut short or malformed (a zero dimension, a JPEG without a frame
/// header before its scan), with the reason in `*why` when given.
std::optional<ImageHeader> ParseImageHeader(std::span<const uint8_t> bytes,
                                            std::string* why = nullptr);

/// `image` (a PNG or JPEG ParseImageHeader reads) with its header rewritten to claim
/// `width` x `height` (PNG: IHDR and its CRC; JPEG: the SOF segment), every other byte kept:
/// the decompression bombs of axis-sim and of the tests. Throws std::invalid_argument when
/// `image` has no readable header or a dimension does not fit the format (JPEG: 1..65535).
std::vector<uint8_t> WithClaimedSize(std::span<const uint8_t> image, int width, int height);

}  // namespace tsc
