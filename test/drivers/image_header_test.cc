#include "drivers/image/image_header.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "test/support/image_bombs.h"

namespace tsc {
namespace {

using testing_support::EncodeImage;

// Property: the header of every image OpenCV writes gives the size OpenCV decodes it at.
TEST(ImageHeader, ClaimsTheSizeOpenCvDecodesForPngAndJpeg) {
  for (const char* ext : {".png", ".jpg"}) {
    for (const cv::Size size : {cv::Size(1, 1), cv::Size(33, 7), cv::Size(640, 480)}) {
      const std::vector<uint8_t> bytes = EncodeImage(ext, size.width, size.height);
      std::string why;
      const std::optional<ImageHeader> h = ParseImageHeader(bytes, &why);
      ASSERT_TRUE(h) << ext << " " << why;
      EXPECT_EQ(h->format, std::string(ext) == ".png" ? ImageFormat::kPng : ImageFormat::kJpeg);
      EXPECT_EQ(h->width, size.width) << ext;
      EXPECT_EQ(h->height, size.height) << ext;
      EXPECT_EQ(h->pixels(), int64_t{size.width} * size.height);
      EXPECT_EQ(cv::imdecode(bytes, cv::IMREAD_UNCHANGED).size(), size) << ext;
    }
  }
}

// A progressive JPEG has its frame header in SOF2, after the same tables.
TEST(ImageHeader, ReadsAProgressiveJpeg) {
  const cv::Mat img(21, 45, CV_8UC3, cv::Scalar(1, 2, 3));
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(cv::imencode(".jpg", img, bytes, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
  const std::optional<ImageHeader> h = ParseImageHeader(bytes);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->SizeText(), "45x21");
}

// The bombs of issue 18: what the header claims is read without decoding anything, and the
// rewritten file is still a well-formed PNG (CRC) / JPEG as far as the header goes.
TEST(ImageHeader, ReadsTheClaimOfForgedBombs) {
  const std::vector<uint8_t> jpeg = testing_support::ForgedJpegBomb();
  const std::optional<ImageHeader> j = ParseImageHeader(jpeg);
  ASSERT_TRUE(j);
  EXPECT_EQ(j->SizeText(), "20512x35225");
  EXPECT_EQ(j->pixels(), int64_t{20512} * 35225);
  const std::optional<ImageHeader> p = ParseImageHeader(testing_support::ForgedPngBomb());
  ASSERT_TRUE(p);
  EXPECT_EQ(p->SizeText(), "20000x20000");
}

// The 20000x20000 bomb of the tests is built from repeated deflate blocks (image_bombs.h): the
// same construction, small enough to decode here, is a valid PNG of zeros.
TEST(ImageHeader, ZeroPngBombIsAValidPngOfZeros) {
  const std::vector<uint8_t> small = testing_support::ZeroPngBomb(70, 300, 100);
  const cv::Mat decoded = cv::imdecode(small, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(decoded.size(), cv::Size(70, 300));
  ASSERT_EQ(decoded.type(), CV_8UC3);
  EXPECT_EQ(cv::countNonZero(decoded.reshape(1)), 0);
  const std::vector<uint8_t> bomb = testing_support::ZeroPngBomb(20000, 20000);
  EXPECT_GT(bomb.size(), 1000000u);
  EXPECT_LT(bomb.size(), 1300000u);
  const std::optional<ImageHeader> h = ParseImageHeader(bomb);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->SizeText(), "20000x20000");
}

TEST(ImageHeader, PngCrcIsRecomputedWhenTheClaimIsRewritten) {
  // With the CRC right, libpng reads the forged IHDR (and would allocate for it): a claim of
  // 20x10 over 16x16 pixels of data decodes to 20x10 (rows cut short) or fails on the data,
  // never on "IHDR: CRC error".
  const std::vector<uint8_t> forged = WithClaimedSize(EncodeImage(".png", 16, 16), 20, 10);
  const cv::Mat decoded = cv::imdecode(forged, cv::IMREAD_COLOR);
  if (!decoded.empty()) {
    EXPECT_EQ(decoded.size(), cv::Size(20, 10));
  }
  const std::optional<ImageHeader> h = ParseImageHeader(forged);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->SizeText(), "20x10");
}

TEST(ImageHeader, RefusesWhatIsNotAPngOrJpegOrIsCutShort) {
  std::string why;
  const std::vector<uint8_t> text = {'h', 'e', 'l', 'l', 'o'};
  EXPECT_FALSE(ParseImageHeader(text, &why));
  EXPECT_NE(why.find("not a PNG or JPEG"), std::string::npos) << why;
  EXPECT_FALSE(LooksLikePngOrJpeg(text));

  for (const char* ext : {".png", ".jpg"}) {
    const std::vector<uint8_t> whole = EncodeImage(ext, 8, 8);
    ASSERT_TRUE(LooksLikePngOrJpeg(whole));
    const std::optional<ImageHeader> h = ParseImageHeader(whole);
    ASSERT_TRUE(h);
    // Every prefix that ends before the dimensions is refused, naming why; none is misread.
    const size_t needed = h->size_offset + (h->format == ImageFormat::kPng ? 8 : 4);
    for (size_t n = 0; n < needed; ++n) {
      why.clear();
      const std::vector<uint8_t> cut(whole.begin(), whole.begin() + static_cast<ptrdiff_t>(n));
      EXPECT_FALSE(ParseImageHeader(cut, &why)) << ext << " cut to " << n << " bytes";
      EXPECT_FALSE(why.empty());
    }
  }
}

TEST(ImageHeader, RefusesZeroDimensionsAndAScanBeforeTheFrameHeader) {
  std::vector<uint8_t> png = EncodeImage(".png", 8, 8);
  png[16] = png[17] = png[18] = png[19] = 0;  // IHDR width 0
  std::string why;
  EXPECT_FALSE(ParseImageHeader(png, &why));
  EXPECT_NE(why.find("0x8"), std::string::npos) << why;

  // SOI, then at once SOS: no frame header.
  const std::vector<uint8_t> jpeg = {0xff, 0xd8, 0xff, 0xda, 0x00, 0x08, 1, 1, 0, 0, 63, 0};
  EXPECT_FALSE(ParseImageHeader(jpeg, &why));
  EXPECT_NE(why.find("0xFFDA"), std::string::npos) << why;

  // A JPEG whose SOF defers its height to a DNL marker (height 0).
  std::vector<uint8_t> dnl = EncodeImage(".jpg", 8, 8);
  const std::optional<ImageHeader> h = ParseImageHeader(dnl);
  ASSERT_TRUE(h);
  dnl[h->size_offset] = dnl[h->size_offset + 1] = 0;
  EXPECT_FALSE(ParseImageHeader(dnl, &why));
}

TEST(ImageHeader, WithClaimedSizeRefusesWhatAFormatCannotHold) {
  EXPECT_THROW(WithClaimedSize(EncodeImage(".jpg", 8, 8), 70000, 10), std::invalid_argument);
  EXPECT_THROW(WithClaimedSize(std::vector<uint8_t>{1, 2, 3}, 10, 10), std::invalid_argument);
}

}  // namespace
}  // namespace tsc
