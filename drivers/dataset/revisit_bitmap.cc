#include "drivers/dataset/revisit_bitmap.h"

#include <array>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

#include "drivers/dataset/dataset.h"

namespace tsc {
namespace fs = std::filesystem;
namespace {

constexpr size_t kFileHeaderBytes = 14;
constexpr uint32_t kMinInfoHeaderBytes = 40;  // BITMAPINFOHEADER; later versions extend it
constexpr uint32_t kUncompressed = 0;         // BI_RGB

uint32_t U32(const unsigned char* p) {
  return uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24;
}
uint16_t U16(const unsigned char* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }

bool White(unsigned char b, unsigned char g, unsigned char r) { return b + g + r >= 3 * 128; }

}  // namespace

std::vector<std::vector<int>> ReadRevisitBitmap(const fs::path& file, int frames) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw DatasetError(file, "cannot be read");
  std::array<unsigned char, kFileHeaderBytes + kMinInfoHeaderBytes> h{};
  if (!in.read(reinterpret_cast<char*>(h.data()), h.size())) {
    throw DatasetError(file, "not a bitmap (shorter than its headers)");
  }
  if (h[0] != 'B' || h[1] != 'M') throw DatasetError(file, "not a bitmap (no \"BM\" at its start)");
  const uint32_t pixel_offset = U32(&h[10]);
  const unsigned char* info = &h[kFileHeaderBytes];
  const uint32_t info_bytes = U32(info);
  const auto width = static_cast<int32_t>(U32(info + 4));
  const auto height = static_cast<int32_t>(U32(info + 8));
  const uint16_t bits = U16(info + 14);
  const uint32_t compression = U32(info + 16);
  const uint32_t colours_used = U32(info + 32);
  if (info_bytes < kMinInfoHeaderBytes) {
    throw DatasetError(file,
                       "unsupported bitmap header (" + std::to_string(info_bytes) + " bytes)");
  }
  if (width != frames || std::abs(int64_t{height}) != frames) {
    throw DatasetError(file, "is " + std::to_string(width) + "x" +
                                 std::to_string(std::abs(int64_t{height})) +
                                 " pixels, but the folder has " + std::to_string(frames) +
                                 " frames (one row and one column each)");
  }
  if (bits != 1 && bits != 8 && bits != 24 && bits != 32) {
    throw DatasetError(file, std::to_string(bits) + " bits a pixel (1, 8, 24 or 32 are read)");
  }
  if (compression != kUncompressed) throw DatasetError(file, "compressed bitmaps are not read");

  // Grey levels of the palette, for 1 and 8 bits a pixel.
  std::vector<bool> white_index;
  if (bits <= 8) {
    const uint32_t most = 1u << bits;
    const uint32_t count = colours_used == 0 ? most : colours_used;
    if (count > most)
      throw DatasetError(file, "a palette of " + std::to_string(count) + " colours");
    in.seekg(static_cast<std::streamoff>(kFileHeaderBytes + info_bytes));
    std::vector<unsigned char> palette(size_t{count} * 4);
    if (!in.read(reinterpret_cast<char*>(palette.data()),
                 static_cast<std::streamsize>(palette.size()))) {
      throw DatasetError(file, "palette cut short");
    }
    white_index.assign(most, false);
    for (uint32_t c = 0; c < count; ++c) {
      white_index[c] = White(palette[4 * c], palette[4 * c + 1], palette[4 * c + 2]);
    }
  }

  const size_t stride = ((size_t{bits} * static_cast<size_t>(frames) + 31) / 32) * 4;
  std::vector<unsigned char> row(stride);
  std::vector<std::vector<int>> revisits(static_cast<size_t>(frames));
  in.seekg(pixel_offset);
  for (int r = 0; r < frames; ++r) {
    if (!in.read(reinterpret_cast<char*>(row.data()), static_cast<std::streamsize>(stride))) {
      throw DatasetError(file, "pixel data cut short at row " + std::to_string(r + 1) + " of " +
                                   std::to_string(frames));
    }
    const int frame = height > 0 ? frames - 1 - r : r;  // positive height: bottom-up rows
    std::vector<int>& earlier = revisits[static_cast<size_t>(frame)];
    for (int j = 0; j < frame; ++j) {
      const auto x = static_cast<size_t>(j);
      bool white = false;
      switch (bits) {
        case 1:
          white = white_index[(row[x / 8] >> (7 - x % 8)) & 1];
          break;
        case 8:
          white = white_index[row[x]];
          break;
        default: {
          const size_t p = x * (bits / 8);
          white = White(row[p], row[p + 1], row[p + 2]);
        }
      }
      if (white) earlier.push_back(j);
    }
  }
  return revisits;
}

}  // namespace tsc
