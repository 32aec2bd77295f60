#!/usr/bin/env bash
# End-to-end: bad input through `mvbrdf validate` and `mvbrdf submit` (issue #7,
# "Bad input"): each exits non-zero with exactly one line on stderr, and that
# line names the field or file. The full table of cases is
# tests/bad_input_test.cc; this checks what a user of the CLI sees.
# Usage: cli_bad_input_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

# one_line NAME EXPECTED_EXIT PATTERN -- command...: the command exits with
# EXPECTED_EXIT and writes exactly one line to stderr, which contains PATTERN.
# The upload's progress line ("upload  done in 0.0 s", which submit prints
# before it asks the server) is not a reason and is not counted.
one_line() {
  local name=$1 want=$2 pattern=$3
  shift 4
  local rc lines
  "$@" > "$work/out" 2> "$work/err"
  rc=$?
  grep -v '^upload  *done in ' "$work/err" > "$work/reason"
  lines=$(wc -l < "$work/reason")
  if [ "$rc" -ne "$want" ]; then
    echo "FAIL $name: exit $rc, expected $want"; tail -5 "$work/err"; failures=$((failures + 1)); return
  fi
  if [ "$lines" -ne 1 ]; then
    echo "FAIL $name: $lines lines of reason on stderr, expected 1"; cat "$work/err"; failures=$((failures + 1)); return
  fi
  if ! grep -qF -- "$pattern" "$work/reason"; then
    echo "FAIL $name: stderr lacks '$pattern'"; cat "$work/err"; failures=$((failures + 1)); return
  fi
  echo "ok   $name: $(cat "$work/reason")"; passes=$((passes + 1))
}

# A copy of the valid scene with one thing broken by a sed expression on scene.json.
broken() {
  local name=$1 expr=$2
  cp -r "$work/valid" "$work/$name"
  sed -i "$expr" "$work/$name/scene.json"
}

check "generate a tiny sequence" 0 "" -- "$bin" synth --cameras 2 --frames 3 --width 64 --height 48 \
  --actor-segments 6 --out "$work/valid"
check "the valid scene validates" 0 "valid: " -- "$bin" validate "$work/valid/scene.json"

# validate: caught locally.
broken bad_fx 's/"fx": [0-9.e+]*/"fx": -1/'
one_line "validate: non-positive focal length" 3 "scene.cameras[0].intrinsics.fx: must be > 0, got -1" -- \
  "$bin" validate "$work/bad_fx/scene.json"
broken malformed 's/"frames"/"frames",,/'
one_line "validate: malformed JSON is one line" 3 "scene.json: not a valid mvbrdf.v1.Scene JSON document" -- \
  "$bin" validate "$work/malformed/scene.json"
broken escape 's#meshes/mesh_%04d.obj#../mesh_%04d.obj#'
one_line "validate: a path leaving the scene's directory" 3 "scene.mesh.path: must be a relative path inside" -- \
  "$bin" validate "$work/escape/scene.json"
cp -r "$work/valid" "$work/nan"
sed -i '0,/^v /s/^v .*/v 0 nan 0/' "$work/nan/meshes/mesh_0002.obj"
one_line "validate: a NaN vertex in a later frame" 3 "scene.mesh.path (frame 2): meshes/mesh_0002.obj" -- \
  "$bin" validate "$work/nan/scene.json"

# Issue #19 defect 12: "mesh_%999999999d.obj" cost 18 s, 5.9 GB and a 1 GB error line.
broken wide 's#meshes/mesh_%04d.obj#meshes/mesh_%999999999d.obj#'
one_line "validate: a frame number a billion digits wide" 3 "scene.mesh.path: a frame number is at most 9 digits wide" -- \
  timeout 10 "$bin" validate "$work/wide/scene.json"
expect "  ... and its error line is short" test "$(wc -c < "$work/reason")" -lt 400
# Issue #19 weak spots: what validate let through.
broken dup_key 's/"frames": {/"frames": {"count": 7, /'
one_line "validate: a duplicate JSON key" 3 'duplicate key "count" in frames' -- "$bin" validate "$work/dup_key/scene.json"
broken inf_fps 's/"fps": [0-9.e+]*/"fps": "Infinity"/'
one_line "validate: an infinite fps" 3 "scene.frames.fps: must be a finite number > 0, got inf" -- \
  "$bin" validate "$work/inf_fps/scene.json"
cp -r "$work/valid" "$work/truncated"
size=$(stat -c %s "$work/truncated/videos/cam1.mkv")
truncate -s $((size * 2 / 3)) "$work/truncated/videos/cam1.mkv"
# (check, not one_line: FFmpeg itself logs "File ended prematurely" on stderr.)
check "validate: a truncated video" 3 "scene.cameras.1.\.video: frame 1 (file frame 1) is past the end of videos/cam1.mkv" -- \
  "$bin" validate "$work/truncated/scene.json"
check "validate --quick says it did not read the videos" 0 "not checked (--quick): later mesh frames, the videos" -- \
  "$bin" validate --quick "$work/truncated/scene.json"
"$bin" synth --cameras 2 --frames 3 --width 64 --height 48 --actor-segments 6 --format png --out "$work/png" >/dev/null ||
  exit 1
"$bin" synth --cameras 1 --frames 1 --width 32 --height 24 --actor-segments 6 --format png --out "$work/small" \
  >/dev/null || exit 1
cp -r "$work/png" "$work/png_small"
cp "$work/small/videos/cam0/0000.png" "$work/png_small/videos/cam0/0002.png"
one_line "validate: a later image of the wrong size" 3 "scene.cameras[0].video: frame 2" -- \
  "$bin" validate "$work/png_small/scene.json"
cp -r "$work/valid" "$work/flat"
python3 - "$work/flat/meshes" <<'EOF_PY'
import glob, sys
for path in glob.glob(sys.argv[1] + "/*.obj"):  # every vertex at the origin: every triangle has zero area
    lines = ["v 0 0 0" if l.startswith("v ") else l for l in open(path).read().split("\n")]
    open(path, "w").write("\n".join(lines))
EOF_PY
one_line "validate: a mesh of zero area" 3 "triangles have zero area in frame 0" -- "$bin" validate "$work/flat/scene.json"
cp -r "$work/valid" "$work/far"
sed -i '0,/^v .*/s//v 1e30 0 0/' "$work/far/meshes/mesh_0000.obj"  # one vertex at 1e30: the rest are specks beside it
one_line "validate: a vertex at 1e30 names the mesh's extent" 3 "to (1e+30, " \
  -- "$bin" validate "$work/far/scene.json"
cp -r "$work/valid" "$work/dark"
python3 - "$work/dark/scene.json" <<'EOF_PY'
import json, sys
scene = json.load(open(sys.argv[1]))
for light in scene["lights"]:
    light["intensity"] = [0, 0, 0]
json.dump(scene, open(sys.argv[1], "w"))
EOF_PY
one_line "validate: every light off" 3 "scene.lights: every light's intensity is 0" -- "$bin" validate "$work/dark/scene.json"

# submit: caught by the server (a server without workers: nothing runs).
expect "server starts and prints its address" start_server "$work/server.log"
# A camera turned around (rotation rows 0 and 2 and translation x, z negated) sees nothing.
cp -r "$work/valid" "$work/away"
python3 - "$work/away/scene.json" <<'EOF'
import json, sys
path = sys.argv[1]
scene = json.load(open(path))
pose = scene["cameras"][1]["camFromWorld"]
for k in (0, 1, 2, 6, 7, 8):
    pose["rotation"][k] = -pose["rotation"][k]
pose["translation"][0] = -pose["translation"][0]
pose["translation"][2] = -pose["translation"][2]
json.dump(scene, open(path, "w"))
EOF
one_line "submit: a camera that sees nothing" 3 "scene.cameras[1]: sees none of the mesh in frame 0" -- \
  "$bin" submit "$work/away/scene.json" --server "$address" --client tester
one_line "submit: an unknown configuration" 3 "configuration: the scene has no light configuration \"XX\"" -- \
  "$bin" submit "$work/valid/scene.json" --server "$address" --client tester --config XX
cp -r "$work/valid" "$work/short"
rm "$work/short/meshes/mesh_0002.obj"
one_line "submit: a missing mesh frame" 3 "mesh_0002.obj" -- \
  "$bin" submit "$work/short/scene.json" --server "$address" --client tester
check "the server still takes a valid job" 0 "" -- \
  "$bin" submit "$work/valid/scene.json" --server "$address" --client tester
kill "$pid" 2> /dev/null
wait "$pid" 2> /dev/null

summary
