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
    Descriptor coherence;
    for (size_t j = 0; j < views.size(); ++j) {
      surface.Observe(views[j]);
      // A sweep: the first view alone gives the coherence descriptor (Pipeline::AccumulateView).
      if (j == 0 && views.size() > 1) coherence = computer.Compute(surface);
    }
    if (surface.features().IndexOf(Feature::kIntensity) >= 0) {
      out.view = FinishBasePoint(surface, computer);
    } else {  // a classification feature set without intensity: no reliability statistics
      out.view.descriptor = computer.Compute(surface);
      surface.Reset();
    }
    out.view.coherence = std::move(coherence);
    out.descriptor_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    return out;
  } catch (const std::exception& e) {
    surface.Reset();
    throw DatasetError("frame " + std::to_string(i + 1) + " (" + dataset.image_path(i).string() +
                       "): " + e.what());
  }
}

}  // namespace tsc
