#include "tools/frame_view.h"

#include <chrono>
#include <string>

namespace tsc {

std::vector<Observation> LoadFrame(const Dataset& dataset, int i) {
  try {
    return dataset.Load(i);
  } catch (const DatasetError& e) {  // names the file already
    throw DatasetError("frame " + std::to_string(i + 1) + ": " + e.what());
  }
}

TimedView DescribeFrame(const Dataset& dataset, int i, BubbleSurface& surface,
                        const DescriptorComputer& computer) {
  const std::vector<Observation> views = LoadFrame(dataset, i);
  using Clock = std::chrono::steady_clock;
  const Clock::time_point t0 = Clock::now();
  try {
    TimedView out;
    out.view = DescribeBasePoint(views, surface, computer);
    out.descriptor_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    return out;
  } catch (const std::exception& e) {  // the surface is reset already
    throw DatasetError("frame " + std::to_string(i + 1) + " (" + dataset.image_path(i).string() +
                       "): " + e.what());
  }
}

}  // namespace tsc
