#!/usr/bin/env bash
# Issue #15: a measured material as the truth (synth --materials: MERL's
# neural BRDFs in ../shared/data/merl_nbrdf), and GGX drawn within the
# capture's grazing support (core/fit/grazing_support.h). Yellow-phenolic alone
# on the sphere under a 48-light OLAT dome, exposed for its highlights: its
# measured mirror peak levels off past ~75 degrees where a fitted GGX lobe's
# keeps rising as 1 / cos^2, and drawn plain GGX relit held-out views and
# lights worse than Phong (docs/models.md). Checked against the truth: held at
# the support GGX relights better than plain, and within 5 % of Phong or
# better (the issue's "never worse than Phong by more than 5 %").
# Usage: cli_merl_test.sh MVBRDF_BINARY WORK_DIR MERL_NBRDF_JSON
# Exits 77 (ctest: skipped), saying why, when MERL_NBRDF_JSON is missing.
set -u
bin=$1
work=$2
merl=$3
if [ ! -f "$merl" ]; then
  echo "SKIP: the measured materials are not here: $merl (../shared/data/merl_nbrdf/merl_nbrdf.json)"
  exit 77
fi
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

check "synth: yellow-phenolic on the sphere, 48-light OLAT, 16-bit" 0 "wrote" -- "$bin" synth --preset sphere \
  --dome 48 --lighting olat --frames 48 --materials yellow-phenolic --measured-exposure highlights --bit-depth 16 \
  --format png --merl-file "$merl" --out "$work/s"
for model in ggx phong; do
  check "run --brdf $model" 0 "wrote" -- "$bin" run --direct "$work/s/scene.json" --brdf "$model" --no-powell \
    --out "$work/$model"
done

# json FILE EXPR: prints EXPR of the JSON document `d` in FILE.
json() { python3 -c 'import json, sys; d = json.load(open(sys.argv[1])); print(eval(sys.argv[2]))' "$1" "$2"; }
supports() { json "$1/result.json" '[round(c.get("ggxGrazingSupport", 0), 4) for c in d["clusters"]]'; }
echo "     GGX grazing support per cluster: $(supports "$work/ggx")"
expect "result.json: the GGX cluster's grazing support, in (0, 1)" python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
sys.exit(not (len(d["clusters"]) == 1 and 0 < d["clusters"][0].get("ggxGrazingSupport", 0) < 1))' \
  "$work/ggx/result.json"
expect "a Phong run has none" test "$(supports "$work/phong")" = "[0]"

"$bin" evaluate "$work/ggx" --truth "$work/s" > "$work/ggx.eval.json" || echo "evaluate ggx failed"
"$bin" evaluate "$work/ggx" --truth "$work/s" --no-grazing-support > "$work/ggx_plain.eval.json" ||
  echo "evaluate ggx --no-grazing-support failed"
"$bin" evaluate "$work/phong" --truth "$work/s" > "$work/phong.eval.json" || echo "evaluate phong failed"
expect "evaluate records that GGX was drawn within its support (not with --no-grazing-support)" test \
  "$(json "$work/ggx.eval.json" 'd["relighting"].get("grazingSupport", False)') $(json \
    "$work/ggx_plain.eval.json" 'd["relighting"].get("grazingSupport", False)')" = "True False"
# Measured (2026-12-06, this test's capture): relative relighting RMSE GGX
# held 0.351, GGX plain 0.954, Phong 0.652 (docs/models.md).
python3 - "$work" <<'PY'
import json, sys
work = sys.argv[1]
r = {name: json.load(open("%s/%s.eval.json" % (work, name)))["relighting"]["relativeRmse"]
     for name in ("ggx", "ggx_plain", "phong")}
print("     relative relighting RMSE against the measured truth: GGX held %.3f, GGX plain %.3f, Phong %.3f" %
      (r["ggx"], r["ggx_plain"], r["phong"]))
json.dump(r, open(work + "/relighting.json", "w"))
PY
rel() { json "$work/relighting.json" "d['$1']"; }
expect "held at the support, GGX relights the measured material better than plain" python3 -c \
  "import sys; sys.exit(not $(rel ggx) < 0.8 * $(rel ggx_plain))"
expect "held at the support, GGX is no worse than Phong by more than 5 %" python3 -c \
  "import sys; sys.exit(not $(rel ggx) <= 1.05 * $(rel phong))"

# render draws what evaluate scored, both ways.
check "evaluate --relight-images (one row)" 0 "" -- "$bin" evaluate "$work/ggx" --truth "$work/s" \
  --relight-views 1 --relight-lights 1 --relight-images "$work/row"
check "render: the row's view and light" 0 "wrote" -- "$bin" render "$work/ggx" \
  --camera "$work/row/000_camera.json" --lights "$work/row/000_lights.json" --out "$work/held.exr"
check "render --no-grazing-support" 0 "wrote" -- "$bin" render "$work/ggx" --no-grazing-support \
  --camera "$work/row/000_camera.json" --lights "$work/row/000_lights.json" --out "$work/plain.exr"
expect "render draws the row's reconstruction, byte for byte" cmp "$work/held.exr" \
  "$work/row/000_reconstruction.exr"
expect "render --no-grazing-support draws another image" test "$(cmp -s "$work/held.exr" "$work/plain.exr"; echo $?)" = 1

summary
