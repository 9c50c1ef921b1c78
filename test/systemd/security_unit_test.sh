#!/usr/bin/env bash
# tscd@.service's sandbox: `systemd-analyze security --offline=true` exposure at most
# THRESHOLD/10 (see TSCD_UNIT_EXPOSURE_MAX in CMakeLists.txt for the reasoning).
#   security_unit_test.sh SYSTEMD_ANALYZE UNIT_FILE THRESHOLD
set -euo pipefail
analyze=$1 unit=$2 threshold=$3
status=0
output=$("${analyze}" security --offline=true --threshold="${threshold}" "${unit}" 2>&1) ||
  status=$?
# The checks that cost exposure, then the verdict.
grep -E '^✗|Overall' <<<"${output}" || true
if [[ ${status} -ne 0 ]]; then
  echo "FAIL: exposure above ${threshold}/10 (exit ${status})"
  exit 1
fi
echo "PASS: exposure at most ${threshold}/10"
