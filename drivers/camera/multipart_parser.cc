#include "drivers/camera/multipart_parser.h"

#include <algorithm>
#include <cctype>
#include <stdexcept>

namespace tsc {
namespace {

bool IEquals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

int64_t CountNonNewline(std::string_view s) {
  return static_cast<int64_t>(
      std::count_if(s.begin(), s.end(), [](char c) { return c != '\r' && c != '\n'; }));
}

// The decimal value of `s`, or nullopt when it is not all digits or exceeds `limit`.
std::optional<size_t> ParseLength(std::string_view s, size_t limit, bool* too_large) {
  *too_large = false;
  if (s.empty() || s.size() > 19) {
    *too_large = !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
      return std::isdigit(static_cast<unsigned char>(c)) != 0;
    });
    return std::nullopt;
  }
  size_t v = 0;
  for (char c : s) {
    if (std::isdigit(static_cast<unsigned char>(c)) == 0) return std::nullopt;
    v = v * 10 + static_cast<size_t>(c - '0');
  }
  if (v > limit) {
    *too_large = true;
    return std::nullopt;
  }
  return v;
}

}  // namespace

void MultipartParserOptions::Validate() const {
  if (max_part_bytes == 0) throw std::invalid_argument("multipart: max_part_bytes must be > 0");
  if (max_header_bytes < 16) {
    throw std::invalid_argument("multipart: max_header_bytes " + std::to_string(max_header_bytes) +
                                " must be at least 16");
  }
}

std::optional<std::string> BoundaryFromContentType(std::string_view content_type) {
  const size_t semi = content_type.find(';');
  const std::string_view type = Trim(content_type.substr(0, semi));
  if (type.size() < 10 || !IEquals(type.substr(0, 10), "multipart/")) return std::nullopt;
  std::string_view rest = semi == std::string_view::npos ? "" : content_type.substr(semi + 1);
  while (!rest.empty()) {
    const size_t next = rest.find(';');
    const std::string_view param = Trim(rest.substr(0, next));
    rest = next == std::string_view::npos ? "" : rest.substr(next + 1);
    const size_t eq = param.find('=');
    if (eq == std::string_view::npos || !IEquals(Trim(param.substr(0, eq)), "boundary")) continue;
    std::string_view value = Trim(param.substr(eq + 1));
    if (value.size() >= 2 && value.front() == '"' && value.back() == '"') {
      value = value.substr(1, value.size() - 2);
    }
    if (value.empty()) return std::nullopt;
    return std::string(value);
  }
  return std::nullopt;
}

MultipartParser::MultipartParser(std::string boundary, MultipartParserOptions options)
    : options_(options), delimiter_("--" + boundary), body_delimiter_("\r\n--" + boundary) {
  options_.Validate();
  if (boundary.empty()) throw std::invalid_argument("multipart: the boundary is empty");
}

bool MultipartParser::Fail(std::string why) {
  error_ = std::move(why);
  buffer_.clear();
  start_ = 0;
  return false;
}

bool MultipartParser::Feed(std::string_view bytes, std::vector<MultipartPart>* parts) {
  if (failed()) return false;
  if (state_ == State::kFinished) return true;
  buffer_.append(bytes);
  for (bool progress = true; progress && !failed();) {
    switch (state_) {
      case State::kSeekBoundary:
        progress = SeekBoundary();
        break;
      case State::kBoundaryLine:
        progress = BoundaryLine();
        break;
      case State::kHeaders:
        progress = Headers();
        break;
      case State::kBodyWithLength:
        progress = BodyWithLength(parts);
        break;
      case State::kBodyScan:
        progress = BodyScan(parts);
        break;
      case State::kFinished:
        progress = false;
        break;
    }
  }
  if (failed()) return false;
  if (state_ == State::kFinished) {
    buffer_.clear();
    start_ = 0;
  } else if (start_ > 0) {
    buffer_.erase(0, start_);
    start_ = 0;
  }
  return true;
}

bool MultipartParser::SeekBoundary() {
  const std::string_view pending = Pending();
  const size_t at = pending.find(delimiter_, scan_from_);
  if (at == std::string_view::npos) {
    // Keep what could be the start of a delimiter split across two reads.
    const size_t keep = std::min(pending.size(), delimiter_.size() - 1);
    skipped_ += CountNonNewline(pending.substr(0, pending.size() - keep));
    Consume(pending.size() - keep);
    scan_from_ = 0;
    return false;
  }
  skipped_ += CountNonNewline(pending.substr(0, at));  // the CRLF ending a part is expected
  Consume(at + delimiter_.size());
  scan_from_ = 0;
  state_ = State::kBoundaryLine;
  return true;
}

bool MultipartParser::BoundaryLine() {
  const std::string_view pending = Pending();
  if (pending.size() < 2) return false;
  if (pending.substr(0, 2) == "--") {
    state_ = State::kFinished;
    return false;
  }
  // Only transport padding (RFC 2046), at most max_header_bytes of it, may follow the boundary
  // on its line; anything else means the delimiter was the prefix of some other text. The same
  // verdict whatever the reads: without a CRLF yet, wait while the padding could still fit
  // (a CR may be its last byte).
  const size_t eol = pending.find("\r\n");
  if (eol == std::string_view::npos && pending.size() <= options_.max_header_bytes + 1) {
    return false;
  }
  if (eol == std::string_view::npos || eol > options_.max_header_bytes ||
      !Trim(pending.substr(0, eol)).empty()) {
    skipped_ += static_cast<int64_t>(delimiter_.size());
    state_ = State::kSeekBoundary;
    return true;
  }
  Consume(eol + 2);
  state_ = State::kHeaders;
  return true;
}

bool MultipartParser::Headers() {
  const std::string_view pending = Pending();
  size_t end = 0;  // length of the header block including its blank line
  if (pending.substr(0, 2) == "\r\n") {
    end = 2;  // a part without headers
  } else {
    const size_t at = pending.find("\r\n\r\n");
    if (at == std::string_view::npos) {
      // Refused once the block cannot fit any more, whatever the reads: the blank line may have
      // begun in the last three bytes.
      if (pending.size() > options_.max_header_bytes + 3) {
        return Fail("multipart: a part's header block exceeds " +
                    std::to_string(options_.max_header_bytes) + " bytes");
      }
      return false;
    }
    end = at + 4;
  }
  if (end > options_.max_header_bytes + 4) {
    return Fail("multipart: a part's header block exceeds " +
                std::to_string(options_.max_header_bytes) + " bytes");
  }
  content_length_.reset();
  content_type_.clear();
  std::string_view block = pending.substr(0, end - 2);
  while (!block.empty()) {
    const size_t eol = block.find("\r\n");
    const std::string_view line = block.substr(0, eol);
    block = eol == std::string_view::npos ? "" : block.substr(eol + 2);
    const size_t colon = line.find(':');
    if (colon == std::string_view::npos) continue;  // tolerate junk header lines
    const std::string_view name = Trim(line.substr(0, colon));
    const std::string_view value = Trim(line.substr(colon + 1));
    if (IEquals(name, "Content-Length")) {
      bool too_large = false;
      content_length_ = ParseLength(value, options_.max_part_bytes, &too_large);
      if (!content_length_) {
        return Fail(too_large
                        ? "multipart: Content-Length " + std::string(value) +
                              " exceeds the limit of " + std::to_string(options_.max_part_bytes) +
                              " bytes"
                        : "multipart: Content-Length '" + std::string(value) + "' is not a number");
      }
    } else if (IEquals(name, "Content-Type")) {
      content_type_ = std::string(value);
    }
  }
  Consume(end);
  scan_from_ = 0;
  state_ = content_length_ ? State::kBodyWithLength : State::kBodyScan;
  return true;
}

bool MultipartParser::BodyWithLength(std::vector<MultipartPart>* parts) {
  const std::string_view pending = Pending();
  if (pending.size() < *content_length_) return false;
  parts->push_back(MultipartPart{content_type_, std::string(pending.substr(0, *content_length_))});
  ++parts_;
  Consume(*content_length_);
  state_ = State::kSeekBoundary;
  return true;
}

bool MultipartParser::BodyScan(std::vector<MultipartPart>* parts) {
  const std::string_view pending = Pending();
  const size_t at = pending.find(body_delimiter_, scan_from_);
  if (at == std::string_view::npos) {
    if (pending.size() > options_.max_part_bytes + body_delimiter_.size()) {
      return Fail("multipart: a part without Content-Length grew past the limit of " +
                  std::to_string(options_.max_part_bytes) + " bytes");
    }
    // Resume the search where a delimiter split across reads could start.
    scan_from_ =
        pending.size() >= body_delimiter_.size() ? pending.size() - body_delimiter_.size() + 1 : 0;
    return false;
  }
  if (at > options_.max_part_bytes) {
    return Fail("multipart: a part without Content-Length grew past the limit of " +
                std::to_string(options_.max_part_bytes) + " bytes");
  }
  parts->push_back(MultipartPart{content_type_, std::string(pending.substr(0, at))});
  ++parts_;
  Consume(at + 2);  // leaves "--boundary" for SeekBoundary
  scan_from_ = 0;
  state_ = State::kSeekBoundary;
  return true;
}

}  // namespace tsc
