#!/usr/bin/env bash
# Issue #18, against the truth: per-texel normals refined from the video.
# An OLAT sphere (one orthographic camera, 96 dome lights, one light per
# frame) rendered with procedural normal detail below the mesh's resolution
# (`synth --normal-detail 0.3`, ~17 degrees of tilt per axis):
#   - `--outputs ...,normals` plans the stage, writes atlases/normal.exr,
#     normal.png and normal_sigma.exr, and result.json's normals row;
#   - the normals' angular error against the truth: median <= 2 degrees,
#     90th percentile <= 5 (the mesh's own normals: ~12 / ~15.5);
#   - kd RMSE and the held-out relighting error (evaluate's, against the truth
#     drawn with its detail) at least 30 % lower than the same run with the
#     mesh's normals; the cluster fits redone with the refined normals' Samples
#     give ks and ke within 15 % (the mesh's normals: ~50 % / ~60 %);
#   - without the output the stage is skipped with its reason, and the run
#     without detail is unchanged by the stage's presence in the binary.
# Usage: cli_normals_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

olat=(--preset sphere --lighting olat --camera-model orthographic --cameras 1 --dome 96 --frames 96 --width 256
      --height 256)
check "synth --normal-detail" 0 "wrote" -- "$bin" synth "${olat[@]}" --normal-detail 0.3 --out "$work/bumps"
expect "the truth records the detail" python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))["normalDetail"]
sys.exit(not (abs(d["amplitude"] - 0.3) < 1e-6 and d["wavelength"] > 0 and len(d["d1"]) == 3))' \
  "$work/bumps/ground_truth/truth.json"
expect "the meshes carry the UVs the detail is read with" grep -q "^vt " "$work/bumps/meshes/mesh_0000.obj"
check "synth --normal-detail: a negative slope is refused" 2 "--normal-detail" -- \
  "$bin" synth "${olat[@]}" --normal-detail -1 --out "$work/x"

run=(--no-powell --atlas 256)
check "run with normals" 0 "normals          done" -- \
  "$bin" run "$work/bumps/scene.json" "${run[@]}" --outputs light,brdf,errors,normals --out "$work/refined"
for f in normal.exr normal.png normal_sigma.exr; do
  expect "atlases/$f written" test -s "$work/refined/atlases/$f"
done
check "run without normals" 0 "skip  normals: not requested" -- \
  "$bin" run "$work/bumps/scene.json" "${run[@]}" --outputs light,brdf,errors --out "$work/mesh"
expect "no normal atlas without the output" test ! -e "$work/mesh/atlases/normal.exr"
check "--outputs: an unknown output names the choices" 2 "errors or normals" -- \
  "$bin" run "$work/bumps/scene.json" --outputs light,bumps --out "$work/x"

# figures RUN: "median p90 mesh_median kd_rmse refined_fraction relighting worst_ks worst_ke"
figures() {
  "$bin" evaluate "$1" --truth "$work/bumps" | python3 -c '
import json, sys
d = json.load(sys.stdin)
n = d["normals"]
r = json.load(open(sys.argv[1] + "/result.json")).get("normals", {})
frac = r.get("refined", 0) / max(1, r.get("texels", 1))
print(n["medianDeg"], n["p90Deg"], n["meshMedianDeg"], d["kdRmse"], frac, d["relighting"]["relativeRmse"],
      max(c["ksRelError"] for c in d["clusters"]), max(c["keRelError"] for c in d["clusters"]))' "$1"
}
read -r median p90 mesh_median kd_refined frac relight_refined ks_refined ke_refined < <(figures "$work/refined")
read -r _ _ _ kd_mesh _ relight_mesh ks_mesh ke_mesh < <(figures "$work/mesh")
echo "     normals: median $median deg, p90 $p90 deg (mesh normals: median $mesh_median deg); refined $frac of texels"
echo "     kd RMSE: $kd_refined with the refined normals, $kd_mesh with the mesh's"
echo "     held-out relighting (relative RMSE): $relight_refined with the refined normals, $relight_mesh with the mesh's"
echo "     worst ks / ke relative error: $ks_refined / $ke_refined with the refined normals, $ks_mesh / $ke_mesh with the mesh's"
expect "normals: median <= 2 degrees" python3 -c "import sys; sys.exit(not $median <= 2.0)"
expect "normals: 90th percentile <= 5 degrees" python3 -c "import sys; sys.exit(not $p90 <= 5.0)"
expect "the detail is there to find (mesh normals' median > 8 degrees)" \
  python3 -c "import sys; sys.exit(not $mesh_median > 8.0)"
expect "most texels refined" python3 -c "import sys; sys.exit(not $frac >= 0.9)"
expect "kd RMSE >= 30 % lower with the refined normals" \
  python3 -c "import sys; sys.exit(not $kd_refined <= 0.7 * $kd_mesh)"
expect "held-out relighting error >= 30 % lower with the refined normals" \
  python3 -c "import sys; sys.exit(not $relight_refined <= 0.7 * $relight_mesh)"
expect "the cluster fits again with the refined normals: ks and ke within 15 %" \
  python3 -c "import sys; sys.exit(not ($ks_refined <= 0.15 and $ke_refined <= 0.15))"

summary
