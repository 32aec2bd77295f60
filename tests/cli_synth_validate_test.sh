#!/usr/bin/env bash
# End-to-end: `mvbrdf synth` writes a bundle that `mvbrdf validate` accepts,
# and broken scenes fail with exit code 3 and a reason naming the field.
# Usage: cli_synth_validate_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

check "no command is a usage error" 2 "usage: mvbrdf" -- "$bin"
check "help" 0 "synth" -- "$bin" --help
check "synth help" 0 "--preset" -- "$bin" synth --help
check "unknown flag" 2 "--colour: unknown option" -- "$bin" synth --colour red --out "$work/x"
check "bad preset" 2 "--preset: expected actor, spot, samba or sphere" -- "$bin" synth --preset cow --out "$work/x"
check "bad camera count" 2 "--cameras: must be in" -- "$bin" synth --cameras 0 --out "$work/x"
check "unknown configuration" 3 "--config: unknown configuration" -- \
  "$bin" synth --config "NE,XX" --frames 1 --cameras 1 --width 64 --height 48 --out "$work/x"

scene="$work/actor/scene.json"
check "synth actor" 0 "ground truth" -- \
  "$bin" synth --preset actor --cameras 3 --frames 4 --width 128 --height 96 --actor-segments 12 --out "$work/actor"
check "validate" 0 "valid: " -- "$bin" validate "$scene"
[ -f "$work/actor/ground_truth/truth.json" ] && [ -f "$work/actor/videos/cam2.mkv" ] && [ -f "$work/actor/meshes/mesh_0003.obj" ] \
  && { echo "ok   bundle files"; passes=$((passes + 1)); } || { echo "FAIL bundle files"; failures=$((failures + 1)); }

# A negative focal length is named by its field.
sed 's/"fx": [0-9.e+]*/"fx": -1/' "$scene" > "$work/actor/bad_fx.json"
check "negative focal length" 3 "cameras\[0\].intrinsics.fx" -- "$bin" validate "$work/actor/bad_fx.json"
# A missing video file is named.
sed 's#videos/cam1.mkv#videos/nope.mkv#' "$scene" > "$work/actor/bad_video.json"
check "missing video" 3 "nope.mkv" -- "$bin" validate "$work/actor/bad_video.json"
# Malformed JSON.
head -c 200 "$scene" > "$work/actor/truncated.json"
check "truncated json" 3 "truncated.json" -- "$bin" validate "$work/actor/truncated.json"
check "missing scene" 3 "missing.json" -- "$bin" validate "$work/actor/missing.json"

summary
