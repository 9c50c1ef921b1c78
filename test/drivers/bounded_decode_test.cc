#include "drivers/image/bounded_decode.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "test/support/image_bombs.h"

namespace tsc {
namespace {

namespace ts = testing_support;

TEST(DecodeBounded, DecodesAnImageWithinTheLimits) {
  for (const char* ext : {".png", ".jpg"}) {
    ImageLimits limits;
    limits.exact_size = cv::Size(40, 30);
    const DecodedImage d = DecodeBounded(ts::EncodeImage(ext, 40, 30), PixelLayout::kBgr, limits);
    ASSERT_TRUE(d.ok()) << ext << ": " << d.error;
    EXPECT_EQ(d.image.size(), cv::Size(40, 30));
    EXPECT_EQ(d.image.type(), CV_8UC3);
    EXPECT_TRUE(d.error.empty());
  }
}

// The bombs of issue 18 are refused from their header: the error says what they claim and
// nothing near their claimed size is allocated (peak RSS of this process, reset first).
TEST(DecodeBounded, RefusesBombsByTheirHeaderWithoutAllocating) {
  const bool can_measure = ts::ResetPeakRss();
  const long before_kb = ts::RssKb();
  for (const auto& [bytes, claim] : {std::pair{ts::ForgedJpegBomb(), std::string("20512x35225")},
                                     std::pair{ts::ForgedPngBomb(), std::string("20000x20000")}}) {
    const DecodedImage d = DecodeBounded(bytes, PixelLayout::kBgr, ImageLimits{});
    EXPECT_FALSE(d.ok());
    EXPECT_NE(d.error.find(claim), std::string::npos) << d.error;
    EXPECT_NE(d.error.find("camera.max_image_pixels"), std::string::npos) << d.error;
  }
  if (can_measure) {
    const long grew_kb = ts::PeakRssKb() - before_kb;
    std::printf("peak RSS grew by %ld kB while refusing two bombs\n", grew_kb);
    EXPECT_LT(grew_kb, 20 * 1024);
  }
}

TEST(DecodeBounded, RefusesAnotherSizeThanTheExpectedOneButAcceptsItTurned) {
  ImageLimits limits;
  limits.exact_size = cv::Size(32, 24);
  const DecodedImage other =
      DecodeBounded(ts::EncodeImage(".jpg", 48, 24), PixelLayout::kBgr, limits);
  EXPECT_FALSE(other.ok());
  EXPECT_NE(other.error.find("48x24"), std::string::npos) << other.error;
  EXPECT_NE(other.error.find("32x24"), std::string::npos) << other.error;
  // 24x32 is 32x24 turned (a JPEG's EXIF orientation): the header passes.
  EXPECT_FALSE(CheckImageHeader(ImageHeader{ImageFormat::kJpeg, 24, 32, 0}, limits));
}

TEST(DecodeBounded, TheLimitIsInclusive) {
  ImageLimits limits;
  limits.max_pixels = 40 * 30;
  EXPECT_TRUE(DecodeBounded(ts::EncodeImage(".png", 40, 30), PixelLayout::kBgr, limits).ok());
  limits.max_pixels = 40 * 30 - 1;
  const DecodedImage d = DecodeBounded(ts::EncodeImage(".png", 40, 30), PixelLayout::kBgr, limits);
  EXPECT_FALSE(d.ok());
  EXPECT_NE(d.error.find("40x30"), std::string::npos) << d.error;
}

TEST(DecodeBounded, OtherFormatsAndGarbageAreRefusedUndecoded) {
  const std::vector<uint8_t> bmp = [] {
    std::vector<uint8_t> b;
    cv::imencode(".bmp", cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 2, 3)), b);
    return b;
  }();
  const DecodedImage d = DecodeBounded(bmp, PixelLayout::kBgr, ImageLimits{});
  EXPECT_FALSE(d.ok());
  EXPECT_NE(d.error.find("not a PNG or JPEG"), std::string::npos) << d.error;
  // A JPEG header with nothing decodable after it.
  std::vector<uint8_t> jpeg = ts::EncodeImage(".jpg", 8, 8);
  jpeg.resize(jpeg.size() / 2);
  const DecodedImage half = DecodeBounded(jpeg, PixelLayout::kBgr, ImageLimits{});
  if (!half.ok()) {
    EXPECT_FALSE(half.error.empty());
  }
}

TEST(ImageLimits, ValidateNamesTheBadField) {
  ImageLimits limits;
  limits.max_pixels = 0;
  EXPECT_THROW(limits.Validate(), std::invalid_argument);
  limits.max_pixels = 1;
  limits.exact_size = cv::Size(0, 5);
  EXPECT_THROW(limits.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace tsc
