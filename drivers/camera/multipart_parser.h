#pragma once
// The multipart/x-mixed-replace stream an MJPEG camera sends (RFC 2046 §5.1 as Axis VAPIX uses
// it): `--boundary CRLF headers CRLF CRLF body CRLF --boundary ...`. Pure and incremental: bytes
// go in as they arrive (split anywhere), whole parts come out. No I/O, no exceptions on bad
// input (a fuzz target feeds it arbitrary bytes): a malformed stream puts the parser into a
// failed state with a message.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tsc {

struct MultipartParserOptions {
  /// Largest part body accepted, bytes. A larger Content-Length (or a part without one that
  /// grows past it) fails the stream rather than buffering without bound.
  size_t max_part_bytes = 8u << 20;
  /// Largest header block of one part, bytes.
  size_t max_header_bytes = 8u << 10;
  /// Throws std::invalid_argument naming the bad field.
  void Validate() const;
};

/// One part of the stream.
struct MultipartPart {
  std::string content_type;  ///< "" when the part has no Content-Type header
  std::string body;
};

/// The boundary parameter of a Content-Type header value such as
/// `multipart/x-mixed-replace; boundary="myboundary"`, unquoted. nullopt when the value is
/// not a multipart type or has no (or an empty) boundary.
std::optional<std::string> BoundaryFromContentType(std::string_view content_type);

class MultipartParser {
 public:
  /// Precondition: `boundary` is not empty (see BoundaryFromContentType). Throws
  /// std::invalid_argument for an empty boundary or bad options.
  explicit MultipartParser(std::string boundary, MultipartParserOptions options = {});

  /// Consumes `bytes`; appends every part completed by them to `parts`. Returns false once the
  /// stream is malformed (then error() says why and further input is ignored).
  bool Feed(std::string_view bytes, std::vector<MultipartPart>* parts);

  bool failed() const { return !error_.empty(); }
  /// Why the stream was refused: a Content-Length that is not a number or exceeds
  /// max_part_bytes, a header block or a length-less part that grows too large.
  const std::string& error() const { return error_; }
  /// True after the closing delimiter `--boundary--` (later bytes are ignored).
  bool finished() const { return state_ == State::kFinished; }
  /// Parts completed so far.
  int64_t parts() const { return parts_; }
  /// Bytes skipped while looking for a boundary (garbage between parts, preamble).
  int64_t skipped_bytes() const { return skipped_; }
  /// Bytes held between calls: at most a part (max_part_bytes) and the delimiter after it, or a
  /// header block (max_header_bytes) and its blank line, whatever the stream.
  size_t buffered_bytes() const { return buffer_.size() - start_; }

 private:
  enum class State {
    kSeekBoundary,
    kBoundaryLine,
    kHeaders,
    kBodyWithLength,
    kBodyScan,
    kFinished
  };
  // Each step consumes from the buffer; false = needs more bytes.
  bool SeekBoundary();
  bool BoundaryLine();
  bool Headers();
  bool BodyWithLength(std::vector<MultipartPart>* parts);
  bool BodyScan(std::vector<MultipartPart>* parts);
  std::string_view Pending() const { return std::string_view(buffer_).substr(start_); }
  void Consume(size_t n) { start_ += n; }
  bool Fail(std::string why);

  MultipartParserOptions options_;
  std::string delimiter_;       // "--" + boundary
  std::string body_delimiter_;  // "\r\n--" + boundary: the end of a part without a length
  std::string buffer_;
  size_t start_ = 0;      // first unconsumed byte of buffer_
  size_t scan_from_ = 0;  // offset into Pending() where the next search may start
  State state_ = State::kSeekBoundary;
  std::optional<size_t> content_length_;
  std::string content_type_;
  std::string error_;
  int64_t parts_ = 0;
  int64_t skipped_ = 0;
};

}  // namespace tsc
