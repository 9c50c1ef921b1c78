#pragma once
// A memory whose places were learned in another descriptor space than the configuration's:
// other bubble features (another descriptor dimension) or another memory.view_basis. No
// retry and no repair makes such a memory usable under this configuration, so callers tell
// it apart from a damaged store or a bad peer: tscd exits with a configuration error instead
// of running on without its store, and `tsc inspect` reads the memory in its own space.

#include <stdexcept>
#include <string>

namespace tsc {

class DescriptorSpaceMismatch : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

}  // namespace tsc
