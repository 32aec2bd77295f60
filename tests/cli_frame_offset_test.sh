#!/usr/bin/env bash
# Issue #20: Video.frame_offset. Absolute frame f of the sequence is frame
# f + frame_offset of a camera's video. One camera of a synthetic capture
# "started recording one frame late": its image sequence loses its first image
# and is renumbered (file j shows absolute frame j + 1). With frameOffset -1 the
# run must equal the run on the unshifted capture (result.json to 1e-6);
# without it that camera sees the wrong poses and its error is higher.
# Offsets that reach before the video's start or past its end are refused,
# naming the camera and the frame.
# Usage: cli_frame_offset_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

check "synth" 0 "wrote" -- "$bin" synth --cameras 3 --frames 6 --width 160 --height 120 --actor-segments 12 \
  --format png --out "$work/base"

# edit SCENE FIRST COUNT [OFFSET]: scene.frames first/count; cameras[1]'s frameOffset.
edit() {
  python3 - "$@" <<'EOF_PY'
import json, sys
path, first, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
scene = json.load(open(path))
scene["frames"]["first"] = first
scene["frames"]["count"] = count
if len(sys.argv) > 4:
    scene["cameras"][1]["video"]["frameOffset"] = int(sys.argv[4])
json.dump(scene, open(path, "w"), indent=1)
EOF_PY
}
pattern=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["cameras"][1]["video"]["path"])' \
  "$work/base/scene.json")
cam1_dir=$(dirname "$pattern")

# The reference: absolute frames 1..4 of the capture as it was rendered.
cp -r "$work/base" "$work/ref"
edit "$work/ref/scene.json" 1 4
# Camera 1 started one frame late: its file j is absolute frame j + 1.
cp -r "$work/base" "$work/shifted"
for j in 0 1 2 3 4; do
  mv "$work/shifted/$cam1_dir/$(printf %04d $((j + 1))).png" "$work/shifted/$cam1_dir/$(printf %04d $j).png"
done
cp -r "$work/shifted" "$work/unaligned"
edit "$work/shifted/scene.json" 1 4 -1
edit "$work/unaligned/scene.json" 1 4

check "validate the shifted scene states the offset" 0 "frame offset -1: sequence frame f is its frame f - 1" -- \
  "$bin" validate "$work/shifted/scene.json"
run_opts=(--config "NE,NW,SE,SW" --no-powell --atlas 128)
for name in ref shifted unaligned; do
  check "run on $name" 0 "wrote" -- "$bin" run --direct "$work/$name/scene.json" "${run_opts[@]}" --out "$work/r_$name"
done

# compare A B: B's figures equal A's to 1e-6 (relative).
compare() {
  python3 - "$1/result.json" "$2/result.json" <<'EOF_PY'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
def rel(x, y): return abs(x - y) / max(abs(x), abs(y), 1e-12)
bad = []
for x, y in zip(a["cameras"], b["cameras"]):
    for key in ("mseBrdf", "mseCorrection"):
        if (key in x) != (key in y) or (key in x and rel(x[key], y[key]) > 1e-6): bad.append("camera %s %s: %r vs %r" % (x["name"], key, x.get(key), y.get(key)))
for x, y in zip(a["clusters"], b["clusters"]):
    for key in ("ks", "ke", "centre"):
        for u, v in zip(x.get(key, []), y.get(key, [])):
            if rel(u, v) > 1e-6: bad.append("cluster %s %s: %r vs %r" % (x["name"], key, u, v))
for x, y in zip(a["solvers"], b["solvers"]):
    for u, v in zip(x["kd"], y["kd"]):
        if rel(u, v) > 1e-6: bad.append("cluster %s kd: %r vs %r" % (x["cluster"], u, v))
if len(a["cameras"]) != len(b["cameras"]) or not a["cameras"]: bad.append("camera lists differ")
if len(a["clusters"]) != len(b["clusters"]) or len(a["solvers"]) != len(b["solvers"]): bad.append("cluster lists differ")
for line in bad: print(line, file=sys.stderr)
sys.exit(1 if bad else 0)
EOF_PY
}
expect "frameOffset -1 on the late camera gives the unshifted run's result.json (1e-6)" compare "$work/r_ref" "$work/r_shifted"
err() { python3 -c 'import json,sys; print([c for c in json.load(open(sys.argv[1]))["cameras"] if c["name"] == sys.argv[2]][0]["mseBrdf"])' "$1/result.json" "$2"; }
cam1=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["cameras"][1]["name"])' "$work/base/scene.json")
e_ref=$(err "$work/r_ref" "$cam1")
e_unaligned=$(err "$work/r_unaligned" "$cam1")
echo "     $cam1 mse_brdf: aligned $e_ref, without frameOffset $e_unaligned"
expect "without frameOffset the late camera's error is higher (x1.5)" \
  python3 -c "import sys; sys.exit(not $e_unaligned > 1.5 * $e_ref)"

# Out of the video: before its start, past its end (5 files: 0..4).
cp -r "$work/shifted" "$work/early"
edit "$work/early/scene.json" 1 4 -2
check "frameOffset before the video's start: exit 3 naming camera and frame" 3 \
  "scene.cameras\[1\].video.frame_offset: camera \"$cam1\": frame 1 of the sequence would be frame -1" -- \
  "$bin" validate "$work/early/scene.json"
cp -r "$work/shifted" "$work/late"
edit "$work/late/scene.json" 1 4 1
check "frameOffset past the video's end: exit 3 naming camera and frame" 3 \
  "camera \"$cam1\": frame 4 of the sequence is frame 5 of its video, past the video's end" -- \
  "$bin" validate "$work/late/scene.json"

summary
