#pragma once
// `tsc run`: runs the TSC pipeline over a dataset folder into a store (DESIGN §7.2).

#include <string>
#include <vector>

namespace tsc {

/// Runs `tsc run DATASET --db FILE [--events F] [--robot ID] [--config F] [--set k=v]...`
/// with the arguments after the command name: every frame through the pipeline, each result
/// committed to the store (a store holding a memory is continued). Prints --help and a
/// summary to stdout. Throws UsageError, ConfigError, DatasetError, StoreError or
/// std::runtime_error (RunReportingErrors turns them into exit codes).
int RunPipelineCommand(const std::vector<std::string>& args);

}  // namespace tsc
