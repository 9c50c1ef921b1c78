#pragma once
// The shipped defaults (config/tscd.ini, untouched) as the offline tools apply them to a
// dataset: place detection's τ_p follows the dataset's base-point spacing (tsc run / eval).

#include <stdexcept>

#include "drivers/dataset/dataset.h"
#include "settings/settings.h"
#include "tools/eval.h"

namespace tsc::testing_support {

/// For a dataset whose every frame is a base point; a dense camera's is thinned first
/// (PrepareDataset), so its tests take PrepareDataset's dataset with the options.
inline PipelineOptions DefaultProfile(const Dataset& dataset) {
  PreparedDataset prepared = PrepareDataset(LoadSettings(std::nullopt, {}), dataset, nullptr);
  if (prepared.dataset.size() != dataset.size()) {
    throw std::logic_error("DefaultProfile: " + dataset.folder().string() +
                           " is a dense camera's; take PrepareDataset's frames");
  }
  return std::move(prepared.options);
}

}  // namespace tsc::testing_support
