// Loop-closure ground truth read from RTAB-Map's bitmap (drivers/dataset/revisit_bitmap.h): the
// real loop's groundtruth.bmp gives exactly its revisits.csv; bitmaps of every bit depth and
// row order read alike; anything else is refused naming the file.

#include "drivers/dataset/revisit_bitmap.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "drivers/dataset/dataset.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;

using Revisits = std::vector<std::vector<int>>;

// Frame 2 revisits 0; frame 3 revisits 0 and 1.
const Revisits kFour{{}, {}, {0}, {0, 1}};

cv::Mat Matrix(const Revisits& revisits) {
  const int n = static_cast<int>(revisits.size());
  cv::Mat m(n, n, CV_8UC1, cv::Scalar(0));
  for (int i = 0; i < n; ++i) {
    for (const int j : revisits[static_cast<size_t>(i)]) m.at<uint8_t>(i, j) = 255;
  }
  return m;
}

void Put32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
  for (int k = 0; k < 4; ++k) b[at + k] = static_cast<uint8_t>(v >> (8 * k));
}

// A 1-bit, top-down bitmap (what OpenCV does not write): palette black, white.
std::vector<uint8_t> OneBitTopDown(const cv::Mat& m) {
  const int n = m.cols;
  const size_t stride = ((static_cast<size_t>(n) + 31) / 32) * 4;
  const size_t offset = 14 + 40 + 8;
  std::vector<uint8_t> b(offset + stride * static_cast<size_t>(n), 0);
  b[0] = 'B';
  b[1] = 'M';
  Put32(b, 2, static_cast<uint32_t>(b.size()));
  Put32(b, 10, static_cast<uint32_t>(offset));
  Put32(b, 14, 40);
  Put32(b, 18, static_cast<uint32_t>(n));
  Put32(b, 22, static_cast<uint32_t>(-n));  // negative height: top-down
  b[26] = 1;                                // planes
  b[28] = 1;                                // bits a pixel
  Put32(b, 54 + 4, 0x00ffffff);             // palette entry 1: white
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      if (m.at<uint8_t>(i, j) != 0) {
        b[offset + stride * static_cast<size_t>(i) + static_cast<size_t>(j) / 8] |=
            static_cast<uint8_t>(0x80 >> (j % 8));
      }
    }
  }
  return b;
}

class RevisitBitmapTest : public ::testing::Test {
 protected:
  fs::path Write(const std::string& name, const cv::Mat& m) {
    const fs::path p = temp_.path() / name;
    EXPECT_TRUE(cv::imwrite(p.string(), m)) << p;
    return p;
  }
  fs::path WriteBytes(const std::string& name, const std::vector<uint8_t>& bytes) {
    const fs::path p = temp_.path() / name;
    std::ofstream(p, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()),
               static_cast<std::streamsize>(bytes.size()));
    return p;
  }
  static std::vector<uint8_t> Bytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  template <typename Fn>
  static void ExpectRefused(Fn fn, const std::string& needle) {
    try {
      fn();
      ADD_FAILURE() << "no DatasetError naming " << needle;
    } catch (const DatasetError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.bmp"), std::string::npos) << e.what();
    }
  }
  testing_support::TempDir temp_{"tscd_revisit_bitmap_test"};
};

TEST_F(RevisitBitmapTest, TheRealLoopsBitmapIsItsRevisitsCsv) {
  const fs::path loop = fs::path(TSCD_DATA_DIR) / "rtabmap-loop";
  const Dataset with_csv = Dataset::Open(loop);
  ASSERT_EQ(with_csv.size(), 84);
  ASSERT_FALSE(with_csv.revisits().empty());
  // The same folder without its revisits.csv: the bitmap is read instead.
  const fs::path copy = temp_.path() / "loop";
  fs::create_directories(copy);
  for (const fs::directory_entry& e : fs::directory_iterator(loop)) {
    if (e.path().filename() != "revisits.csv")
      fs::create_symlink(e.path(), copy / e.path().filename());
  }
  const Dataset with_bitmap = Dataset::Open(copy);
  EXPECT_EQ(with_bitmap.revisits(), with_csv.revisits());
  EXPECT_EQ(with_csv.revisits_file(), "revisits.csv");
  EXPECT_EQ(with_bitmap.revisits_file(), "groundtruth.bmp");
  int revisiting = 0;
  for (const std::vector<int>& r : with_bitmap.revisits()) revisiting += r.empty() ? 0 : 1;
  EXPECT_EQ(revisiting, 44);  // frames 41-84
}

TEST_F(RevisitBitmapTest, EveryDepthAndRowOrderReadsAlike) {
  const cv::Mat m = Matrix(kFour);
  // OpenCV writes 8-bit grey (a grey palette) and 24-bit colour, bottom-up.
  EXPECT_EQ(ReadRevisitBitmap(Write("grey.bmp", m), 4), kFour);
  cv::Mat colour;
  cv::merge(std::vector<cv::Mat>{m, m, m}, colour);
  EXPECT_EQ(ReadRevisitBitmap(Write("colour.bmp", colour), 4), kFour);
  EXPECT_EQ(ReadRevisitBitmap(WriteBytes("one-bit.bmp", OneBitTopDown(m)), 4), kFour);
  // A symmetric bitmap: what lies on or above the diagonal is not read.
  cv::Mat symmetric = m | m.t();
  symmetric.at<uint8_t>(1, 1) = 255;
  EXPECT_EQ(ReadRevisitBitmap(Write("symmetric.bmp", symmetric), 4), kFour);
  // Greys below half white are not revisits.
  cv::Mat faint = m.clone();
  faint.at<uint8_t>(1, 0) = 100;
  EXPECT_EQ(ReadRevisitBitmap(Write("faint.bmp", faint), 4), kFour);
}

TEST_F(RevisitBitmapTest, AnythingElseIsRefusedNamingTheFile) {
  const fs::path good = Write("good.bmp", Matrix(kFour));
  std::vector<uint8_t> bytes = Bytes(good);
  ExpectRefused([&] { ReadRevisitBitmap(WriteBytes("bad.bmp", bytes), 5); },
                "the folder has 5 frames");
  std::vector<uint8_t> cut(bytes.begin(), bytes.end() - 3);
  ExpectRefused([&] { ReadRevisitBitmap(WriteBytes("bad.bmp", cut), 4); }, "cut short");
  std::vector<uint8_t> compressed = bytes;
  Put32(compressed, 30, 1);  // BI_RLE8
  ExpectRefused([&] { ReadRevisitBitmap(WriteBytes("bad.bmp", compressed), 4); }, "compressed");
  std::vector<uint8_t> sixteen = bytes;
  sixteen[28] = 16;
  ExpectRefused([&] { ReadRevisitBitmap(WriteBytes("bad.bmp", sixteen), 4); }, "16 bits a pixel");
  std::vector<uint8_t> not_bmp = bytes;
  not_bmp[0] = 'P';
  ExpectRefused([&] { ReadRevisitBitmap(WriteBytes("bad.bmp", not_bmp), 4); }, "not a bitmap");
  std::vector<uint8_t> far = bytes;
  Put32(far, 10, 0x7fffffff);  // pixel data claimed beyond the end
  ExpectRefused([&] { ReadRevisitBitmap(WriteBytes("bad.bmp", far), 4); }, "cut short");
  ExpectRefused([&] { ReadRevisitBitmap(WriteBytes("bad.bmp", {'B', 'M', 0}), 4); }, "shorter");
}

}  // namespace
}  // namespace tsc
