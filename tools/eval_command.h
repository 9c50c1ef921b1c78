#pragma once
// `tsc eval`: runs the pipeline on a fresh memory and scores it (DESIGN §7.1b, §7.2).

#include <string>
#include <vector>

namespace tsc {

/// Runs `tsc eval DATASET --json FILE [--plots DIR] [--sweep FROM:TO:STEP] [--config F]
/// [--set k=v]...` with the arguments after the command name: writes the figures as JSON
/// (and plots), prints a summary to stdout. Throws UsageError, ConfigError, DatasetError or
/// std::runtime_error (RunReportingErrors turns them into exit codes).
int RunEvalCommand(const std::vector<std::string>& args);

}  // namespace tsc
