#!/usr/bin/env bash
# Issue #15: the reflectance model is a choice (`run --brdf`), the truth need
# not be the model fitted (`synth --brdf`), and every output follows the
# model: GGX truth, fitted with GGX, Blinn-Phong and the thesis's Phong, each
# checked against the truth (kd RMSE, GGX's F0 and roughness), through the
# service and directly; the atlases, result.json, evaluate, render and the
# report speak the model's parameters.
# Usage: cli_brdf_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

small=(--cameras 4 --width 160 --height 120 --actor-segments 12 --frames 8)
fit=(--config NE,NW,SE,SW --no-powell --atlas 128)
check "synth --brdf ggx" 0 "" -- "$bin" synth "${small[@]}" --brdf ggx --format png --noise 0 --out "$work/b"
check "synth --brdf cook is a usage error naming the flag" 2 "--brdf: .*expected one of phong, blinn-phong, ggx" -- \
  "$bin" synth "${small[@]}" --brdf cook --out "$work/x"
check "run --brdf cook is a usage error naming the flag" 2 "--brdf: expected phong, blinn-phong, ggx or auto" -- \
  "$bin" run "$work/b/scene.json" --brdf cook --out "$work/x"
check "submit --brdf cook is a usage error too" 2 "--brdf: expected phong, blinn-phong, ggx or auto" -- \
  "$bin" submit "$work/b/scene.json" --brdf cook --server 127.0.0.1:1
check "run --help names --brdf" 0 "--brdf MODEL" -- "$bin" run --help
expect "the truth records the model and GGX's parameters" python3 -c '
import json, sys
t = json.load(open(sys.argv[1]))
m = {x["name"]: x for x in t["materials"]}
sys.exit(not (t["brdf"] == "ggx" and abs(m["cloth"]["f0"][0] - 0.04) < 1e-6 and "ks" not in m["cloth"]
              and abs(m["hair"]["roughness"][0] - (2 / 162) ** 0.25) < 1e-6))' "$work/b/ground_truth/truth.json"

for model in ggx blinn-phong phong; do
  check "run --brdf $model (through the service)" 0 "wrote" -- \
    "$bin" run "$work/b/scene.json" --brdf "$model" "${fit[@]}" --out "$work/$model"
  "$bin" evaluate "$work/$model" --truth "$work/b" > "$work/$model.eval.json" || echo "evaluate $model failed"
done
check "run --direct --brdf ggx" 0 "wrote" -- \
  "$bin" run --direct "$work/b/scene.json" --brdf ggx "${fit[@]}" --out "$work/ggx_direct"

# json FILE EXPR: prints EXPR of the JSON document `d` in FILE.
json() { python3 -c 'import json, sys; d = json.load(open(sys.argv[1])); print(eval(sys.argv[2]))' "$1" "$2"; }
expect "result.json says the model and the fitting options record it" test \
  "$(json "$work/ggx/result.json" 'd["brdf"], d["options"]["fitting"]["brdf"]')" = "('ggx', 'ggx')"
expect "GGX clusters carry f0 and roughness, not ks and ke" python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
sys.exit(not all(len(c.get("f0", [])) == 3 and len(c.get("roughness", [])) == 3 and "ks" not in c
                 for c in d["clusters"]))' "$work/ggx/result.json"
expect "GGX atlases are f0 and roughness" test -f "$work/ggx/atlases/f0.exr" -a -f "$work/ggx/atlases/roughness.exr" \
  -a ! -e "$work/ggx/atlases/ks.exr"
expect "Blinn-Phong and Phong atlases are ks and ke" test -f "$work/blinn-phong/atlases/ke.exr" -a \
  -f "$work/phong/atlases/ks.exr"
expect "the service and the direct run agree" test \
  "$(json "$work/ggx/result.json" '[c["f0"] + c["roughness"] for c in d["clusters"]]')" = \
  "$(json "$work/ggx_direct/result.json" '[c["f0"] + c["roughness"] for c in d["clusters"]]')"

# Against the truth. Measured (this sequence, GGX with F90 / F0 free and its
# prior, charts packed by outline since issue #17): GGX fit roughness errors
# 0.017 / 0.027 / 0.002 and F0 errors 0.195 / 0.155 / 0.033 (cloth / skin /
# hair); kd RMSE GGX 0.0146, Blinn-Phong 0.0161, Phong 0.0159. F0 is weakly
# determined by 4 cameras x 8 frames: over atlases of 96, 112, 128, 144 and
# 160 texels its error moves 0.10-0.28 (cloth), 0.002-0.16 (skin), 0.008-0.10
# (hair), and 0.05-0.27 / 0.02-0.25 / 0.009-0.07 with the charts' rectangles
# packed on shelves as before (F0 0.065 / 0.068 / 0.019 at 128 then); the 5 %
# bound on F0 is cli_ggx_acceptance's, on 8 cameras x 30 frames. (With F90 /
# F0 fixed at 25 the old atlas gave 0.040 / 0.025 / 0.019, with F90 fixed at 1
# 0.047 / 0.137 / 0.019. 8 cameras x 30 frames: F0 0.033 / 0.004 / 0.006,
# roughness 0.003 / 0.024 / 0.001, F90 / F0 within 3.4 % of the truth's 25,
# kd RMSE 0.0113.)
python3 - "$work" <<'PY'
import json, sys
work = sys.argv[1]
e = {m: json.load(open("%s/%s.eval.json" % (work, m))) for m in ("ggx", "blinn-phong", "phong")}
bad = []
for c in e["ggx"]["clusters"]:
    if not c.get("parametersCompared"):
        bad.append("%s: GGX parameters not compared" % c["cluster"]); continue
    f0_bound = 0.3
    print("  GGX %s: F0 error %.3f, roughness error %.3f" % (c["cluster"], c["ksRelError"], c["keRelError"]))
    if c["keRelError"] > 0.1: bad.append("%s roughness error %.3f > 0.1" % (c["cluster"], c["keRelError"]))
    if c["ksRelError"] > f0_bound: bad.append("%s F0 error %.3f > %g" % (c["cluster"], c["ksRelError"], f0_bound))
    # F90 / F0 against the truth's dielectric (25).
    ratio = c.get("f90RatioRelError")
    print("  GGX %s: F90 / F0 %s, error %s" % (c["cluster"], c.get("f90Ratio"), ratio))
    if ratio is None or len(c.get("f90RatioTrue", [])) != 3 or ratio > 0.5:
        bad.append("%s F90 / F0 not compared with the truth's or off by more than 50 %%: %s" % (c["cluster"], ratio))
for m in ("blinn-phong", "phong"):
    for c in e[m]["clusters"]:
        if c.get("parametersCompared") or c.get("ks"):
            bad.append("%s fitted to GGX truth: parameters compared across models" % m)
kd = {m: e[m]["kdRmse"] for m in e}
print("  kd RMSE on GGX truth: " + ", ".join("%s %.4f" % (m, kd[m]) for m in kd))
if not kd["ggx"] < min(kd["blinn-phong"], kd["phong"]): bad.append("the true model does not fit kd best: %s" % kd)
if kd["ggx"] > 0.02: bad.append("GGX kd RMSE %.4f > 0.02" % kd["ggx"])
# The relighting error (held-out views and lights): the true model relights best.
relit = {m: e[m]["relighting"]["relativeRmse"] for m in e}
print("  relighting relative RMSE on GGX truth: " + ", ".join("%s %.4f" % kv for kv in relit.items()))
if not relit["ggx"] < min(relit["blinn-phong"], relit["phong"]): bad.append("GGX does not relight best: %s" % relit)
rows = e["ggx"]["relighting"]["rows"]
if len(rows) != 12 or any(r["pixels"] == 0 for r in rows): bad.append("relighting rows: %s" % rows)
for b in bad: print("FAIL " + b)
sys.exit(1 if bad else 0)
PY
expect "GGX fits its own truth (parameters, kd RMSE and relighting error below the other models')" test $? -eq 0
expect "each relighting row says its pixels per true material, and they add up to the material rows" python3 -c '
import json, math, sys
r = json.load(open(sys.argv[1]))["relighting"]
ok = all(sum(m["pixels"] for m in row["materials"]) == row["pixels"] for row in r["rows"])
for mat in r["materials"]:
    cells = [m for row in r["rows"] for m in row["materials"] if m["material"] == mat["material"]]
    sq = sum(m["rmse"] ** 2 * m["pixels"] for m in cells)
    ok &= sum(m["pixels"] for m in cells) == mat["pixels"] and math.isclose(sq / mat["pixels"], mat["rmse"] ** 2, rel_tol=1e-6)
sys.exit(not (ok and len({m["material"] for row in r["rows"] for m in row["materials"]}) == 3))' "$work/ggx.eval.json"
check "evaluate --no-relighting leaves it out" 0 "" -- "$bin" evaluate "$work/ggx" --truth "$work/b" --no-relighting
expect "no relighting key with --no-relighting" test \
  "$("$bin" evaluate "$work/ggx" --truth "$work/b" --no-relighting | grep -c relighting)" = 0
"$bin" evaluate "$work/ggx" --truth "$work/b" --relight-views 2 --relight-lights 1 --relight-frame 2 \
  > "$work/ggx.relight.json" || echo "evaluate --relight-* failed"
expect "--relight-views, --relight-lights and --relight-frame choose the rows and the pose" test \
  "$(json "$work/ggx.relight.json" 'len(d["relighting"]["rows"]), d["relighting"]["frame"], d["relighting"]["rmse"] != json.load(open("'"$work"'/ggx.eval.json"))["relighting"]["rmse"]')" = \
  "(2, 2, True)"
check "--relight-views 0 is a usage error" 2 "--relight-views" -- "$bin" evaluate "$work/ggx" --truth "$work/b" \
  --relight-views 0
# --relight-images: each row's images, and the view and light that `render`
# draws the row's reconstruction from again, byte for byte.
check "evaluate --relight-images writes each row's images" 0 "" -- "$bin" evaluate "$work/ggx" --truth "$work/b" \
  --relight-views 2 --relight-lights 1 --relight-frame 2 --relight-images "$work/relit"
expect "one set of images per relighting row" test \
  "$(ls "$work/relit" | grep -c -E '^00[01](_truth.exr|_reconstruction.exr|_counted.png|_camera.json|_lights.json|.png)$')" = 12
check "render draws row 1's view and light at the row's frame" 0 "wrote" -- "$bin" render "$work/ggx" \
  --camera "$work/relit/001_camera.json" --lights "$work/relit/001_lights.json" --frame 2 --out "$work/relit1.exr"
expect "render's image is the row's reconstruction, byte for byte" cmp "$work/relit1.exr" \
  "$work/relit/001_reconstruction.exr"
expect "the row's truth is not its reconstruction" test "$(cmp -s "$work/relit/001_truth.exr" \
  "$work/relit/001_reconstruction.exr"; echo $?)" = 1
check "--relight-images into a non-empty directory is refused" 3 "not empty" -- "$bin" evaluate "$work/ggx" \
  --truth "$work/b" --relight-views 1 --relight-lights 1 --relight-images "$work/relit"
check "--relight-images with --no-relighting is a usage error" 2 "--relight-images" -- "$bin" evaluate "$work/ggx" \
  --truth "$work/b" --no-relighting --relight-images "$work/relit2"
check "--force clears it first (a directory evaluate wrote)" 0 "" -- "$bin" evaluate "$work/ggx" --truth "$work/b" \
  --relight-views 1 --relight-lights 1 --relight-images "$work/relit" --force
expect "only the new run's row is left" test "$(ls "$work/relit" | grep -c -E '^[0-9]{3}')" = 6
# --relight-supersample N: each pixel the average of N x N subpixels (what a
# sensor's pixel integrates); only pixels covered whole count; render
# --supersample N draws the same image.
"$bin" evaluate "$work/ggx" --truth "$work/b" --relight-views 2 --relight-lights 1 --relight-frame 2 \
  --relight-supersample 3 --relight-images "$work/relit3" > "$work/ggx.relight3.json" ||
  echo "evaluate --relight-supersample failed"
expect "--relight-supersample 3 is recorded, counts fewer pixels (those covered whole) and changes the error" test \
  "$(json "$work/ggx.relight3.json" 'd["relighting"]["supersample"], all(a["pixels"] < b["pixels"] for a, b in zip(d["relighting"]["rows"], json.load(open("'"$work"'/ggx.relight.json"))["relighting"]["rows"])), d["relighting"]["rmse"] != json.load(open("'"$work"'/ggx.relight.json"))["relighting"]["rmse"]')" = \
  "(3, True, True)"
check "render --supersample 3 draws row 1's view and light" 0 "wrote" -- "$bin" render "$work/ggx" \
  --camera "$work/relit3/001_camera.json" --lights "$work/relit3/001_lights.json" --frame 2 --supersample 3 \
  --out "$work/relit3_1.exr"
expect "render --supersample 3's image is the supersampled row's reconstruction, byte for byte" cmp \
  "$work/relit3_1.exr" "$work/relit3/001_reconstruction.exr"
expect "and not the point-sampled one" test "$(cmp -s "$work/relit3_1.exr" "$work/relit1.exr"; echo $?)" = 1
check "--relight-supersample 0 is a usage error" 2 "--relight-supersample" -- "$bin" evaluate "$work/ggx" \
  --truth "$work/b" --relight-supersample 0
check "render --supersample 9 is refused" 3 "--supersample" -- "$bin" render "$work/ggx" --camera cam1 \
  --lights "$work/relit3/001_lights.json" --supersample 9 --out "$work/ss9.exr"

# render and the report follow the model: the GGX reconstruction drawn by
# `render` is closer to the GGX truth's frame than the other models'.
python3 -c 'import json, sys
s = json.load(open(sys.argv[1]))
json.dump({"lights": [l for l in s["lights"] if l["name"] in ("NE", "NW", "SE", "SW")]}, open(sys.argv[2], "w"))' \
  "$work/b/scene.json" "$work/lights.json"
for model in ggx blinn-phong phong; do
  check "render the $model reconstruction" 0 "wrote" -- "$bin" render "$work/$model" --camera cam1 \
    --lights "$work/lights.json" --frame 3 --alpha --out "$work/render_$model.png"
done
python3 - "$work" "$(dirname "$0")" <<'PY'
import sys
work = sys.argv[1]
sys.path.insert(0, sys.argv[2])
from png_read import covered_linear, linear, read_png
truth = read_png("%s/b/videos/cam1/0003.png" % work)
error = {}
for m in ("ggx", "blinn-phong", "phong"):
    r = covered_linear("%s/render_%s.png" % (work, m))
    err = n = 0
    for y, row in enumerate(r):
        for x, px in enumerate(row):
            if px is None: continue
            err += sum(abs(px[k] - linear(truth[y][x][k])) for k in range(3))
            n += 3
    error[m] = err / max(n, 1)
# Measured: GGX 0.0040, Blinn-Phong 0.0058, Phong 0.0054 (mean |linear error| over covered pixels).
print("  render vs the truth's frame: " + ", ".join("%s %.5f" % kv for kv in error.items()))
sys.exit(0 if error["ggx"] < min(error["blinn-phong"], error["phong"]) and error["ggx"] < 0.008 else 1)
PY
expect "the GGX render is the closest to the truth" test $? -eq 0
check "report of the GGX run" 0 "wrote" -- "$bin" report "$work/ggx" --truth "$work/b" --out "$work/report.html"
expect "the report names the model and its parameters" grep -q "Reflectance model: ggx.*f0 (RGB).*roughness (RGB)" \
  "$work/report.html"
expect "the report shows the relighting error" grep -q 'id="relighting"' "$work/report.html"

# --brdf auto: per cluster the model its held-out Samples prefer; on GGX
# truth every cluster picks GGX and relights as well as the GGX run.
check "run --brdf auto" 0 "wrote" -- "$bin" run "$work/b/scene.json" --brdf auto "${fit[@]}" --out "$work/auto"
expect "auto writes the model atlas and model-neutral parameter atlases" test -f "$work/auto/atlases/model.png" -a \
  -f "$work/auto/atlases/parameter_1.exr" -a -f "$work/auto/atlases/parameter_2.exr" -a ! -e "$work/auto/atlases/f0.exr"
"$bin" evaluate "$work/auto" --truth "$work/b" > "$work/auto.eval.json" || echo "evaluate auto failed"
python3 - "$work" <<'PY'
import json, sys
work = sys.argv[1]
d = json.load(open("%s/auto/result.json" % work))
e = {m: json.load(open("%s/%s.eval.json" % (work, m))) for m in ("auto", "ggx", "phong")}
bad = []
if d["brdf"] != "auto" or d["options"]["fitting"]["brdf"] != "auto": bad.append("result.json brdf: %s" % d["brdf"])
for c in d["clusters"]:
    choices = {m["model"]: m["heldOutRmse"] for m in c.get("modelChoices", [])}
    print("  auto %s: %s (%s)" % (c["name"], c.get("brdf"), c.get("brdfReason")))
    if sorted(choices) != ["blinn-phong", "ggx", "phong"]: bad.append("%s: model choices %s" % (c["name"], choices))
    if c.get("brdf") != "ggx": bad.append("%s picked %s on GGX truth" % (c["name"], c.get("brdf")))
    if c.get("brdf") == "ggx" and len(c.get("f0", [])) != 3: bad.append("%s: no f0" % c["name"])
for c in e["auto"]["clusters"]:
    if not c.get("parametersCompared"): bad.append("%s: auto's GGX parameters not compared" % c["cluster"])
relit = {m: e[m]["relighting"]["relativeRmse"] for m in e}
print("  relighting relative RMSE: " + ", ".join("%s %.4f" % kv for kv in relit.items()))
if abs(relit["auto"] - relit["ggx"]) > 0.02 or not relit["auto"] < relit["phong"]: bad.append("relighting %s" % relit)
for b in bad: print("FAIL " + b)
sys.exit(1 if bad else 0)
PY
expect "auto picks GGX on GGX truth, records why, and relights like GGX" test $? -eq 0
# A cluster without parameters (flagged tiny: its texels joined another) has no
# model of its own in an auto run; evaluate takes it as it is.
cp -r "$work/auto" "$work/auto_tiny"
python3 -c 'import json, sys
d = json.load(open(sys.argv[1]))
d["clusters"].append({"name": "stray", "texels": 0, "centre": [0.5, 0.5, 0.5], "flags": ["tiny"]})
json.dump(d, open(sys.argv[1], "w"))' "$work/auto_tiny/result.json"
check "evaluate an auto run with a tiny cluster" 0 "clusterAccuracy" -- "$bin" evaluate "$work/auto_tiny" \
  --truth "$work/b" --no-relighting
check "render the auto reconstruction" 0 "wrote" -- "$bin" render "$work/auto" --camera cam1 \
  --lights "$work/lights.json" --frame 3 --out "$work/render_auto.png"
check "report of the auto run" 0 "wrote" -- "$bin" report "$work/auto" --truth "$work/b" --out "$work/report_auto.html"
expect "the report shows models x clusters" grep -q 'Reflectance model: auto.*id="models".*held-out RMSE' \
  "$work/report_auto.html"

summary
