#include "drivers/image/image_header.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <stdexcept>

#include "drivers/image/byte_order.h"

namespace tsc {
namespace {

constexpr std::array<uint8_t, 8> kPngSignature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
constexpr std::array<uint8_t, 3> kJpegStart = {0xff, 0xd8, 0xff};  // SOI, then a marker

template <size_t N>
bool StartsWith(std::span<const uint8_t> bytes, const std::array<uint8_t, N>& prefix) {
  return bytes.size() >= N && std::equal(prefix.begin(), prefix.end(), bytes.begin());
}

uint32_t BigEndian32(std::span<const uint8_t> b, size_t at) { return ReadUnsigned(b, at, 4); }

int BigEndian16(std::span<const uint8_t> b, size_t at) {
  return static_cast<int>(ReadUnsigned(b, at, 2));
}

std::optional<ImageHeader> Refuse(std::string* why, const std::string& reason) {
  if (why != nullptr) *why = reason;
  return std::nullopt;
}

// PNG: the signature, then the IHDR chunk first of all (length 13, "IHDR", width, height, ...).
std::optional<ImageHeader> ParsePng(std::span<const uint8_t> b, std::string* why) {
  constexpr size_t kIhdr = 8;  // after the signature
  if (b.size() < kIhdr + 16) return Refuse(why, "PNG cut short before its IHDR dimensions");
  if (BigEndian32(b, kIhdr) != 13 || b[kIhdr + 4] != 'I' || b[kIhdr + 5] != 'H' ||
      b[kIhdr + 6] != 'D' || b[kIhdr + 7] != 'R') {
    return Refuse(why, "PNG without an IHDR chunk first");
  }
  const uint32_t width = BigEndian32(b, kIhdr + 8);
  const uint32_t height = BigEndian32(b, kIhdr + 12);
  // The PNG specification bounds both by 2^31 - 1.
  if (width == 0 || height == 0 || width > 0x7fffffffu || height > 0x7fffffffu) {
    return Refuse(
        why, "PNG IHDR claims " + std::to_string(width) + "x" + std::to_string(height) + " pixels");
  }
  return ImageHeader{ImageFormat::kPng, static_cast<int>(width), static_cast<int>(height),
                     kIhdr + 8};
}

// A start-of-frame marker: C0..CF except DHT (C4), JPG (C8) and DAC (CC).
bool IsStartOfFrame(uint8_t marker) {
  return marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
}

// JPEG: segments after SOI until the first SOFn (as libjpeg reads them: the first frame header
// is the one decoded). Markers without a length (RSTn, TEM) are stepped over; fill bytes (0xFF
// runs) before a marker are allowed.
std::optional<ImageHeader> ParseJpeg(std::span<const uint8_t> b, std::string* why) {
  size_t at = 2;  // after SOI
  for (;;) {
    if (at >= b.size()) return Refuse(why, "JPEG cut short before its frame header (SOF)");
    if (b[at] != 0xff) {
      return Refuse(why,
                    "JPEG: no marker at byte " + std::to_string(at) + " before its frame header");
    }
    while (at < b.size() && b[at] == 0xff) ++at;  // fill bytes
    if (at >= b.size()) return Refuse(why, "JPEG cut short before its frame header (SOF)");
    const uint8_t marker = b[at++];
    if (marker == 0x01 || (marker >= 0xd0 && marker <= 0xd7)) continue;  // no length
    if (marker == 0xd8 || marker == 0xd9 || marker == 0xda || marker == 0x00) {
      char text[8];
      std::snprintf(text, sizeof text, "0xFF%02X", marker);
      return Refuse(why, std::string("JPEG without a frame header (SOF) before marker ") + text);
    }
    if (at + 2 > b.size()) return Refuse(why, "JPEG cut short before its frame header (SOF)");
    const int length = BigEndian16(b, at);  // includes its own two bytes
    if (length < 2) return Refuse(why, "JPEG segment of length " + std::to_string(length));
    if (IsStartOfFrame(marker)) {
      // length(2) precision(1) height(2) width(2) components(1)
      if (length < 8 || at + 7 > b.size()) {
        return Refuse(why, "JPEG frame header (SOF) cut short");
      }
      const int height = BigEndian16(b, at + 3);
      const int width = BigEndian16(b, at + 5);
      if (width == 0 || height == 0) {
        // Height 0 defers it to a DNL marker, which libjpeg does not support.
        return Refuse(why, "JPEG frame header claims " + std::to_string(width) + "x" +
                               std::to_string(height) + " pixels");
      }
      return ImageHeader{ImageFormat::kJpeg, width, height, at + 3};
    }
    at += static_cast<size_t>(length);
  }
}

// CRC-32 of PNG chunks (ISO 3309, as zlib's crc32), bit by bit: it runs over 17 bytes.
uint32_t Crc32(std::span<const uint8_t> bytes) {
  uint32_t crc = 0xffffffffu;
  for (const uint8_t b : bytes) {
    crc ^= b;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xffffffffu;
}

void PutBigEndian(std::vector<uint8_t>& out, size_t at, uint32_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) {
    out[at + static_cast<size_t>(i)] = static_cast<uint8_t>(v >> (8 * (bytes - 1 - i)));
  }
}

}  // namespace

std::vector<uint8_t> WithClaimedSize(std::span<const uint8_t> image, int width, int height) {
  std::string why;
  const std::optional<ImageHeader> header = ParseImageHeader(image, &why);
  if (!header) throw std::invalid_argument("WithClaimedSize: " + why);
  std::vector<uint8_t> out(image.begin(), image.end());
  if (header->format == ImageFormat::kPng) {
    if (width < 1 || height < 1) throw std::invalid_argument("WithClaimedSize: PNG size < 1");
    PutBigEndian(out, header->size_offset, static_cast<uint32_t>(width), 4);
    PutBigEndian(out, header->size_offset + 4, static_cast<uint32_t>(height), 4);
    // The CRC covers the chunk type and data: 4 + 13 bytes from 4 before the width.
    const size_t type = header->size_offset - 4;
    if (out.size() < type + 17 + 4) throw std::invalid_argument("WithClaimedSize: PNG cut short");
    PutBigEndian(out, type + 17, Crc32(std::span<const uint8_t>(out).subspan(type, 17)), 4);
  } else {
    if (width < 1 || height < 1 || width > 65535 || height > 65535) {
      throw std::invalid_argument("WithClaimedSize: a JPEG dimension is in 1..65535");
    }
    PutBigEndian(out, header->size_offset, static_cast<uint32_t>(height), 2);
    PutBigEndian(out, header->size_offset + 2, static_cast<uint32_t>(width), 2);
  }
  return out;
}

std::string ImageHeader::SizeText() const {
  return std::to_string(width) + "x" + std::to_string(height);
}

bool LooksLikePngOrJpeg(std::span<const uint8_t> bytes) {
  return StartsWith(bytes, kPngSignature) || StartsWith(bytes, kJpegStart);
}

std::optional<ImageHeader> ParseImageHeader(std::span<const uint8_t> bytes, std::string* why) {
  if (StartsWith(bytes, kPngSignature)) return ParsePng(bytes, why);
  if (StartsWith(bytes, kJpegStart)) return ParseJpeg(bytes, why);
  return Refuse(why, "not a PNG or JPEG (by its first bytes)");
}

}  // namespace tsc
