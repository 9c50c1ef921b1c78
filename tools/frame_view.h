#pragma once
// A dataset frame turned into what the pipeline sees of it, for the offline tools that
// compute descriptors before they run anything on them (tsc eval, tsc classify).

#include <vector>

#include "core/pipeline/pipeline.h"
#include "drivers/dataset/dataset.h"

namespace tsc {

/// The views of frame `i` (0-based) of `dataset` (one without a pan sweep); a DatasetError
/// names the frame and its file.
std::vector<Observation> LoadFrame(const Dataset& dataset, int i);

/// The base point view of one frame (a frame, with all the views of its sweep, is one base
/// point; DescribeBasePoint) and the milliseconds its descriptor took (observing it in
/// `surface`, computing, resetting; not the loading). The intensity statistics stay zero when
/// the feature set has no intensity feature.
struct TimedView {
  BasePointView view;
  double descriptor_ms = 0.0;
};
/// Describes frame `i` of `dataset` through `surface`, which is left reset. Throws
/// DatasetError naming the frame and its file when the frame cannot be read or described.
TimedView DescribeFrame(const Dataset& dataset, int i, BubbleSurface& surface,
                        const DescriptorComputer& computer);

}  // namespace tsc
