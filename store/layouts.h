#pragma once
// How each value the store keeps in a blob is laid out, written and read in one place
// (internal to tscd::store). Decoders take a BlobReader over the cell and refuse what no
// encoder writes with a BlobError (sizes checked before anything is allocated), which Row
// names with its table, row and column.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/detect/place_detector.h"
#include "core/memory/compact_views.h"
#include "core/memory/place_id.h"
#include "core/memory/slink.h"
#include "store/blob.h"

namespace tsc::store_internal {

/// float32 values of a vector, or of a matrix column-major.
Bytes EncodeFloats(const Eigen::Ref<const Eigen::MatrixXf>& values);

/// float32 values; `dim` ≥ 0 requires that many. Values must be finite.
Eigen::VectorXf DecodeVector(BlobReader& r, int64_t dim = -1);

/// float32 values column-major, `rows` x `cols` given beside the blob (int32, so the byte
/// count cannot overflow). Values must be finite.
Eigen::MatrixXf DecodeMatrix(BlobReader& r, int32_t rows, int32_t cols);

/// Member views as the memory keeps them (core/memory/compact_views.h): the marker -1, int32
/// rows, int32 cols, int32 shift, then rows x cols int16 column-major. Schema versions before
/// 4 wrote int32 rows, int32 cols and float32 values (a row count is never negative, so the
/// marker tells the layouts apart); both are read.
Bytes EncodeSamples(const CompactViews& v);
CompactViews DecodeSamples(BlobReader& r);

/// int64 first, int64 last of each region.
Bytes EncodeTransitions(const std::vector<TransitionRegion>& regions);
std::vector<TransitionRegion> DecodeTransitions(BlobReader& r);

/// int32 π[n] then float64 λ[n], for `expected` = n learned places.
Bytes EncodeSlink(const Slink& slink);
Slink DecodeSlink(BlobReader& r, size_t expected);

/// uint32 robot, uint32 local of each source place.
Bytes EncodeSources(const std::vector<PlaceId>& sources);
std::vector<PlaceId> DecodeSources(BlobReader& r);

}  // namespace tsc::store_internal
