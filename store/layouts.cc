#include "store/layouts.h"

#include <span>
#include <stdexcept>
#include <string>
#include <utility>

namespace tsc::store_internal {
namespace {

constexpr int32_t kCompactSamples = -1;  // EncodeSamples' marker

/// rows x cols member views' values of `value_bytes` each, checked against what `r` holds
/// before anything is allocated or walked: a place keeps at least one view of at least one
/// value (0 x 2·10⁹ views held no bytes, yet took seconds to check, found by fuzz_store).
/// int32 sizes: their product times a value's bytes fits 64 bits.
size_t CountOf(const BlobReader& r, int32_t rows, int32_t cols, size_t value_bytes) {
  if (rows <= 0 || cols <= 0) {
    throw BlobError("views of size " + std::to_string(rows) + " x " + std::to_string(cols) +
                    ": at least 1 x 1");
  }
  const uint64_t count = static_cast<uint64_t>(rows) * static_cast<uint64_t>(cols);
  if (count > r.remaining() / value_bytes) {
    throw BlobError(std::to_string(rows) + " x " + std::to_string(cols) + " values need " +
                    std::to_string(count * value_bytes) + " bytes, " +
                    std::to_string(r.remaining()) + " left");
  }
  return static_cast<size_t>(count);
}

template <typename M>
M Finite(M m) {
  if (!m.allFinite()) throw BlobError("non-finite value");
  return m;
}

/// Pairs of values read as one (first, second) each; an odd count is refused as `what`.
template <Arithmetic T, typename Pair, typename Make>
std::vector<Pair> DecodePairs(BlobReader& r, const char* what, Make make) {
  const std::vector<T> values = r.TakeRest<T>();
  if (values.size() % 2 != 0) throw BlobError(std::string("odd number of ") + what);
  std::vector<Pair> out;
  out.reserve(values.size() / 2);
  for (size_t i = 0; i < values.size(); i += 2) out.push_back(make(values[i], values[i + 1]));
  return out;
}

/// Each pair as its two values, `split` giving them.
template <Arithmetic T, typename Pair, typename Split>
Bytes EncodePairs(const std::vector<Pair>& pairs, Split split) {
  BlobWriter w;
  for (const Pair& p : pairs) {
    const auto [first, second] = split(p);
    w.PutOne(static_cast<T>(first));
    w.PutOne(static_cast<T>(second));
  }
  return w.Finish();
}

}  // namespace

Bytes EncodeFloats(const Eigen::Ref<const Eigen::MatrixXf>& values) {
  return EncodeArray(std::span<const float>(values.data(), static_cast<size_t>(values.size())));
}

Eigen::VectorXf DecodeVector(BlobReader& r, int64_t dim) {
  if (r.remaining() % sizeof(float) != 0 ||
      (dim >= 0 && r.remaining() != static_cast<size_t>(dim) * sizeof(float))) {
    throw BlobError("blob of " + std::to_string(r.remaining()) + " bytes is not " +
                    (dim >= 0 ? std::to_string(dim) : std::string("a whole number of")) +
                    " float32 values");
  }
  Eigen::VectorXf out(static_cast<Eigen::Index>(r.remaining() / sizeof(float)));
  r.TakeInto(out.data(), static_cast<size_t>(out.size()));
  return Finite(std::move(out));
}

Eigen::MatrixXf DecodeMatrix(BlobReader& r, int32_t rows, int32_t cols) {
  if (rows < 0 || cols < 0 ||
      static_cast<uint64_t>(rows) * static_cast<uint64_t>(cols) * sizeof(float) != r.remaining()) {
    throw BlobError("blob of " + std::to_string(r.remaining()) + " bytes is not " +
                    std::to_string(rows) + " x " + std::to_string(cols) + " float32 values");
  }
  Eigen::MatrixXf out(rows, cols);
  r.TakeInto(out.data(), static_cast<size_t>(out.size()));
  r.ExpectEnd();
  return Finite(std::move(out));
}

Bytes EncodeSamples(const CompactViews& v) {
  BlobWriter w;
  w.PutOne(kCompactSamples)
      .PutOne(static_cast<int32_t>(v.rows()))
      .PutOne(static_cast<int32_t>(v.cols()))
      .PutOne(static_cast<int32_t>(v.shift()));
  const std::vector<int16_t> wide = v.Wide();
  w.Put(std::span<const int16_t>(wide));
  return w.Finish();
}

CompactViews DecodeSamples(BlobReader& r) {
  try {
    const int32_t first = r.TakeOne<int32_t>();
    if (first == kCompactSamples) {
      const int32_t rows = r.TakeOne<int32_t>(), cols = r.TakeOne<int32_t>();
      const int32_t shift = r.TakeOne<int32_t>();
      std::vector<int16_t> values = r.Take<int16_t>(CountOf(r, rows, cols, sizeof(int16_t)));
      r.ExpectEnd();
      return CompactViews(rows, cols, shift, values);
    }
    const int32_t cols = r.TakeOne<int32_t>();
    const size_t count = CountOf(r, first, cols, sizeof(float));
    Eigen::MatrixXf floats(first, cols);
    r.TakeInto(floats.data(), count);
    r.ExpectEnd();
    return CompactViews(Finite(std::move(floats)));
  } catch (const std::invalid_argument& e) {  // views no encoding gives, or too large
    throw BlobError(e.what());
  }
}

Bytes EncodeTransitions(const std::vector<TransitionRegion>& regions) {
  return EncodePairs<int64_t>(regions,
                              [](const TransitionRegion& t) { return std::pair(t.first, t.last); });
}

std::vector<TransitionRegion> DecodeTransitions(BlobReader& r) {
  return DecodePairs<int64_t, TransitionRegion>(r, "region bounds",
                                                [](int64_t first, int64_t last) {
                                                  return TransitionRegion{first, last};
                                                });
}

Bytes EncodeSlink(const Slink& slink) {
  std::vector<int32_t> pi(slink.pi().begin(), slink.pi().end());
  return BlobWriter()
      .Put(std::span<const int32_t>(pi))
      .Put(std::span<const double>(slink.lambda()))
      .Finish();
}

Slink DecodeSlink(BlobReader& r, size_t expected) {
  if (r.remaining() != expected * (sizeof(int32_t) + sizeof(double))) {
    throw BlobError("blob of " + std::to_string(r.remaining()) + " bytes is not a SLINK " +
                    "state of " + std::to_string(expected) + " places");
  }
  const std::vector<int32_t> pi = r.Take<int32_t>(expected);
  std::vector<double> lambda = r.Take<double>(expected);
  try {
    return Slink(std::vector<int>(pi.begin(), pi.end()), std::move(lambda));
  } catch (const std::invalid_argument& e) {  // a pointer representation SLINK never builds
    throw BlobError(e.what());
  }
}

Bytes EncodeSources(const std::vector<PlaceId>& sources) {
  return EncodePairs<uint32_t>(sources,
                               [](const PlaceId& id) { return std::pair(id.robot, id.local); });
}

std::vector<PlaceId> DecodeSources(BlobReader& r) {
  return DecodePairs<uint32_t, PlaceId>(r, "robot/local values",
                                        [](uint32_t robot, uint32_t local) {
                                          return PlaceId{robot, local};
                                        });
}

}  // namespace tsc::store_internal
