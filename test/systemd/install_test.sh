#!/usr/bin/env bash
# `cmake --install BUILD --component tscd` into a DESTDIR puts every file where the unit and
# the README expect it; a second install keeps an edited tscd.ini; the installed lcm-spy-tsc
# and tscd-logdump.jar find the installed types jar.
#   install_test.sh CMAKE BUILD DESTDIR BINDIR DATADIR SYSCONFDIR UNITDIR SYSUSERSDIR
#                   JAVA(yes|no) PROGRAMS(comma-separated) LIBDIR
set -euo pipefail
cmake=$1 build=$2 dest=$3 bindir=$4 datadir=$5 sysconfdir=$6 unitdir=$7 sysusersdir=$8
java=$9 programs=${10} libdir=${11}

failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
expect_file() { [[ -f ${dest}$1 ]] && echo "ok: $1" || fail "missing $1"; }
expect_exec() { [[ -f ${dest}$1 && -x ${dest}$1 ]] && echo "ok: $1 (executable)" ||
                  fail "missing or not executable $1"; }

rm -rf "${dest}"
DESTDIR=${dest} "${cmake}" --install "${build}" --component tscd >"${dest}.log" 2>&1 ||
  { cat "${dest}.log"; echo "FAIL: cmake --install"; exit 1; }

IFS=, read -r -a program_list <<<"${programs}"
for program in "${program_list[@]}"; do
  expect_exec "${bindir}/${program}"
done
expect_exec "${bindir}/lcm-spy-tsc"
# OpenCV's video I/O, which the installed tscd loads for camera.source device or video
# (drivers/camera/opencv_video.h): the installed program finds the installed module. A file
# that is no video gets OpenCV's refusal, not a missing module.
expect_file "${libdir}/tscd/libtscd_opencv_video.so"
if [[ ,${programs}, == *,tscd,* ]]; then
  not_video=${dest}.not-a-video
  echo "not a video" >"${not_video}"
  out=$("${dest}${bindir}/tscd" --robot 1 --state-dir "${dest}.state" --set lcm.url=memq:// \
          --set camera.source=video --set "camera.path=${not_video}" 2>&1) && status=0 ||
    status=$?
  [[ ${status} -ne 0 && ${out} == *"OpenCV cannot open it"* && ${out} != *"cannot load"* ]] &&
    echo "ok: the installed tscd loads the installed video module" ||
    fail "installed tscd with camera.source=video (exit ${status}): ${out}"
fi
expect_file "${unitdir}/tscd@.service"
expect_file "${sysusersdir}/tscd.conf"
expect_file "${sysconfdir}/tscd/tscd.ini"
expect_file "${sysconfdir}/tscd/tscd.ini.default"

unit=${dest}${unitdir}/tscd@.service
if [[ -f ${unit} ]]; then
  grep -q "^ExecStart=${bindir}/tscd --config ${sysconfdir}/tscd/tscd.ini --robot %i " "${unit}" &&
    echo "ok: ExecStart runs ${bindir}/tscd with ${sysconfdir}/tscd/tscd.ini" ||
    fail "ExecStart of ${unitdir}/tscd@.service: $(grep '^ExecStart=' "${unit}")"
  ! grep -q '@[A-Z_]*@' "${unit}" || fail "unconfigured @VARIABLE@ left in the unit"
fi
grep -q '^u *tscd ' "${dest}${sysusersdir}/tscd.conf" 2>/dev/null && echo "ok: sysusers user tscd" ||
  fail "no user tscd in ${sysusersdir}/tscd.conf"

if [[ ${java} == yes ]]; then
  expect_file "${datadir}/java/tscd-lcmtypes.jar"
  expect_file "${datadir}/java/tscd-logdump.jar"
  classpath=$("${dest}${bindir}/lcm-spy-tsc" --print-classpath 2>&1) ||
    fail "installed lcm-spy-tsc: ${classpath}"
  [[ ${classpath} == *"${dest}${bindir}/../share/java/tscd-lcmtypes.jar"* ||
     ${classpath} == *"${dest}${datadir}/java/tscd-lcmtypes.jar"* ]] &&
    echo "ok: installed lcm-spy-tsc uses the installed jar" ||
    fail "installed lcm-spy-tsc class path: ${classpath}"
  # The manifest's Class-Path must reach the installed types jar beside it.
  java -jar "${dest}${datadir}/java/tscd-logdump.jar" --help >/dev/null 2>"${dest}.java.err" &&
    echo "ok: installed tscd-logdump.jar loads the tsc types" ||
    fail "installed tscd-logdump.jar: $(cat "${dest}.java.err")"
fi

# A second install keeps the operator's tscd.ini and refreshes tscd.ini.default.
ini=${dest}${sysconfdir}/tscd/tscd.ini
if [[ -f ${ini} ]]; then
  echo "# edited by the operator" >>"${ini}"
  DESTDIR=${dest} "${cmake}" --install "${build}" --component tscd >"${dest}.log" 2>&1 ||
    fail "second cmake --install"
  grep -q '^# edited by the operator' "${ini}" && echo "ok: reinstall keeps an edited tscd.ini" ||
    fail "reinstall overwrote ${sysconfdir}/tscd/tscd.ini"
fi

if [[ ${failures} -ne 0 ]]; then
  echo "FAIL: ${failures} problems; installed tree in ${dest}"
  exit 1
fi
echo "PASS: cmake --install into DESTDIR"
