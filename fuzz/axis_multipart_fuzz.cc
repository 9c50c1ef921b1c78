// Fuzz target: an MJPEG stream as an Axis camera serves it (drivers/camera/multipart_parser).
// The input's first line is the Content-Type the camera answered with (its boundary taken as
// AxisCamera does), the rest the stream, fed in reads of sizes the input chooses
// (fuzz/chunked_input.h). Properties: the parts, the failure and its reason do not depend on
// how the stream was cut into reads; the parser never holds more than a part and a delimiter,
// or a header block, whatever it is fed; the parts it yields, written out again as a
// well-formed stream (with and without Content-Length), parse back to the same parts.

#include <algorithm>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/camera/multipart_parser.h"
#include "fuzz/chunked_input.h"
#include "fuzz/fuzz_target.h"

using tsc::MultipartPart;
using tsc::fuzz::Require;

namespace {

// Small limits, so the fuzzer reaches them; the camera's are 8 MiB and 8 KiB (same code).
tsc::MultipartParserOptions Limits() {
  tsc::MultipartParserOptions o;
  o.max_part_bytes = 2048;
  o.max_header_bytes = 256;
  return o;
}

struct Outcome {
  std::vector<MultipartPart> parts;
  bool failed = false;
  bool finished = false;
  std::string error;
  int64_t skipped = 0;
};

bool SameParts(const std::vector<MultipartPart>& a, const std::vector<MultipartPart>& b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(),
                    [](const MultipartPart& x, const MultipartPart& y) {
                      return x.content_type == y.content_type && x.body == y.body;
                    });
}

// Feeds `stream` in the input's reads, checking the memory bound after each.
Outcome Parse(const std::string& boundary, std::string_view stream,
              const tsc::fuzz::ChunkedInput& reads, bool in_one_read) {
  const tsc::MultipartParserOptions limits = Limits();
  // A part's body and the delimiter after it, or a header block and its blank line.
  const size_t bound =
      std::max(limits.max_part_bytes + boundary.size() + 4, limits.max_header_bytes + 4);
  tsc::MultipartParser dut(boundary, limits);
  Outcome out;
  auto feed = [&](std::string_view read) {
    dut.Feed(read, &out.parts);
    Require(dut.buffered_bytes() <= bound, "the parser holds at most a part or a header block");
  };
  if (in_one_read) {
    feed(stream);
  } else {
    reads.ForEachRead(stream, feed);
  }
  for (const MultipartPart& p : out.parts) {
    Require(p.body.size() <= limits.max_part_bytes, "a part is within the limit");
  }
  Require(dut.parts() == static_cast<int64_t>(out.parts.size()), "parts() counts the parts");
  out.failed = dut.failed();
  out.finished = dut.finished();
  out.error = dut.error();
  out.skipped = dut.skipped_bytes();
  return out;
}

// The parts as a camera would send them; with lengths, or without (then a body must not
// contain the delimiter, which would end it early).
std::string Serialize(const std::vector<MultipartPart>& parts, const std::string& boundary,
                      bool with_length) {
  std::string s;
  for (const MultipartPart& p : parts) {
    s += "--" + boundary + "\r\n";
    if (!p.content_type.empty()) s += "Content-Type: " + p.content_type + "\r\n";
    if (with_length) s += "Content-Length: " + std::to_string(p.body.size()) + "\r\n";
    s += "\r\n" + p.body + "\r\n";
  }
  return s + "--" + boundary + "--\r\n";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const tsc::fuzz::ChunkedInput input = tsc::fuzz::SplitChunked(data, size);
  const size_t eol = input.stream.find('\n');
  if (eol == std::string_view::npos || eol > 200) return 0;
  std::string_view content_type = input.stream.substr(0, eol);  // as HTTP hands it: no CRLF
  if (!content_type.empty() && content_type.back() == '\r') content_type.remove_suffix(1);
  const auto boundary = tsc::BoundaryFromContentType(content_type);
  if (!boundary) return 0;
  Require(!boundary->empty(), "a boundary is never empty");
  const std::string_view stream = input.stream.substr(eol + 1);

  const Outcome whole = Parse(*boundary, stream, input, true);
  const Outcome cut = Parse(*boundary, stream, input, false);
  Require(SameParts(whole.parts, cut.parts), "the same parts whatever the reads");
  Require(whole.failed == cut.failed && whole.error == cut.error,
          "the same failure whatever the reads");
  Require(whole.finished == cut.finished, "the same end whatever the reads");
  Require(whole.skipped == cut.skipped, "the same skipped bytes whatever the reads");

  // A content type with a line break cannot be written back as a header, nor one too long for
  // the header limit with a Content-Length beside it; a body holding the delimiter cannot be
  // sent without a length.
  const bool writable = std::none_of(whole.parts.begin(), whole.parts.end(), [](const auto& p) {
    return p.content_type.find_first_of("\r\n") != std::string::npos || p.content_type.size() > 200;
  });
  if (!writable) return 0;
  const std::string again = Serialize(whole.parts, *boundary, true);
  const Outcome reparsed = Parse(*boundary, again, input, false);
  Require(!reparsed.failed && reparsed.finished && SameParts(reparsed.parts, whole.parts),
          "parts written with lengths parse back the same");
  const std::string body_delimiter = "\r\n--" + *boundary;
  const bool scannable = std::all_of(whole.parts.begin(), whole.parts.end(), [&](const auto& p) {
    return (p.body + body_delimiter).find(body_delimiter) == p.body.size();
  });
  if (scannable) {
    const Outcome scanned =
        Parse(*boundary, Serialize(whole.parts, *boundary, false), input, false);
    Require(!scanned.failed && scanned.finished && SameParts(scanned.parts, whole.parts),
            "parts written without lengths parse back the same");
  }
  return 0;
}
