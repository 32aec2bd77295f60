#!/usr/bin/env bash
# End-to-end: `mvbrdf resample` on a generated bundle writes its atlases and
# figures, streams (peak memory does not grow with the number of frames), and
# rejects bad input with the documented exit codes.
# Usage: cli_resample_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

json_field() {  # json_field FILE FIELD -> the number after "FIELD":
  grep -o "\"$2\": \"*[0-9.e+-]*" "$1" | head -1 | sed 's/.*: "*//'
}

"$bin" synth --cameras 2 --frames 16 --width 160 --height 120 --actor-segments 12 --out "$work/b16" >/dev/null || exit 1
# The same bundle cut to 4 frames.
mkdir -p "$work/b4" && cp -r "$work/b16/." "$work/b4/"
sed -i 's/"count": 16/"count": 4/' "$work/b4/scene.json"

check "resample help" 0 "--atlas" -- "$bin" resample --help
check "missing scene" 3 "nope.json" -- "$bin" resample "$work/nope.json" --out "$work/x"
check "bad atlas size" 2 "--atlas: must be in" -- "$bin" resample "$work/b4/scene.json" --atlas 8 --out "$work/x"
check "bad save mode" 2 "--save: expected first, all or none" -- "$bin" resample "$work/b4/scene.json" --save some --out "$work/x"
check "resample 4 frames" 0 "resample.json" -- "$bin" resample "$work/b4/scene.json" --atlas 256 --save all --out "$work/r4"
check "resample 4 frames, nothing saved" 0 "recall" -- "$bin" resample "$work/b4/scene.json" --atlas 256 --save none --out "$work/r4n"
check "resample 16 frames" 0 "recall" -- "$bin" resample "$work/b16/scene.json" --atlas 256 --save none --out "$work/r16"
for f in resample.json atlas/mesh.obj atlas/charts.png frames/0003/cam1.exr frames/0003/cam1_grown.png frames/0003/shadows.exr; do
  if [ -f "$work/r4/$f" ]; then echo "ok   wrote $f"; passes=$((passes + 1)); else echo "FAIL missing $f"; failures=$((failures + 1)); fi
done
# resample.json names its scene relative to itself (issue #20), so input and output move together.
check "resample.json's scene resolves from its own directory to the scene" 0 "same" -- python3 -c '
import json, os, sys
d = sys.argv[1]
scene = json.load(open(os.path.join(d, "resample.json")))["scene"]
ok = not os.path.isabs(scene) and os.path.samefile(os.path.join(d, scene), sys.argv[2])
print("same" if ok else "differs: %s" % scene)' "$work/r4" "$work/b4/scene.json"
[ ! -d "$work/r16/frames" ] && { echo "ok   --save none writes no frames"; passes=$((passes + 1)); } || { echo "FAIL --save none wrote frames"; failures=$((failures + 1)); }

# Streaming: 4x the frames must not need noticeably more memory.
rss4=$(json_field "$work/r4n/resample.json" peakRssBytes)
rss16=$(json_field "$work/r16/resample.json" peakRssBytes)
if [ -n "$rss4" ] && [ -n "$rss16" ] && [ "$rss16" -lt $((rss4 + rss4 / 10)) ]; then
  echo "ok   peak memory $rss4 B (4 frames) vs $rss16 B (16 frames)"; passes=$((passes + 1))
else
  echo "FAIL memory grows with frames: $rss4 B (4 frames) vs $rss16 B (16 frames)"; failures=$((failures + 1))
fi

summary
