#!/usr/bin/env bash
# run --pixel-footprint N against the truth: frames recorded as a sensor
# records them (synth --pixel-samples 4: each pixel the mean of 4 x 4 samples
# over its area), then the cluster fits with each pixel modelled as its
# centre (1, the default) and as the mean over 3 x 3 subpixels. A sharp lobe
# seen through a pixel's area looks broader and dimmer than at one point, so
# the point model gets ks and ke wrong (hair: measured 0.32 / 0.31 here) and
# the footprint model should not (0.10 / 0.10); result.json records the
# choice; out-of-range values are refused naming the flag.
# Usage: cli_footprint_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

check "synth --pixel-samples 4" 0 "wrote" -- "$bin" synth --frames 6 --pixel-samples 4 --out "$work/scene"
run_opts=(--config "NE,NW,SE,SW" --no-powell --atlas 128 --direct --refine-cameras off)
for f in 1 3; do
  check "run --pixel-footprint $f" 0 "wrote" -- \
    "$bin" run "$work/scene/scene.json" "${run_opts[@]}" --pixel-footprint "$f" --out "$work/f$f"
  "$bin" evaluate "$work/f$f" --truth "$work/scene" --no-relighting > "$work/f$f.eval.json" 2>/dev/null
done
expect "--pixel-footprint 3: the worst ks / ke error at most 0.6 x the point model's, every cluster's ke closer" \
  python3 - "$work" <<'EOF_PY'
import json, sys
w = sys.argv[1]
e = {f: json.load(open("%s/f%d.eval.json" % (w, f))) for f in (1, 3)}
worst = {f: max(max(c["ksRelError"], c["keRelError"]) for c in e[f]["clusters"]) for f in e}
for f in e:
    print("      footprint %d: %s; worst %.3f" % (f, ", ".join(
        "%s ks %.3f ke %.3f" % (c["material"], c["ksRelError"], c["keRelError"]) for c in e[f]["clusters"]), worst[f]))
ke = {f: {c["material"]: c["keRelError"] for c in e[f]["clusters"]} for f in e}
sys.exit(0 if worst[3] <= 0.6 * worst[1] and all(ke[3][m] < ke[1][m] for m in ke[1]) else 1)
EOF_PY
expect "result.json records the footprint (options.fitting.pixelFootprint 3, and 1 by default)" python3 -c "
import json, sys
f = lambda d: json.load(open('$work/' + d + '/result.json'))['options']['fitting'].get('pixelFootprint')
sys.exit(0 if (f('f3'), f('f1')) == (3, 1) else 1)"
expect "the plan's cluster_fit line says so (3 x 3 subpixels), and not without it" python3 -c "
import json, sys
why = lambda d: [s['why'] for s in json.load(open('$work/' + d + '/result.json'))['plan']['stages'] if s['name'] == 'cluster_fit'][0]
sys.exit(0 if '3 x 3 subpixels' in why('f3') and 'subpixels' not in why('f1') else 1)"
for bad in 0 5 x; do
  check "--pixel-footprint $bad refused" 2 "--pixel-footprint: must be an integer in \[1, 4\]" -- \
    "$bin" run "$work/scene/scene.json" "${run_opts[@]}" --pixel-footprint "$bad" --out "$work/bad"
done
# 65 dome lights x 16 copies (footprint 4) exceed the 1024 lights a Sample
# can name: refused up front with the most this scene allows (3).
check "synth a 65-light dome" 0 "wrote" -- "$bin" synth --frames 2 --cameras 2 --width 64 --height 48 --dome 65 \
  --config all --out "$work/dome"
check "--pixel-footprint 4 with 65 lights refused (invalid input), naming the most it allows" 3 \
  "pixel_footprint (--pixel-footprint): 4 models each pixel with 16 copies of each of the scene's 65 lights.*at most 3" -- \
  "$bin" run "$work/dome/scene.json" --direct --atlas 64 --pixel-footprint 4 --out "$work/dome_run"
summary
