#pragma once
// The shipped defaults (config/tscd.ini, untouched) as the offline tools apply them to a
// dataset: place detection's τ_p follows the dataset's base-point spacing (tsc run / eval).

#include "drivers/dataset/dataset.h"
#include "settings/settings.h"
#include "tools/eval.h"

namespace tsc::testing_support {

inline PipelineOptions DefaultProfile(const Dataset& dataset) {
  return OptionsForDataset(LoadSettings(std::nullopt, {}), dataset, /*say=*/nullptr);
}

}  // namespace tsc::testing_support
