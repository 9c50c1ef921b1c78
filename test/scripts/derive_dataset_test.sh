#!/usr/bin/env bash
# derive_dataset_test.sh SCRIPT: scripts/derive-dataset on a seven-frame fixture whose thinned
# frames and pose revisits are known by hand: renumbering, spacing, the view-overlap rule (2 m,
# 45°, headings across ±π), a frame's own visit left out, and the errors a user meets.
set -euo pipefail
SCRIPT="$1"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
IN="$WORK/in"
mkdir -p "$IN"
for k in 1 2 3 4 5 6 7; do printf 'frame %d' "$k" >"$IN/$(printf '%06d' "$k").jpg"; done
echo '{"width":160,"height":120,"hfov_deg":58.000000,"spacing_m":0.150000}' >"$IN/camera.json"
cat >"$IN/groundtruth.csv" <<'CSV'
frame,place,x,y,heading
1,room1,0,0,0
2,room1,0.1,0,0
3,corr,5,0,0
4,room1,0.5,0,0.3
5,room1,0.5,0,3.0
6,corr,5,1.5,-0.2
7,room1,0.2,0,6.2
CSV
fail() { echo "derive_dataset_test: $*" >&2; exit 1; }
expect_file() {  # expect_file FILE CONTENT
  [[ "$(cat "$1")" == "$2" ]] || fail "$1 is"$'\n'"$(cat "$1")"$'\n'"expected"$'\n'"$2"
}

bash "$SCRIPT" --in "$IN" --out "$WORK/all" --pose-revisits >/dev/null
# 4 sees 1 and 2 (same room, another visit, 0.3 rad apart); 5 faces away; 6 sees 3; 7's
# heading 6.2 is 0.08 rad from 0, so it sees 1, 2 and 4 (not 5: 3.1 rad).
expect_file "$WORK/all/revisits.csv" "frame,revisits
1,
2,
3,
4,1 2
5,
6,3
7,1 2 4"
expect_file "$WORK/all/000007.jpg" "frame 7"

bash "$SCRIPT" --in "$IN" --out "$WORK/x2" --every 2 --pose-revisits >/dev/null
# Frames 1, 3, 5, 7 as 1..4; 3 and 4 (old 5 and 7) are one visit of room1.
expect_file "$WORK/x2/groundtruth.csv" "frame,place,x,y,heading
1,room1,0,0,0
2,corr,5,0,0
3,room1,0.5,0,3.0
4,room1,0.2,0,6.2"
expect_file "$WORK/x2/revisits.csv" "frame,revisits
1,
2,
3,
4,1"
expect_file "$WORK/x2/000002.jpg" "frame 3"
grep -q '"spacing_m":0.300000' "$WORK/x2/camera.json" || fail "spacing not doubled: $(cat "$WORK/x2/camera.json")"
[[ ! -e "$WORK/x2/000005.jpg" ]] || fail "a fifth frame was written"

# Errors: usage 2, data 1, and nothing written over.
set +e
bash "$SCRIPT" --in "$IN" --out "$WORK/x2" >/dev/null 2>&1; [[ $? == 1 ]] || fail "an existing --out was not refused"
bash "$SCRIPT" --in "$IN" --out "$WORK/bad" --every 0 >/dev/null 2>&1; [[ $? == 2 ]] || fail "--every 0 was not a usage error"
bash "$SCRIPT" --out "$WORK/bad" >/dev/null 2>&1; [[ $? == 2 ]] || fail "a missing --in was not a usage error"
echo '{"width":160}' >"$IN/camera.json"
bash "$SCRIPT" --in "$IN" --out "$WORK/bad" >/dev/null 2>&1; [[ $? == 1 ]] || fail "a camera.json without spacing_m was accepted"
set -e
[[ ! -e "$WORK/bad" ]] || fail "a refused run left $WORK/bad behind"
echo "derive_dataset_test: thinning, pose revisits and errors as expected"
