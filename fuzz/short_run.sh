#!/usr/bin/env bash
# fuzz/short_run.sh FUZZER [libFuzzer flags...] -- INPUT_DIR...
# The test suite's short run of one libFuzzer target (fuzz/CMakeLists.txt): replays the input
# folders (seed corpus, regression inputs), then runs the executions the flags fix (-runs=,
# -seed=) into a scratch corpus made for this run and removed after it, so every run of the
# same commit does the same executions (address space randomisation off, see below). Prints the command (with the seed) first, so a failure
# can be replayed.
set -euo pipefail
fuzzer=$1
shift
flags=()
while (($#)) && [[ $1 != -- ]]; do
  flags+=("$1")
  shift
done
[[ ${1:-} == -- ]] && shift
scratch=$(mktemp -d "${TMPDIR:-/tmp}/tscd-fuzz-short.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
# Without address space randomisation: libFuzzer feeds compared values (pointers among them,
# under ASan) back into its mutations, so with ASLR the same seed explores differently.
norandom=()
if setarch "$(uname -m)" -R true 2>/dev/null; then
  norandom=(setarch "$(uname -m)" -R)
else
  echo "fuzz short run: setarch -R is not allowed here; addresses vary, so may the executions"
fi
echo "fuzz short run: ${norandom[*]} $fuzzer ${flags[*]} SCRATCH $*"
"${norandom[@]}" "$fuzzer" "${flags[@]}" "$scratch" "$@"
