#!/usr/bin/env bash
# Issue #13 items 5, 6 and 9: what a real capture brings, tested against the
# truth of small synthetic scenes: validation catches what a run would refuse
# or get wrong (lights, an inside-out mesh, frames.step / indices, symlinks),
# invalid pixels (mask, saturation) never become Samples, and the resampling's
# job options (depth tolerance, grazing margin) change the output.
# Usage: cli_capture_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

small=(--cameras 4 --width 160 --height 120 --actor-segments 12)
fit=(--config NE,NW,SE,SW --no-powell --atlas 128 --no-render --outputs brdf)
"$bin" synth "${small[@]}" --frames 4 --out "$work/s" >/dev/null || exit 1

# edit SCENE_IN SCENE_OUT PYTHON: writes SCENE_OUT, scene.json with `d` changed by PYTHON.
edit() {
  python3 -c 'import json, sys
d = json.load(open(sys.argv[1]))
exec(sys.argv[3])
json.dump(d, open(sys.argv[2], "w"), indent=1)' "$1" "$2" "$3"
}
# json FILE EXPR: prints EXPR of the JSON document `d` in FILE.
json() { python3 -c 'import json, sys; d = json.load(open(sys.argv[1])); print(eval(sys.argv[2]))' "$1" "$2"; }
# kd_rmse RUN TRUTH_DIR
kd_rmse() { "$bin" evaluate "$1" --truth "$2" | python3 -c 'import json, sys; print(json.load(sys.stdin)["kdRmse"])'; }
# close A B TOLERANCE: |A - B| <= TOLERANCE
close() { python3 -c 'import sys; a, b, t = map(float, sys.argv[1:]); sys.exit(0 if abs(a - b) <= t else 1)' "$@"; }
less() { python3 -c 'import sys; a, b = map(float, sys.argv[1:]); sys.exit(0 if a < b else 1)' "$@"; }

# --- Lights: the run's limit and directions near unit length.
edit "$work/s/scene.json" "$work/s/many_lights.json" '
for i in range(40): d["lights"].append(dict(d["lights"][0], name="extra%d" % i))'
check "validate refuses more lights than a run takes, as the run would" 3 "scene.lights: at most 16 lights" -- \
  "$bin" validate "$work/s/many_lights.json"
edit "$work/s/scene.json" "$work/s/directional.json" '
for l in d["lights"]: l.pop("position", None); l["direction"] = [0.0, 1.0 + 6e-5, 0.0]'
check "validate renormalises a direction off unit length by 6e-5, with a note" 0 \
  "note: scene.lights\[0\].direction has length 1.00006, renormalised to unit length" -- \
  "$bin" validate "$work/s/directional.json"
edit "$work/s/scene.json" "$work/s/far_direction.json" '
for l in d["lights"]: l.pop("position", None); l["direction"] = [0.0, 1.01, 0.0]'
check "validate refuses a direction 1e-2 off unit length" 3 \
  "scene.lights\[0\].direction: must have unit length (within 0.001" -- "$bin" validate "$work/s/far_direction.json"

# --- A mesh whose triangles face inwards.
"$bin" run --direct "$work/s/scene.json" "${fit[@]}" --out "$work/r_base" >/dev/null 2>&1 || exit 1
cp -r "$work/s" "$work/inward"
for f in "$work"/inward/meshes/*.obj; do awk '$1 == "f" { print $1, $2, $4, $3; next } { print }' "$f" > "$f.t" && mv "$f.t" "$f"; done
check "validate refuses an inside-out mesh, naming mesh.flipWinding" 3 \
  "triangles face inwards .*set scene.mesh.flipWinding to true" -- "$bin" validate "$work/inward/scene.json"
check "run refuses it too (it fitted the initial guess, exit 0)" 3 "triangles face inwards" -- \
  "$bin" run --direct "$work/inward/scene.json" "${fit[@]}" --out "$work/r_inward"
edit "$work/inward/scene.json" "$work/inward/scene.json" 'd["mesh"]["flipWinding"] = True'
check "with flipWinding the inside-out mesh runs" 0 "wrote" -- \
  "$bin" run --direct "$work/inward/scene.json" "${fit[@]}" --out "$work/r_flipped"
kd_base=$(kd_rmse "$work/r_base" "$work/s")
kd_flipped=$(kd_rmse "$work/r_flipped" "$work/inward")
echo "     kd RMSE: original $kd_base, inside-out mesh with flipWinding $kd_flipped"
expect "flipWinding recovers kd like the original mesh" close "$kd_base" "$kd_flipped" 1e-4

# --- Job options of the resampling (run goes through the service and a worker).
seen() { json "$1/result.json" 'd["texelsSeen"]'; }
"$bin" run "$work/s/scene.json" "${fit[@]}" --out "$work/o_default" >/dev/null 2>&1 || exit 1
check "run --grazing-margin 80" 0 "wrote" -- \
  "$bin" run "$work/s/scene.json" "${fit[@]}" --grazing-margin 80 --out "$work/o_grazing"
check "run --depth-tolerance-absolute 100 (bigger than the object)" 0 "wrote" -- \
  "$bin" run "$work/s/scene.json" "${fit[@]}" --depth-tolerance-absolute 100 --out "$work/o_absolute"
echo "     texels seen: default $(seen "$work/o_default"), grazing margin 80 $(seen "$work/o_grazing"), absolute tolerance 100 $(seen "$work/o_absolute")"
expect "a huge grazing margin leaves fewer texels seen" less "$(seen "$work/o_grazing")" "$(seen "$work/o_default")"
expect "an absolute tolerance bigger than the object makes hidden texels seen" \
  less "$(seen "$work/o_default")" "$(seen "$work/o_absolute")"
# Against the resample evaluator's truth: the texels marked valid though hidden.
"$bin" resample "$work/s/scene.json" --atlas 128 --save none --out "$work/rs_default" >/dev/null 2>&1
"$bin" resample "$work/s/scene.json" --atlas 128 --save none --depth-tolerance-absolute 100 --out "$work/rs_absolute" >/dev/null 2>&1
false_valid() { json "$1/resample.json" 'max(c["falseValidFraction"] for c in d["cameras"])'; }
echo "     worst false-valid fraction: default $(false_valid "$work/rs_default"), absolute 100 $(false_valid "$work/rs_absolute")"
expect "resample --depth-tolerance-absolute 100 marks truly hidden texels valid" \
  less "$(python3 -c "print(5 * $(false_valid "$work/rs_default"))")" "$(false_valid "$work/rs_absolute")"
check "both tolerances at once: a usage error" 2 "give at most one" -- \
  "$bin" run "$work/s/scene.json" --depth-tolerance-absolute 1 --depth-tolerance-relative 0.01 --out "$work/x"
check "submit: a negative absolute tolerance is a usage error" 2 \
  "--depth-tolerance-absolute: must be a finite number >= 0 (world units)" -- \
  "$bin" submit "$work/s/scene.json" --server 127.0.0.1:1 --depth-tolerance-absolute -1
check "submit: --grazing-margin 90 is a usage error" 2 "--grazing-margin: must be in \[0, 90) degrees, got 90" -- \
  "$bin" submit "$work/s/scene.json" --server 127.0.0.1:1 --grazing-margin 90
check "run --help names the resampling options" 0 "--depth-tolerance-absolute" -- "$bin" run --help
check "submit --help names the resampling options" 0 "--grazing-margin" -- "$bin" submit --help

summary
