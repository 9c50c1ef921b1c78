#pragma once
// Decompression bombs for the tests of bounded image decoding (issue 18): small files whose
// headers claim huge images.
//   ZeroPngBomb(20000, 20000)  a real PNG of 20000x20000 black RGB pixels, deflated: ~1.1 MB
//                              (built in ~0.1 s, see below)
//   ForgedJpegBomb()           a 16x16 JPEG whose SOF claims 20512x35225 (~0.6 KB)
//   ForgedPngBomb()            a 16x16 PNG whose IHDR (and CRC) claims 20000x20000 (~0.1 KB)
// Decoding any of them unbounded asks for 1.2-2.2 GB.

#include <zlib.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "drivers/image/image_header.h"

namespace tsc::testing_support {

inline std::vector<uint8_t> EncodeImage(const char* ext, int width, int height) {
  const cv::Mat img(height, width, CV_8UC3, cv::Scalar(60, 120, 180));
  std::vector<uint8_t> bytes;
  if (!cv::imencode(ext, img, bytes)) throw std::runtime_error("imencode failed");
  return bytes;
}

inline std::vector<uint8_t> ForgedJpegBomb(int width = 20512, int height = 35225) {
  return WithClaimedSize(EncodeImage(".jpg", 16, 16), width, height);
}

inline std::vector<uint8_t> ForgedPngBomb(int width = 20000, int height = 20000) {
  return WithClaimedSize(EncodeImage(".png", 16, 16), width, height);
}

namespace detail {
inline void PutChunk(std::vector<uint8_t>& out, const char* type,
                     const std::vector<uint8_t>& data) {
  const auto be32 = [&out](uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<uint8_t>(v >> s));
  };
  be32(static_cast<uint32_t>(data.size()));
  const size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  be32(static_cast<uint32_t>(crc32(0, out.data() + start, static_cast<uInt>(out.size() - start))));
}
}  // namespace detail

/// A valid PNG of width x height black 8-bit RGB pixels: every row filter 0, all zeros. The
/// zlib stream is built without deflating 1.2 GB: a run of `rows_per_chunk` rows of zeros is
/// deflated once with Z_FULL_FLUSH (which resets the compressor, so every further run of the
/// same zeros deflates to the same bytes), that block is repeated, and the Adler-32 of n zero
/// bytes (a = 1, b = n mod 65521) closes the stream. Precondition: rows_per_chunk divides height.
inline std::vector<uint8_t> ZeroPngBomb(uint32_t width = 20000, uint32_t height = 20000,
                                        uint32_t rows_per_chunk = 100) {
  if (height % rows_per_chunk != 0) throw std::invalid_argument("ZeroPngBomb: rows_per_chunk");
  std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<uint8_t> ihdr;
  for (const uint32_t v : {width, height}) {
    for (int s = 24; s >= 0; s -= 8) ihdr.push_back(static_cast<uint8_t>(v >> s));
  }
  ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // 8-bit, RGB, deflate, filter 0, no interlace
  detail::PutChunk(png, "IHDR", ihdr);
  z_stream z{};
  if (deflateInit(&z, Z_BEST_COMPRESSION) != Z_OK) throw std::runtime_error("deflateInit");
  std::vector<uint8_t> chunk((1 + 3 * size_t{width}) * rows_per_chunk, 0);
  std::vector<uint8_t> buf(chunk.size() / 64 + 1024);
  const auto run = [&](uint8_t* in, size_t n, int flush) {
    z.next_in = in;
    z.avail_in = static_cast<uInt>(n);
    z.next_out = buf.data();
    z.avail_out = static_cast<uInt>(buf.size());
    const int rc = deflate(&z, flush);
    if (z.avail_out == 0 || z.avail_in != 0 || rc == Z_STREAM_ERROR) {
      throw std::runtime_error("ZeroPngBomb: deflate");
    }
    return std::vector<uint8_t>(buf.data(), buf.data() + (buf.size() - z.avail_out));
  };
  std::vector<uint8_t> idat = run(chunk.data(), chunk.size(), Z_FULL_FLUSH);  // with the header
  const std::vector<uint8_t> block = run(chunk.data(), chunk.size(), Z_FULL_FLUSH);
  std::vector<uint8_t> finish = run(nullptr, 0, Z_FINISH);  // last block + a wrong Adler-32
  deflateEnd(&z);
  for (uint32_t c = 1; c < height / rows_per_chunk; ++c) {
    idat.insert(idat.end(), block.begin(), block.end());
  }
  const uint64_t n = uint64_t{height} * (1 + 3 * uint64_t{width});
  const uint32_t adler = (static_cast<uint32_t>(n % 65521) << 16) | 1u;
  finish.resize(finish.size() - 4);
  for (int s = 24; s >= 0; s -= 8) finish.push_back(static_cast<uint8_t>(adler >> s));
  idat.insert(idat.end(), finish.begin(), finish.end());
  detail::PutChunk(png, "IDAT", idat);
  detail::PutChunk(png, "IEND", {});
  return png;
}

inline void WriteBytes(const std::filesystem::path& p, const std::vector<uint8_t>& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

/// A "Key:" line's value from a /proc/<pid>/status file, kB; -1 when it cannot be read.
inline long ProcStatusKb(const std::filesystem::path& status, const std::string& field) {
  std::ifstream in(status);
  std::string key;
  while (in >> key) {
    if (key == field) {
      long kb = -1;
      in >> kb;
      return kb;
    }
    std::string rest;
    std::getline(in, rest);
  }
  return -1;
}

/// Peak resident set of this process since the last ResetPeakRss(), kB (VmHWM).
inline long PeakRssKb() { return ProcStatusKb("/proc/self/status", "VmHWM:"); }

/// Resets VmHWM to the current resident set (Linux ≥ 4.0: "5" > /proc/self/clear_refs).
/// False when the kernel does not allow it.
inline bool ResetPeakRss() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  out.flush();
  return static_cast<bool>(out);
}

/// Current resident set, kB (VmRSS).
inline long RssKb() { return ProcStatusKb("/proc/self/status", "VmRSS:"); }

}  // namespace tsc::testing_support
