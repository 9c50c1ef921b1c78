#!/usr/bin/env bash
# Every tscd LCM type survives udpm:// → lcm-logger → log file → Java decoding (TscLogDump),
# with the values lcm_publish_all put in (expected_fields.txt); and TscLogDump fails on a
# message that does not decode.
#
#   java_decode_test.sh PUBLISHER LCM_LOGGER JAVA DUMP_JAR EXPECTED WORKDIR
#
# Runs itself inside a private network namespace (unshare -n as root, unshare -rn otherwise)
# whose only interface is lo with a multicast route: no datagram leaves the namespace.
# Exit status: 0 pass, 1 fail, 77 skip (no network namespace can be made here).
set -euo pipefail

readonly SKIP=77
readonly URL='udpm://239.255.76.67:7667?ttl=0'

if [[ "${1:-}" != --inside ]]; then
  if [[ $# -ne 6 ]]; then
    echo "usage: $0 PUBLISHER LCM_LOGGER JAVA DUMP_JAR EXPECTED WORKDIR" >&2
    exit 2
  fi
  if [[ $(id -u) -eq 0 ]]; then ns=(unshare -n); else ns=(unshare -rn); fi
  if ! probe=$("${ns[@]}" true 2>&1); then
    echo "SKIP: cannot create a private network namespace with '${ns[*]}': ${probe}"
    exit "${SKIP}"
  fi
  exec "${ns[@]}" -- bash "$0" --inside "$@"
fi
shift
publisher=$1 logger=$2 java=$3 dump_jar=$4 expected=$5 work=$6

fail() { echo "FAIL: $*" >&2; exit 1; }

# Refuse to send anything unless this really is a fresh namespace with nothing but lo.
links=$(ip -o link show | wc -l)
[[ ${links} -eq 1 ]] || fail "not in a private network namespace (${links} interfaces)"
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo

rm -rf "${work}"
mkdir -p "${work}"

logger_pid=
cleanup() { [[ -n ${logger_pid} ]] && kill "${logger_pid}" 2>/dev/null || true; }
trap cleanup EXIT

# Logs what PUBLISHER publishes (with PUBLISHER_ARGS) into LOG, then stops the logger.
record() {
  local log=$1
  shift
  "${logger}" -q -f --flush-interval=20 --lcm-url="${URL}" "${log}" &
  logger_pid=$!
  "${publisher}" --url "${URL}" --robot 7 --wait-for-file "${log}" "$@" ||
    fail "publisher failed"
  sleep 0.5  # the last datagrams reach the logger and are flushed
  kill -INT "${logger_pid}"
  wait "${logger_pid}" || true
  logger_pid=
}

# 1. One message of every type, decoded with the expected values.
record "${work}/all.lcm"
status=0
"${java}" -jar "${dump_jar}" "${work}/all.lcm" >"${work}/all.txt" 2>"${work}/all.err" ||
  status=$?
cat "${work}/all.err" >&2
[[ ${status} -eq 0 ]] || fail "TscLogDump exited ${status} on the valid log"

checked=0 tokens=0 errors=0
channel= type= line=
while IFS= read -r entry || [[ -n ${entry} ]]; do
  [[ -z ${entry} || ${entry} == \#* ]] && continue
  if [[ ${entry} =~ ^\[([A-Z0-9_]+)\ ([a-z0-9_.]+)\]$ ]]; then
    channel=${BASH_REMATCH[1]} type=${BASH_REMATCH[2]}
    matches=$(awk -v c="${channel}" '$2 == c' "${work}/all.txt")
    count=$(printf '%s' "${matches}" | grep -c . || true)
    if [[ ${count} -ne 1 ]]; then
      echo "FAIL: ${count} events on ${channel} in the log, expected 1" >&2
      errors=$((errors + 1)) line=
      continue
    fi
    line=" ${matches} "
    if [[ $(awk '{print $3}' <<<"${matches}") != "${type}" ]]; then
      echo "FAIL: ${channel} decoded as $(awk '{print $3}' <<<"${matches}"), expected ${type}" >&2
      errors=$((errors + 1))
    fi
    checked=$((checked + 1))
    continue
  fi
  [[ -n ${line} ]] || continue
  tokens=$((tokens + 1))
  if [[ ${line} != *" ${entry} "* ]]; then
    echo "FAIL: ${channel}: missing '${entry}' in:${line}" >&2
    errors=$((errors + 1))
  fi
done <"${expected}"

# Nothing on a tsc channel that the expectations do not know about.
tsc_events=$(awk '$2 ~ /^(TSC_|JAGUAR_)/' "${work}/all.txt" | wc -l)
[[ ${tsc_events} -eq ${checked} ]] ||
  fail "${tsc_events} events on tsc channels, ${checked} expected"
[[ ${checked} -ge 6 && ${errors} -eq 0 ]] ||
  fail "${errors} mismatches (${checked} messages, ${tokens} fields checked); dump in ${work}/all.txt"
echo "decoded ${checked} messages, ${tokens} fields as expected"

# 2. Messages that do not decode make TscLogDump fail and name their channel.
record "${work}/garbage.lcm" --garbage
status=0
"${java}" -jar "${dump_jar}" "${work}/garbage.lcm" >"${work}/garbage.txt" \
  2>"${work}/garbage.err" || status=$?
[[ ${status} -eq 1 ]] || fail "TscLogDump exited ${status} on undecodable messages, expected 1"
grep -q 'TSC_EVENT_7 is not a valid tsc.place_event_t' "${work}/garbage.err" ||
  fail "junk on TSC_EVENT_7 not reported: $(cat "${work}/garbage.err")"
grep -q 'TSC_MEMORY_7 is not a valid tsc.memory_portion_v2_t' "${work}/garbage.err" ||
  fail "announce_t on TSC_MEMORY_7 not reported: $(cat "${work}/garbage.err")"
echo "undecodable messages rejected (exit 1)"
echo "PASS"
