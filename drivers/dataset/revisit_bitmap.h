#pragma once
// Loop-closure ground truth as RTAB-Map and the loop-closure benchmarks built on it ship it: an
// N x N bitmap for N frames whose pixel (row i, column j) is white when frame i shows the place
// frame j showed (lower triangular: j < i). ../shared/data/rtabmap-loop has one beside its
// revisits.csv. Read as revisits.csv is, when a folder has no revisits.csv: a user with such a
// sequence scores it without converting anything.

#include <filesystem>
#include <vector>

namespace tsc {

/// Name of the bitmap in a dataset folder.
inline constexpr const char* kRevisitBitmapName = "groundtruth.bmp";

/// Per frame, the earlier frames it revisits (0-based, ascending), from the uncompressed
/// Windows bitmap at `file` (1, 8, 24 or 32 bits a pixel; bottom-up or top-down rows) of
/// `frames` x `frames` pixels. A pixel counts when its grey level (through the palette, for 1
/// and 8 bits) is at least half white; entries on or above the diagonal are ignored (some
/// benchmark bitmaps are symmetric). Rows are read one at a time: memory stays a row and the
/// revisits, whatever the header claims. Throws DatasetError naming `file` for anything else
/// (another size, compression, a header or pixel data cut short).
std::vector<std::vector<int>> ReadRevisitBitmap(const std::filesystem::path& file, int frames);

}  // namespace tsc
