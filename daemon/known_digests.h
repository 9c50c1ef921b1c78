#pragma once
// A set of place body digests (BodyDigest). A receiver holds one for each peer for as long as
// it runs, the bodies it keeps of that peer (PeerExchange), and the exchange builds a few more
// while it assembles a memory: as a sorted vector it takes 8 bytes a body, where a hash set
// took about 40 (0.4 MB for a peer of 10⁴ places, against DESIGN §8's RSS bar).

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <vector>

namespace tsc {

class KnownDigests {
 public:
  KnownDigests() = default;
  /// The digests of [first, last), duplicates once.
  template <std::input_iterator It>
  KnownDigests(It first, It last) : digests_(first, last) {
    Normalise();
  }
  explicit KnownDigests(std::vector<int64_t> digests) : digests_(std::move(digests)) {
    Normalise();
  }

  bool contains(int64_t digest) const {
    return std::binary_search(digests_.begin(), digests_.end(), digest);
  }
  size_t size() const { return digests_.size(); }
  bool empty() const { return digests_.empty(); }
  /// In increasing order.
  auto begin() const { return digests_.begin(); }
  auto end() const { return digests_.end(); }
  bool operator==(const KnownDigests&) const = default;

 private:
  void Normalise() {
    std::sort(digests_.begin(), digests_.end());
    digests_.erase(std::unique(digests_.begin(), digests_.end()), digests_.end());
    digests_.shrink_to_fit();
  }

  std::vector<int64_t> digests_;  // sorted, unique
};

}  // namespace tsc
