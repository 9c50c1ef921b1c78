#!/usr/bin/env bash
# `cmake --install BUILD --component tscd --prefix P` into a DESTDIR, for two prefixes: the unit
# follows the prefix given at install time (ExecStart = P/bin/tscd, --config in the
# GNUInstallDirs sysconfdir of P: /etc for /usr, /etc/opt/tscd for /opt/tscd), the
# configuration lands where the unit reads it, passes `systemd-analyze verify`, and the
# installed tscd refuses to start on the installed configuration until a camera is chosen.
#   install_prefixes_test.sh CMAKE BUILD WORKDIR SYSTEMD_ANALYZE
set -euo pipefail
cmake=$1 build=$2 work=$3 analyze=$4

mkdir -p "${work}"
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
ok() { echo "ok: $*"; }

check_prefix() {
  local prefix=$1 sysconfdir=$2
  local dest=${work}/destdir${prefix//\//_}
  rm -rf "${dest}"
  DESTDIR=${dest} "${cmake}" --install "${build}" --component tscd --prefix "${prefix}" \
    >"${dest}.log" 2>&1 || { cat "${dest}.log"; fail "cmake --install --prefix ${prefix}"; return; }
  local unit=${dest}${prefix}/lib/systemd/system/tscd@.service
  local ini=${sysconfdir}/tscd/tscd.ini
  [[ -f ${unit} ]] || { fail "${prefix}: no ${prefix}/lib/systemd/system/tscd@.service"; return; }
  grep -q "^ExecStart=${prefix}/bin/tscd --config ${ini} --robot %i " "${unit}" &&
    ok "${prefix}: ExecStart runs ${prefix}/bin/tscd with ${ini}" ||
    fail "${prefix}: $(grep '^ExecStart=' "${unit}")"
  [[ -x ${dest}${prefix}/bin/tscd ]] && ok "${prefix}: ${prefix}/bin/tscd installed" ||
    fail "${prefix}: no executable ${prefix}/bin/tscd"
  [[ -f ${dest}${ini} && -f ${dest}${ini}.default ]] && ok "${prefix}: ${ini} installed" ||
    fail "${prefix}: no ${ini} (or ${ini}.default)"
  if [[ ${sysconfdir} == /etc ]]; then
    grep -q '^ConfigurationDirectory=tscd$' "${unit}" && ok "${prefix}: ConfigurationDirectory=tscd" ||
      fail "${prefix}: no ConfigurationDirectory=tscd"
  else
    ! grep -q '^ConfigurationDirectory=' "${unit}" ||
      fail "${prefix}: ConfigurationDirectory= names /etc/tscd, not ${sysconfdir}/tscd"
  fi
  ! grep -q '@[A-Z_]*@' "${unit}" || fail "${prefix}: unconfigured @VARIABLE@ left in the unit"
  # systemd-analyze verify needs ExecStart's binary on this system: verify a copy whose
  # ExecStart is the DESTDIR's binary, the rest unchanged.
  local check=${dest}.verify
  mkdir -p "${check}"
  sed "s#^ExecStart=${prefix}/bin/tscd #ExecStart=${dest}${prefix}/bin/tscd #" "${unit}" \
    >"${check}/tscd@.service"
  local output status=0
  output=$(cd "${check}" && "${analyze}" verify "${check}/tscd@1.service" 2>&1) || status=$?
  if [[ ${status} -ne 0 ]] || grep -q -e 'tscd@' <<<"${output}"; then
    echo "${output}"
    fail "${prefix}: systemd-analyze verify (exit ${status})"
  else
    ok "${prefix}: systemd-analyze verify tscd@1.service"
  fi
  # The installed configuration names no camera: tscd refuses to start (78), saying how to
  # choose one, instead of learning the simulated world.
  grep -q '^source = none$' "${dest}${ini}" && ok "${prefix}: installed camera.source = none" ||
    fail "${prefix}: installed ${ini} does not say camera.source = none"
  status=0
  output=$("${dest}${prefix}/bin/tscd" --config "${dest}${ini}" --state-dir "${dest}/state" 2>&1) ||
    status=$?
  [[ ${status} -eq 78 && ${output} == *"no camera chosen"* && ${output} == *"camera.path"* ]] &&
    ok "${prefix}: tscd on the installed configuration exits 78: ${output}" ||
    fail "${prefix}: tscd on the installed configuration: exit ${status}: ${output}"
  [[ ! -e ${dest}/state/memory.db ]] || fail "${prefix}: a memory was made without a camera"
}

check_prefix /usr /etc
check_prefix /opt/tscd /etc/opt/tscd

if [[ ${failures} -ne 0 ]]; then
  echo "FAIL: ${failures} problems; installed trees in ${work}"
  exit 1
fi
echo "PASS: cmake --install --prefix /usr and /opt/tscd"
