#pragma once
// A fuzz input read as a byte stream plus the sizes of the reads that deliver it, so a target
// drives an incremental parser across read boundaries the fuzzer chooses (a TCP stream is cut
// anywhere). Layout: byte 0 holds n (mod 8), the next n bytes are read sizes (0 = an empty
// read), used in turn; the rest is the stream. With n = 0, or only zero sizes, the stream
// arrives in one read.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

namespace tsc::fuzz {

struct ChunkedInput {
  std::string_view stream;
  std::vector<size_t> read_sizes;  ///< empty: the stream arrives in one read

  /// Calls read(chunk) for each read in order; the chunks make up `bytes` exactly.
  template <typename Read>
  void ForEachRead(std::string_view bytes, Read&& read) const {
    const bool any =
        std::any_of(read_sizes.begin(), read_sizes.end(), [](size_t n) { return n > 0; });
    if (!any) {
      read(bytes);
      return;
    }
    for (size_t i = 0; !bytes.empty(); ++i) {
      const size_t n = std::min(read_sizes[i % read_sizes.size()], bytes.size());
      read(bytes.substr(0, n));
      bytes.remove_prefix(n);
    }
  }
  template <typename Read>
  void ForEachRead(Read&& read) const {
    ForEachRead(stream, read);
  }
};

inline ChunkedInput SplitChunked(const uint8_t* data, size_t size) {
  ChunkedInput in;
  if (size == 0) return in;
  const size_t n = std::min<size_t>(data[0] % 8, size - 1);
  for (size_t i = 0; i < n; ++i) in.read_sizes.push_back(data[1 + i]);
  in.stream = std::string_view(reinterpret_cast<const char*>(data) + 1 + n, size - 1 - n);
  return in;
}

}  // namespace tsc::fuzz
