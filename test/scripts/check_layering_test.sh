#!/usr/bin/env bash
# check_layering_test.sh CHECKER SOURCE_DIR: scripts/check-layering must refuse what it is there
# to refuse, so that it cannot pass by checking nothing. On a copy of the source tree with one
# forbidden include added, and on small fixture trees: each forbidden include fails the check
# and is named (file:line); each allowed one passes.
set -euo pipefail
CHECKER="$1"
SOURCE="$(cd "$2" && pwd)"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
failures=0

# expect PASS|FAIL TREE [TEXT]: the checker's verdict on TREE; with FAIL, its output names TEXT.
expect() {
  local want="$1" tree="$2" text="${3:-}" out rc=0
  out="$("$CHECKER" "$tree" 2>&1)" || rc=$?
  if [[ "$want" == PASS && $rc -ne 0 ]]; then
    echo "FAILED: expected the check to pass on $tree, exit $rc:"$'\n'"$out"
    failures=$((failures + 1))
  elif [[ "$want" == FAIL && $rc -eq 0 ]]; then
    echo "FAILED: expected the check to fail on $tree (${text}), it passed:"$'\n'"$out"
    failures=$((failures + 1))
  elif [[ "$want" == FAIL && -n "$text" && "$out" != *"$text"* ]]; then
    echo "FAILED: the check failed on $tree but did not name '$text':"$'\n'"$out"
    failures=$((failures + 1))
  else
    echo "ok: $want ${text}"
  fi
}

# A copy of the real tree (sources only) passes; one forbidden include in core fails it.
real="$TMP/real"
mkdir "$real"
for d in "$SOURCE"/*/; do
  name="$(basename "$d")"
  [[ "$name" == build* ]] && continue
  cp -r "$d" "$real/$name"
done
expect PASS "$real"
victim="$(cd "$real" && find core -name '*.h' | sort | head -n 1)"
[[ -n "$victim" ]] || { echo "FAILED: no header in core/ to edit"; exit 1; }
lines="$(wc -l <"$real/$victim")"
echo '#include "daemon/daemon.h"' >>"$real/$victim"
expect FAIL "$real" "$victim:$((lines + 1)): core must not include \"daemon/daemon.h\""

# fixture NAME FILE=LINE...: a tree holding each FILE with the one line LINE.
fixture() {
  local tree="$TMP/$1"
  shift
  mkdir -p "$tree/lcmtypes"
  echo 'package tsc; struct announce_t { int64_t utime; }' >"$tree/lcmtypes/tsc_announce_t.lcm"
  for spec in "$@"; do
    mkdir -p "$tree/$(dirname "${spec%%=*}")"
    printf '%s\n' "${spec#*=}" >>"$tree/${spec%%=*}"
  done
  echo "$tree"
}
base=(core/a.h='#include "core/b.h"'
      store/s.h='#include "core/a.h"'
      drivers/d.h='#include "core/a.h"'
      settings/x.h='#include "drivers/d.h"'
      daemon/m.cc='#include "tsc/announce_t.hpp"'
      tools/t.cc='#include "settings/x.h"'
      tools/simulators/s.cc='#include "drivers/d.h"'
      tools/u.cc='#include "tools/simulators/s.h"'
      test/u.cc='#include "tools/t.h"'
      bench/b.cc='#include "test/support/h.h"'
      fuzz/f.cc='#include "daemon/m.h"'
      core/c.cc='#include "c.h"'
      core/e.h='#include "Eigen/Core"')
expect PASS "$(fixture allowed "${base[@]}")"
expect FAIL "$(fixture core_daemon "${base[@]}" core/z.cc='#include "daemon/m.h"')" \
  'core/z.cc:1: core must not include "daemon/m.h"'
expect FAIL "$(fixture drivers_settings "${base[@]}" drivers/camera/f.h='#include "settings/x.h"')" \
  'drivers/camera/f.h:1: drivers must not include "settings/x.h"'
expect FAIL "$(fixture store_drivers "${base[@]}" store/y.cc='#include "drivers/d.h"')" \
  'store/y.cc:1: store must not include "drivers/d.h"'
expect FAIL "$(fixture settings_daemon "${base[@]}" settings/y.cc='#include "daemon/m.h"')" \
  'settings/y.cc:1: settings must not include "daemon/m.h"'
expect FAIL "$(fixture core_lcm "${base[@]}" core/l.cc='#include "tsc/announce_t.hpp"')" \
  'core/l.cc:1: core must not include "tsc/announce_t.hpp"'
expect FAIL "$(fixture core_sqlite "${base[@]}" core/q.cc='  #  include <sqlite3.h>')" \
  'core/q.cc:1: core must not include <sqlite3.h>'
expect FAIL "$(fixture tools_test "${base[@]}" tools/v.cc='#include "test/support/h.h"')" \
  'tools/v.cc:1: tools must not include "test/support/h.h"'
expect FAIL "$(fixture simulators_daemon "${base[@]}" tools/simulators/v.cc='#include "daemon/m.h"')" \
  'tools/simulators/v.cc:1: tools/simulators must not include "daemon/m.h"'
expect FAIL "$(fixture simulators_cli "${base[@]}" tools/simulators/w.h='#include "tools/t.h"')" \
  'tools/simulators/w.h:1: tools/simulators must not include "tools/t.h"'
expect FAIL "$(fixture test_fuzz "${base[@]}" test/w.cc='#include "fuzz/f.h"')" \
  'test/w.cc:1: test must not include "fuzz/f.h"'
expect FAIL "$(fixture new_folder "${base[@]}" extra/n.cc='#include "core/a.h"')" \
  "C++ in folder 'extra', which has no layering rule"
expect FAIL "$(fixture empty)" 'no project includes found'

if ((failures > 0)); then
  echo "$failures case(s) failed"
  exit 1
fi
echo "all cases passed"
