#!/usr/bin/env bash
# tscd@.service passes `systemd-analyze verify` as instance tscd@1.service, with no warning
# about the unit (unknown keys are only warnings there, so any line naming it fails the test).
#   verify_unit_test.sh SYSTEMD_ANALYZE UNIT_FILE TSCD_BINARY
set -euo pipefail
analyze=$1 unit=$2 tscd=$3
[[ -x ${tscd} ]] || { echo "FAIL: ${tscd} is not built"; exit 1; }
grep -q "^ExecStart=${tscd} " "${unit}" ||
  { echo "FAIL: ${unit}: ExecStart is not ${tscd}"; exit 1; }
dir=$(dirname "${unit}")
status=0
# The instance is looked up from the template beside it.
output=$(cd "${dir}" && "${analyze}" verify "${dir}/tscd@1.service" 2>&1) || status=$?
echo "${output}"
[[ ${status} -eq 0 ]] || { echo "FAIL: systemd-analyze verify exited ${status}"; exit 1; }
if grep -q -e 'tscd@' -e "${dir}" <<<"${output}"; then
  echo "FAIL: systemd-analyze verify warns about the unit"
  exit 1
fi
echo "PASS: systemd-analyze verify tscd@1.service"
