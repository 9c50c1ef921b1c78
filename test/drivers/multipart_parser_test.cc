// The MJPEG multipart parser on hand-made streams: split at every byte, parts without
// Content-Length, garbage between parts, limits that refuse a stream.

#include "drivers/camera/multipart_parser.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

namespace tsc {
namespace {

// Bodies that contain CR LF, dashes and a near-boundary, as JPEG bytes may.
const std::vector<std::string> kBodies = {std::string("\xff\xd8 first\r\n--bound\r\n\xff\xd9", 21),
                                          "second part", std::string("\0\r\n\0--x", 7)};

std::string Part(const std::string& body, bool with_length) {
  std::string s = "--bound\r\nContent-Type: image/jpeg\r\n";
  if (with_length) s += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  return s + "\r\n" + body + "\r\n";
}

// Without Content-Length a body must not hold CRLF--boundary itself.
const std::vector<std::string> kPlainBodies = {
    std::string("\xff\xd8 first\r\n--boun\r\n\xff\xd9", 20), "second part",
    std::string("\0\r\n\0--x", 7)};

std::string Stream(const std::vector<std::string>& bodies, bool with_length) {
  std::string s;
  for (const std::string& b : bodies) s += Part(b, with_length);
  return s;
}

std::vector<std::string> Bodies(const std::vector<MultipartPart>& parts) {
  std::vector<std::string> out;
  for (const MultipartPart& p : parts) out.push_back(p.body);
  return out;
}

TEST(MultipartParser, ParsesPartsWithContentLengthSplitAtEveryByte) {
  const std::string stream = Stream(kBodies, true);
  for (size_t split = 0; split <= stream.size(); ++split) {
    MultipartParser dut("bound");
    std::vector<MultipartPart> parts;
    ASSERT_TRUE(dut.Feed(std::string_view(stream).substr(0, split), &parts));
    ASSERT_TRUE(dut.Feed(std::string_view(stream).substr(split), &parts));
    ASSERT_EQ(Bodies(parts), kBodies) << "split at " << split;
    EXPECT_EQ(parts[0].content_type, "image/jpeg");
    EXPECT_EQ(dut.skipped_bytes(), 0);
  }
}

TEST(MultipartParser, ParsesPartsWithoutContentLengthFedOneByteAtATime) {
  // Without a length a part ends at CRLF--boundary; the last part needs the next delimiter.
  const std::string stream = Stream(kPlainBodies, false) + "--bound--\r\n";
  for (size_t split = 0; split <= stream.size(); ++split) {
    MultipartParser dut("bound");
    std::vector<MultipartPart> parts;
    ASSERT_TRUE(dut.Feed(std::string_view(stream).substr(0, split), &parts));
    ASSERT_TRUE(dut.Feed(std::string_view(stream).substr(split), &parts));
    ASSERT_EQ(Bodies(parts), kPlainBodies) << "split at " << split;
    EXPECT_TRUE(dut.finished());
  }
  MultipartParser bytewise("bound");
  std::vector<MultipartPart> parts;
  const std::string simple = Part("abc", false) + Part("defg", false) + "--bound--";
  for (char c : simple) ASSERT_TRUE(bytewise.Feed(std::string_view(&c, 1), &parts));
  EXPECT_EQ(Bodies(parts), (std::vector<std::string>{"abc", "defg"}));
}

TEST(MultipartParser, SkipsAndCountsGarbageBetweenParts) {
  const std::string stream = "preamble junk\r\n" + Part("one", true) + "GARBAGE--boun" +
                             Part("two", true) + "\r\n--boundary-lookalike\r\n" +
                             Part("three", false) + "--bound\r\n";
  MultipartParser dut("bound");
  std::vector<MultipartPart> parts;
  ASSERT_TRUE(dut.Feed(stream, &parts));
  EXPECT_EQ(Bodies(parts), (std::vector<std::string>{"one", "two", "three"}));
  EXPECT_GT(dut.skipped_bytes(), 20);
  EXPECT_FALSE(dut.failed());
}

TEST(MultipartParser, PartWithoutHeadersAndPaddingAfterBoundary) {
  MultipartParser dut("bound");
  std::vector<MultipartPart> parts;
  ASSERT_TRUE(dut.Feed("--bound  \t\r\n\r\nbare\r\n--bound--", &parts));
  ASSERT_EQ(parts.size(), 1u);
  EXPECT_EQ(parts[0].body, "bare");
  EXPECT_EQ(parts[0].content_type, "");
}

TEST(MultipartParser, RefusesAHugeContentLength) {
  MultipartParserOptions options;
  options.max_part_bytes = 1000;
  for (const std::string length : {"1001", "99999999999999999999999999"}) {
    MultipartParser dut("bound", options);
    std::vector<MultipartPart> parts;
    EXPECT_FALSE(dut.Feed("--bound\r\nContent-Length: " + length + "\r\n\r\nxx", &parts));
    EXPECT_TRUE(dut.failed());
    EXPECT_NE(dut.error().find("Content-Length " + length + " exceeds"), std::string::npos)
        << dut.error();
    EXPECT_FALSE(dut.Feed(Part("late", true), &parts));  // a failed stream stays failed
    EXPECT_TRUE(parts.empty());
  }
}

TEST(MultipartParser, RefusesMalformedLengthsAndOversizedParts) {
  MultipartParserOptions options;
  options.max_part_bytes = 64;
  options.max_header_bytes = 64;
  std::vector<MultipartPart> parts;
  MultipartParser not_a_number("bound", options);
  EXPECT_FALSE(not_a_number.Feed("--bound\r\nContent-Length: 12abc\r\n\r\n", &parts));
  EXPECT_NE(not_a_number.error().find("'12abc' is not a number"), std::string::npos);

  MultipartParser endless_part("bound", options);
  EXPECT_FALSE(endless_part.Feed("--bound\r\n\r\n" + std::string(200, 'x'), &parts));
  EXPECT_NE(endless_part.error().find("without Content-Length"), std::string::npos);

  MultipartParser endless_headers("bound", options);
  EXPECT_FALSE(endless_headers.Feed("--bound\r\nX-A: " + std::string(200, 'h'), &parts));
  EXPECT_NE(endless_headers.error().find("header block"), std::string::npos);
  EXPECT_TRUE(parts.empty());
}

// Found by fuzz_axis_multipart (fuzz/regressions/fuzz_axis_multipart/header-end-across-reads):
// a header block that just fits was refused when its blank line arrived split across reads,
// and accepted in one read.
TEST(MultipartParser, HeaderBlockAtTheLimitIsAcceptedWhereverTheReadsEnd) {
  MultipartParserOptions options;
  options.max_header_bytes = 32;
  // "X: …\r\n" of 32 bytes, then the blank line: the block is exactly at the limit.
  const std::string stream = "--bound\r\nX: " + std::string(27, 'h') + "\r\n\r\nbody\r\n--bound--";
  for (size_t split = 0; split <= stream.size(); ++split) {
    MultipartParser dut("bound", options);
    std::vector<MultipartPart> parts;
    EXPECT_TRUE(dut.Feed(std::string_view(stream).substr(0, split), &parts)) << split;
    EXPECT_TRUE(dut.Feed(std::string_view(stream).substr(split), &parts)) << split;
    ASSERT_EQ(parts.size(), 1u) << split;
    EXPECT_EQ(parts[0].body, "body");
    EXPECT_LE(dut.buffered_bytes(), options.max_header_bytes + 4);
  }
  MultipartParser too_long("bound", options);  // one byte more is refused, also in one read
  std::vector<MultipartPart> parts;
  EXPECT_FALSE(too_long.Feed("--bound\r\nX: " + std::string(30, 'h') + "\r\n\r\nbody", &parts));
}

// Found by fuzz_axis_multipart (fuzz/regressions/fuzz_axis_multipart/
// boundary-line-skips-depend-on-reads): text after a boundary-like prefix was counted as skipped
// or not depending on where the reads ended, and long padding was accepted only in one read.
TEST(MultipartParser, BoundaryLineVerdictDoesNotDependOnTheReads) {
  MultipartParserOptions options;
  options.max_header_bytes = 16;
  const std::string padded =
      "--bound" + std::string(17, ' ') + "\r\n\r\nx\r\n--bound\r\n\r\ny\r\n--bound--";
  const std::string prose =
      "--boundless " + std::string(40, 'z') + "\r\n--bound\r\n\r\ny\r\n--bound--";
  for (const std::string& stream : {padded, prose}) {
    int64_t skipped = -1;
    for (size_t split = 0; split <= stream.size(); ++split) {
      MultipartParser dut("bound", options);
      std::vector<MultipartPart> parts;
      ASSERT_TRUE(dut.Feed(std::string_view(stream).substr(0, split), &parts));
      ASSERT_TRUE(dut.Feed(std::string_view(stream).substr(split), &parts));
      // Padding longer than the header limit makes no delimiter line: only "y" is a part.
      ASSERT_EQ(Bodies(parts), std::vector<std::string>{"y"}) << split;
      if (skipped < 0) skipped = dut.skipped_bytes();
      EXPECT_EQ(dut.skipped_bytes(), skipped) << split;
    }
  }
}

// What a fuzz target checks, on seeded mutations of a valid stream: never more bytes out than
// went in, every part within the limit, and a refused stream stays refused.
TEST(MultipartParser, SurvivesMutatedStreams) {
  std::mt19937 rng(7);
  const std::string valid = Stream(kBodies, true) + Stream(kPlainBodies, false);
  MultipartParserOptions options;
  options.max_part_bytes = 64;
  for (int trial = 0; trial < 2000; ++trial) {
    std::string stream = valid;
    const int edits = 1 + static_cast<int>(rng() % 8);
    for (int e = 0; e < edits; ++e) {
      const size_t at = rng() % stream.size();
      switch (rng() % 3) {
        case 0:
          stream[at] = static_cast<char>(rng());
          break;
        case 1:
          stream.erase(at, 1 + rng() % 4);
          break;
        default:
          stream.insert(at, std::string(1 + rng() % 3, static_cast<char>(rng())));
      }
      if (stream.empty()) stream = "-";
    }
    MultipartParser dut("bound", options);
    std::vector<MultipartPart> parts;
    size_t fed = 0;
    bool ok = true;
    while (fed < stream.size()) {
      const size_t n = std::min(stream.size() - fed, static_cast<size_t>(1 + rng() % 40));
      const bool now = dut.Feed(std::string_view(stream).substr(fed, n), &parts);
      ASSERT_FALSE(!ok && now) << "a refused stream came back, trial " << trial;
      ok = now;
      fed += n;
    }
    size_t out = 0;
    for (const MultipartPart& p : parts) {
      ASSERT_LE(p.body.size(), options.max_part_bytes);
      out += p.body.size();
    }
    ASSERT_LE(out, stream.size());
    EXPECT_EQ(dut.failed(), !ok);
  }
}

TEST(MultipartParser, BoundaryComesFromTheContentType) {
  EXPECT_EQ(BoundaryFromContentType("multipart/x-mixed-replace; boundary=myboundary"),
            "myboundary");
  EXPECT_EQ(BoundaryFromContentType("Multipart/X-Mixed-Replace;charset=x; BOUNDARY=\"a b\""),
            "a b");
  EXPECT_EQ(BoundaryFromContentType("multipart/x-mixed-replace"), std::nullopt);
  EXPECT_EQ(BoundaryFromContentType("multipart/x-mixed-replace; boundary=\"\""), std::nullopt);
  EXPECT_EQ(BoundaryFromContentType("image/jpeg; boundary=x"), std::nullopt);
  EXPECT_THROW(MultipartParser(""), std::invalid_argument);
}

}  // namespace
}  // namespace tsc
