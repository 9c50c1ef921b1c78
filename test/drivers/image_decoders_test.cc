// tscd decodes JPEG and PNG with libjpeg and libpng directly (drivers/image/jpeg_decoder.h,
// png_decoder.h) instead of cv::imdecode: every figure of `tsc eval` rests on the pixels, so
// they must be cv::imdecode's, bit for bit, on the real loop's frames and on every layout the
// datasets and cameras produce.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "drivers/image/bounded_decode.h"
#include "drivers/image/jpeg_decoder.h"
#include "drivers/image/png_decoder.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;

std::vector<uint8_t> ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Same size, type and every byte.
::testing::AssertionResult SamePixels(const cv::Mat& ours, const cv::Mat& opencv) {
  if (ours.size() != opencv.size() || ours.type() != opencv.type()) {
    return ::testing::AssertionFailure()
           << "ours " << ours.cols << "x" << ours.rows << " type " << ours.type() << ", OpenCV's "
           << opencv.cols << "x" << opencv.rows << " type " << opencv.type();
  }
  cv::Mat diff;
  cv::compare(ours.reshape(1), opencv.reshape(1), diff, cv::CMP_NE);
  const int differing = cv::countNonZero(diff);
  if (differing != 0) return ::testing::AssertionFailure() << differing << " samples differ";
  return ::testing::AssertionSuccess();
}

cv::Mat Ours(const std::vector<uint8_t>& bytes, PixelLayout layout) {
  const DecodedImage d = DecodeBounded(bytes, layout, ImageLimits{});
  EXPECT_TRUE(d.ok()) << d.error;
  return d.image;
}

// A textured test image from OpenCV's generator seeded with `seed` (fixed: each test passes its
// own).
cv::Mat Texture(int width, int height, int type, int seed) {
  cv::Mat m(height, width, type);
  cv::setRNGSeed(seed);
  cv::randu(m, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
  cv::GaussianBlur(m, m, cv::Size(5, 5), 1.5);  // something a JPEG codec works on as on photos
  return m;
}

TEST(ImageDecoders, TheRealLoopsFramesDecodeAsCvImdecodeDecodesThem) {
  const fs::path loop = fs::path(TSCD_DATA_DIR) / "rtabmap-loop";
  int frames = 0;
  for (const auto& entry : fs::directory_iterator(loop)) {
    if (entry.path().extension() != ".jpg") continue;
    const std::vector<uint8_t> bytes = ReadFile(entry.path());
    EXPECT_TRUE(SamePixels(Ours(bytes, PixelLayout::kBgr), cv::imdecode(bytes, cv::IMREAD_COLOR)))
        << entry.path();
    ++frames;
  }
  EXPECT_EQ(frames, 84);
}

TEST(ImageDecoders, JpegsOfEveryKindDecodeAsCvImdecodeDecodesThem) {
  for (int quality : {50, 90, 100}) {
    for (int type : {CV_8UC3, CV_8UC1}) {
      const cv::Mat image = Texture(67, 45, type, 31);
      std::vector<uint8_t> bytes;
      ASSERT_TRUE(cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality}));
      for (const auto& [layout, flags] :
           {std::pair{PixelLayout::kBgr, cv::IMREAD_COLOR},
            std::pair{PixelLayout::kUnchanged, cv::IMREAD_UNCHANGED}}) {
        EXPECT_TRUE(SamePixels(Ours(bytes, layout), cv::imdecode(bytes, flags)))
            << "quality " << quality << " type " << type << " flags " << flags;
      }
    }
  }
  // Progressive and optimised, as some cameras write them.
  const cv::Mat image = Texture(64, 48, CV_8UC3, 32);
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(cv::imencode(".jpg", image, bytes,
                           {cv::IMWRITE_JPEG_PROGRESSIVE, 1, cv::IMWRITE_JPEG_OPTIMIZE, 1}));
  EXPECT_TRUE(SamePixels(Ours(bytes, PixelLayout::kBgr), cv::imdecode(bytes, cv::IMREAD_COLOR)));
}

TEST(ImageDecoders, PngsOfEveryLayoutDecodeAsCvImdecodeDecodesThem) {
  for (int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3, CV_16UC4}) {
    const cv::Mat image = Texture(37, 29, type, 33);
    std::vector<uint8_t> bytes;
    ASSERT_TRUE(cv::imencode(".png", image, bytes, {cv::IMWRITE_PNG_COMPRESSION, 3}));
    for (const auto& [layout, flags] : {std::pair{PixelLayout::kBgr, cv::IMREAD_COLOR},
                                        std::pair{PixelLayout::kUnchanged, cv::IMREAD_UNCHANGED}}) {
      EXPECT_TRUE(SamePixels(Ours(bytes, layout), cv::imdecode(bytes, flags)))
          << "type " << type << " flags " << flags;
    }
  }
}

// An APP1 "Exif" segment saying `orientation`, inserted after the JPEG's SOI marker.
std::vector<uint8_t> WithOrientation(std::vector<uint8_t> jpeg, int orientation, bool little) {
  std::vector<uint8_t> tiff = little ? std::vector<uint8_t>{'I', 'I', 42, 0, 8, 0, 0, 0, 1, 0}
                                     : std::vector<uint8_t>{'M', 'M', 0, 42, 0, 0, 0, 8, 0, 1};
  const auto u16 = [&tiff, little](int v) {
    if (little) {
      tiff.push_back(static_cast<uint8_t>(v & 0xff));
      tiff.push_back(static_cast<uint8_t>(v >> 8));
    } else {
      tiff.push_back(static_cast<uint8_t>(v >> 8));
      tiff.push_back(static_cast<uint8_t>(v & 0xff));
    }
  };
  u16(0x0112);          // orientation
  u16(3);               // SHORT
  u16(little ? 1 : 0);  // count 1 (32 bits)
  u16(little ? 0 : 1);
  u16(orientation);
  u16(0);
  for (int i = 0; i < 4; ++i) tiff.push_back(0);  // no next IFD
  std::vector<uint8_t> app1 = {'E', 'x', 'i', 'f', 0, 0};
  app1.insert(app1.end(), tiff.begin(), tiff.end());
  const size_t length = app1.size() + 2;
  std::vector<uint8_t> segment = {0xff, 0xe1, static_cast<uint8_t>(length >> 8),
                                  static_cast<uint8_t>(length & 0xff)};
  segment.insert(segment.end(), app1.begin(), app1.end());
  jpeg.insert(jpeg.begin() + 2, segment.begin(), segment.end());
  return jpeg;
}

TEST(ImageDecoders, TheExifOrientationTurnsAJpegAsCvImdecodeTurnsIt) {
  const cv::Mat image = Texture(48, 32, CV_8UC3, 34);
  std::vector<uint8_t> plain;
  ASSERT_TRUE(cv::imencode(".jpg", image, plain));
  for (int orientation = 1; orientation <= 8; ++orientation) {
    for (bool little : {false, true}) {
      const std::vector<uint8_t> bytes = WithOrientation(plain, orientation, little);
      const cv::Mat opencv = cv::imdecode(bytes, cv::IMREAD_COLOR);
      EXPECT_TRUE(SamePixels(Ours(bytes, PixelLayout::kBgr), opencv))
          << "orientation " << orientation << (little ? " II" : " MM");
      if (orientation >= 5) {
        EXPECT_EQ(opencv.size(), cv::Size(32, 48)) << "the test's EXIF is read";
      }
      // Unchanged means as stored: not turned (cv::imdecode with IMREAD_UNCHANGED neither).
      EXPECT_EQ(Ours(bytes, PixelLayout::kUnchanged).size(), cv::Size(48, 32));
    }
  }
}

TEST(ImageDecoders, CutShortOrCorruptStreamsGiveTheLibrarysMessage) {
  const cv::Mat image = Texture(40, 30, CV_8UC3, 35);
  for (const char* ext : {".jpg", ".png"}) {
    std::vector<uint8_t> bytes;
    ASSERT_TRUE(cv::imencode(ext, image, bytes));
    const std::vector<uint8_t> cut(bytes.begin(),
                                   bytes.begin() + static_cast<long>(bytes.size() / 2));
    const DecodedImage d = DecodeBounded(cut, PixelLayout::kBgr, ImageLimits{});
    if (std::string(ext) == ".png") {
      EXPECT_FALSE(d.ok()) << ext;
      EXPECT_NE(d.error.find("not a decodable PNG"), std::string::npos) << d.error;
      EXPECT_NE(d.error.find(": "), std::string::npos) << "names why: " << d.error;
    } else if (!d.ok()) {
      // libjpeg fills a cut stream with grey and warns, as cv::imdecode did; when it refuses
      // one, it says why.
      EXPECT_NE(d.error.find("not a decodable JPEG"), std::string::npos) << d.error;
    }
    std::vector<uint8_t> noise = bytes;
    std::mt19937 rng(36);
    for (size_t i = noise.size() / 3; i < noise.size(); i += 7)
      noise[i] ^= static_cast<uint8_t>(rng());
    const DecodedImage n = DecodeBounded(noise, PixelLayout::kBgr, ImageLimits{});
    if (n.ok()) {
      EXPECT_EQ(n.image.size(), cv::Size(40, 30)) << ext;
    } else {
      EXPECT_FALSE(n.error.empty()) << ext;
    }
  }
}

TEST(ImageDecoders, ExifOrientationIgnoresMalformedSegments) {
  const std::vector<uint8_t> short_one = {'E', 'x', 'i', 'f', 0, 0, 'M', 'M'};
  EXPECT_EQ(ExifOrientation(short_one), 1);
  std::vector<uint8_t> wrong_magic = {'E', 'x', 'i', 'f', 0, 0, 'M', 'M', 0, 43, 0, 0, 0, 8};
  EXPECT_EQ(ExifOrientation(wrong_magic), 1);
  // An IFD offset past the end, and an entry count running past it.
  std::vector<uint8_t> far = {'E', 'x', 'i', 'f', 0, 0, 'M', 'M', 0, 42, 0x7f, 0xff, 0xff, 0xff};
  EXPECT_EQ(ExifOrientation(far), 1);
  std::vector<uint8_t> many = {'E', 'x', 'i', 'f', 0, 0, 'M', 'M', 0, 42, 0, 0, 0, 8, 0xff, 0xff};
  EXPECT_EQ(ExifOrientation(many), 1);
}

}  // namespace
}  // namespace tsc
