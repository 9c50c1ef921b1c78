#!/usr/bin/env bash
# config_paths_test.sh ROOT: every configuration file the scripts and the README (what a user
# runs; docs/ keep the commands of their time) pass with `--config config/...` exists, and
# every script parses (bash -n). The demo (the README's first command) ran `--config
# config/keyframes.ini` for sessions after that file was removed, and failed at its last step;
# nothing in the suite ran it.
set -euo pipefail
ROOT="$1"
cd "$ROOT"
errors=0
while IFS=: read -r file line text; do
  for path in $(grep -o -- '--config[= ][^ "]*config/[A-Za-z0-9_.-]*' <<<"$text" |
                sed 's/^--config[= ]//'); do
    if [[ ! -f "$path" ]]; then
      echo "$file:$line: --config $path: no such file" >&2
      errors=$((errors + 1))
    fi
  done
done < <(grep -n -- '--config[= ][^ "]*config/' scripts/* README.md 2>/dev/null || true)
for s in scripts/*; do
  [[ -f "$s" ]] || continue
  head -1 "$s" | grep -q bash || continue
  bash -n "$s" || { echo "$s: does not parse" >&2; errors=$((errors + 1)); }
done
if ((errors > 0)); then
  echo "config_paths_test: $errors problem(s)" >&2
  exit 1
fi
echo "config_paths_test: every --config path exists, every script parses"
