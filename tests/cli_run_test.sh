#!/usr/bin/env bash
# End-to-end: `mvbrdf run` on a generated bundle, then `render` and
# `evaluate` on its outputs; bad input gets the documented exit codes.
# Usage: cli_run_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

"$bin" synth --cameras 4 --frames 3 --width 160 --height 120 --actor-segments 12 --out "$work/b" >/dev/null || exit 1
scene="$work/b/scene.json"
cat > "$work/lights.json" <<'JSON'
{"lights": [{"name": "key", "position": [2.0, 3.0, 2.0], "intensity": [1.0, 0.9, 0.8]},
            {"name": "sun", "direction": [0.0, 1.0, 0.0], "intensity": [0.3, 0.3, 0.3]}]}
JSON
cat > "$work/bad_lights.json" <<'JSON'
{"lights": [{"name": "key", "position": [2.0, 3.0], "intensity": [1.0, 0.9, 0.8]}]}
JSON

check "run help" 0 "--outputs" -- "$bin" run --help
check "bad outputs" 2 "--outputs: expected light, brdf, correction, errors or normals" -- "$bin" run "$scene" --outputs shiny --out "$work/x"
check "unknown configuration" 3 "no light configuration \"XY\"" -- "$bin" run "$scene" --config XY --out "$work/x"
check "missing scene" 3 "nope.json" -- "$bin" run "$work/nope.json" --out "$work/x"
check "plan printed, light table only" 0 "skip  texel_pass: only the light table was requested" -- \
  "$bin" run "$scene" --outputs light --out "$work/light"
[ ! -d "$work/light/atlases" ] && { echo "ok   light table only writes no atlases"; passes=$((passes + 1)); } ||
  { echo "FAIL light table only wrote atlases"; failures=$((failures + 1)); }

# Issue #19 defect 8: --direct swept all 8 configurations whatever --candidates
# said, and the service's plan said "8 candidate configurations" for 2.
# swept DIR: the configurations result.json's light table has, one line.
swept() { python3 -c 'import json,sys; print(";".join(r["name"] for r in json.load(open(sys.argv[1]))["lightConfigurations"]))' "$1/result.json"; }
check "--candidates --direct: the plan counts what is swept" 0 "run   light_sweep: 2 candidate configurations" -- \
  "$bin" run "$scene" --direct --outputs light --candidates "C;NE,NW,SE,SW" --out "$work/cand_direct"
check "--candidates via the service" 0 "run   light_sweep: 2 candidate configurations" -- \
  "$bin" run "$scene" --outputs light --candidates "C;NE,NW,SE,SW" --out "$work/cand_service"
expect "direct and service sweep exactly the named configurations" \
  test "$(swept "$work/cand_direct")" = "C;NE,NW,SE,SW" -a "$(swept "$work/cand_service")" = "C;NE,NW,SE,SW"
expect "the service's result.json plan counts 2 candidates" \
  grep -q '"why": "2 candidate configurations' "$work/cand_service/result.json"
check "--candidates: an unknown name fails naming it" 3 '--candidates: the scene has no light configuration "NE,XX"' -- \
  "$bin" run "$scene" --direct --outputs light --candidates "C;NE,XX" --out "$work/x"
check "--candidates: an unknown name fails on the service path too" 3 '"NE,XX"' -- \
  "$bin" run "$scene" --outputs light --candidates "C;NE,XX" --out "$work/x"
check "a known wrong configuration (light table only)" 0 "configuration given: C" -- \
  "$bin" run "$scene" --direct --outputs light --config C --out "$work/cand_direct_c"
check "--candidates: an empty name is a usage error" 2 "--candidates: configuration 2 is empty" -- \
  "$bin" run "$scene" --direct --outputs light --candidates "C;;NE,NW,SE,SW" --out "$work/x"
mkdir -p "$work/tmp"
check "full run" 0 "correction atlas" -- env TMPDIR="$work/tmp" "$bin" run "$scene" --config "NE,NW,SE,SW" --no-powell \
  --atlas 256 --out "$work/run"
# The first pass's resampled atlases, kept for the texel pass in an unlinked
# file under TMPDIR (pipeline::ResampledAtlasCache): nothing left there, and
# without it (no such directory: every pass resamples; --direct, since the
# embedded service needs TMPDIR for its state) the same outputs bit for bit.
expect "the kept atlases leave nothing in TMPDIR" test -z "$(ls -A "$work/tmp")"
check "a TMPDIR that does not exist is an environment error naming it" 4 "TMPDIR=$work/no_such_dir" -- \
  env TMPDIR="$work/no_such_dir" "$bin" run "$scene" --config "NE,NW,SE,SW" --no-powell --atlas 256 --out "$work/x"
for tmp in tmp no_such_dir; do
  check "--direct, TMPDIR $tmp" 0 "correction atlas" -- env TMPDIR="$work/$tmp" "$bin" run "$scene" --direct \
    --config "NE,NW,SE,SW" --no-powell --atlas 256 --out "$work/direct_$tmp"
done
for f in atlases/kd.exr atlases/ks.exr atlases/ke.exr atlases/correction/0000.exr atlases/correction/0002.exr; do
  expect "$f: the same with the kept atlases as resampled" cmp "$work/direct_tmp/$f" "$work/direct_no_such_dir/$f"
done
expect "result.json's per-camera errors, reliability counts and fits the same with the kept atlases as resampled" \
  python3 -c '
import json, sys
a, b = (json.load(open(p + "/result.json")) for p in sys.argv[1:])
keys = ["cameras", "reliability", "clusters", "texelsSeen", "robustScales"]
sys.exit(0 if all(a.get(k) == b.get(k) for k in keys) and a.get("cameras") else 1)' \
  "$work/direct_tmp" "$work/direct_no_such_dir"
for f in result.json atlases/kd.exr atlases/ks.exr atlases/ke.exr atlases/cluster.exr atlases/confidence.exr \
         atlases/correction/0002.exr atlas/mesh.obj; do
  [ -f "$work/run/$f" ] && { echo "ok   wrote $f"; passes=$((passes + 1)); } || { echo "FAIL missing $f"; failures=$((failures + 1)); }
done
grep -q '"chosenConfiguration": "NE,NW,SE,SW"' "$work/run/result.json" && grep -q '"skipped"' "$work/run/result.json" &&
  { echo "ok   result.json has the plan and the configuration"; passes=$((passes + 1)); } ||
  { echo "FAIL result.json"; failures=$((failures + 1)); }
check "evaluate" 0 '"configurationCorrect": true' -- "$bin" evaluate "$work/run" --truth "$work/b"
check "evaluate without truth" 3 "truth.json" -- "$bin" evaluate "$work/run" --truth "$work"
# Issue #19 defect 9: the truth of another scene (other mesh, other cameras)
# said "configurationCorrect": true; false was left out of the JSON.
"$bin" synth --cameras 2 --frames 1 --width 64 --height 48 --actor-segments 6 --out "$work/other" >/dev/null || exit 1
check "evaluate against another scene's truth" 3 "--truth: mesh" -- "$bin" evaluate "$work/run" --truth "$work/other"
cp -r "$work/b" "$work/b_cams"
python3 - "$work/b_cams/ground_truth/truth.json" <<'EOF_PY'
import json, sys
truth = json.load(open(sys.argv[1]))
truth["cameras"][2]["name"] = "elsewhere"
del truth["scene"]["cameras"]  # as an older truth file: the cameras as rendered decide
json.dump(truth, open(sys.argv[1], "w"))
EOF_PY
check "evaluate against a truth with other cameras" 3 'cameras.2. names differ: the run' -- \
  "$bin" evaluate "$work/run" --truth "$work/b_cams"
check "a wrong configuration prints configurationCorrect: false" 0 '"configurationCorrect": false' -- \
  "$bin" evaluate "$work/cand_direct_c" --truth "$work/b"
check "render a scene camera" 0 "wrote" -- "$bin" render "$work/run" --camera cam1 --lights "$work/lights.json" --out "$work/cam1.png"
check "render with correction" 0 "wrote" -- "$bin" render "$work/run" --camera cam1 --lights "$work/lights.json" --frame 2 --correction --out "$work/cam1.exr"
check "render unknown camera" 3 "nocam" -- "$bin" render "$work/run" --camera nocam --lights "$work/lights.json" --out "$work/x.png"
check "render bad lights" 3 "bad_lights.json" -- "$bin" render "$work/run" --camera cam1 --lights "$work/bad_lights.json" --out "$work/x.png"
check "render bad frame" 3 "--frame" -- "$bin" render "$work/run" --camera cam1 --lights "$work/lights.json" --frame 9 --out "$work/x.png"
size=$(stat -c %s "$work/cam1.png" 2>/dev/null || echo 0)
[ "$size" -gt 1000 ] && { echo "ok   rendered image has content ($size bytes)"; passes=$((passes + 1)); } ||
  { echo "FAIL rendered image is empty"; failures=$((failures + 1)); }

# The HTML report (its rendering in a browser is checked by core/report's test).
check "report" 0 "wrote" -- "$bin" report "$work/run" --relit-frames 4 --out "$work/report.html"
for section in 'id="truth"' 'id="plan"' 'id="table71"' 'id="atlases"' 'id="cameras"' 'id="relit"' \
               'Configuration <b class="ok">right</b>'; do
  grep -q "$section" "$work/report.html" && { echo "ok   report has $section"; passes=$((passes + 1)); } ||
    { echo "FAIL report lacks $section"; failures=$((failures + 1)); }
done
check "report without renderings or truth" 0 "wrote" -- "$bin" report "$work/run" --no-render --no-truth \
  --out "$work/plain.html"
grep -q 'id="cameras"' "$work/plain.html" && { echo "FAIL --no-render still rendered"; failures=$((failures + 1)); } ||
  { echo "ok   --no-render leaves the renderings out"; passes=$((passes + 1)); }
check "report of a missing run" 3 "result.json" -- "$bin" report "$work/nope" --out "$work/x.html"
check "run --report writes report.html (light table only: no atlases to draw)" 0 "report.html" -- \
  "$bin" run "$scene" --outputs light --report --out "$work/light_report"

summary
