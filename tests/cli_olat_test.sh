#!/usr/bin/env bash
# Issue #13 item 1: per-frame lighting (scene.frameLighting) in every stage,
# tested against the truth. A one-light-at-a-time sequence (`synth --lighting
# olat`: frame t lit by studio light t mod 9 alone) must reconstruct kd as
# well as the studio sequence lit by four lights; with frameLighting ignored
# every frame was modelled as lit by all nine lights and kd came out ~1/9 of
# the truth (kd RMSE 0.164 against 0.022), exit 0.
# Usage: cli_olat_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

small=(--cameras 4 --frames 9 --width 160 --height 120 --actor-segments 12)
check "synth --lighting olat" 0 "active configuration per-frame lighting" -- \
  "$bin" synth "${small[@]}" --lighting olat --out "$work/olat"
check "synth --lighting: an unknown value is a usage error" 2 "--lighting: expected studio or olat" -- \
  "$bin" synth "${small[@]}" --lighting disco --out "$work/x"
"$bin" synth "${small[@]}" --out "$work/studio" >/dev/null || exit 1
olat="$work/olat/scene.json"

# frames.json FILE: one line per frame, its lights, from scene.json or truth.json.
frames() { python3 -c 'import json,sys; print(" ".join(",".join(f["lights"]) for f in json.load(open(sys.argv[1]))["frameLighting"]))' "$1"; }
expect "scene.json: frame t lit by studio light t mod 9" test "$(frames "$olat")" = "C N E W S NE NW SE SW"
expect "the truth records the same frame lighting" test "$(frames "$work/olat/ground_truth/truth.json")" = "$(frames "$olat")"
check "validate counts the frames with their own lights" 0 \
  "Frame lighting: 9 frames with their own lights (every frame: no configuration to choose, no light sweep)" -- \
  "$bin" validate "$olat"

check "run --direct: the sweep is skipped, lighting is given per frame" 0 \
  "skip  light_sweep: lighting is given per frame (scene.frame_lighting names the lights of all 9 frames)" -- \
  "$bin" run --direct "$olat" --no-powell --atlas 256 --out "$work/direct"
check "run through the service: the same plan" 0 "skip  light_sweep: lighting is given per frame" -- \
  "$bin" run "$olat" --no-powell --atlas 256 --out "$work/service"
check "run --direct on the studio sequence" 0 "correction atlas" -- \
  "$bin" run --direct "$work/studio/scene.json" --config "NE,NW,SE,SW" --no-powell --atlas 256 --out "$work/studio_run"
for f in atlases/kd.exr atlases/correction/0008.exr; do
  expect "per-frame lighting run wrote $f" test -f "$work/direct/$f"
done

# errors RUN TRUTH: "kd_rmse min_cloth_kd_ratio max_ks_rel_error max_ke_rel_error" from `evaluate --truth`,
# printed with the per-cluster figures for the log.
errors() {
  "$bin" evaluate "$1" --truth "$2" | python3 -c '
import json, sys
d = json.load(sys.stdin)
for c in d["clusters"]:
    print("  %-6s ks rel error %.3f, ke rel error %.3f, kd RMSE %.4f" % (c["cluster"], c["ksRelError"], c["keRelError"], c["kdRmse"]), file=sys.stderr)
print(d["kdRmse"], d["configurationCorrect"], max(c["ksRelError"] for c in d["clusters"]),
      max(c["keRelError"] for c in d["clusters"]))'
}
read -r kd_direct correct_direct ks_direct ke_direct < <(errors "$work/direct" "$work/olat")
read -r kd_service correct_service ks_service ke_service < <(errors "$work/service" "$work/olat")
read -r kd_studio correct_studio ks_studio ke_studio < <(errors "$work/studio_run" "$work/studio")
echo "     kd RMSE: olat --direct $kd_direct, olat service $kd_service, studio $kd_studio"
echo "     ks/ke worst relative error: olat $ks_direct/$ke_direct, studio $ks_studio/$ke_studio"
# Measured: olat 0.0216 (direct and service alike), studio 0.0203; ignoring
# frameLighting gave 0.164 (kd scaled by ~1/9).
expect "OLAT kd RMSE within 0.01 of the studio's" \
  python3 -c "import sys; sys.exit(not abs($kd_direct - $kd_studio) <= 0.01)"
expect "OLAT kd RMSE far from the 1/N-scaled result (< 0.04)" python3 -c "import sys; sys.exit(not $kd_direct < 0.04)"
expect "the service path gives the same kd RMSE" python3 -c "import sys; sys.exit(not abs($kd_service - $kd_direct) <= 1e-6)"
expect "the configuration is right: per-frame lighting" test "$correct_direct" = True -a "$correct_service" = True
expect "OLAT ks and ke within 15 % of the truth (measured: 3 % and 8 %)" \
  python3 -c "import sys; sys.exit(not ($ks_direct < 0.15 and $ke_direct < 0.15))"
grep -q '"chosenConfiguration": "per-frame lighting"' "$work/direct/result.json" &&
  { echo "ok   result.json names per-frame lighting"; passes=$((passes + 1)); } ||
  { echo "FAIL result.json's chosenConfiguration"; failures=$((failures + 1)); }

# Mixed: frame 0 (lit by C alone) without an entry, so a configuration is
# chosen; frames 1..8 keep their own lights, all outside C. A frame with its
# own lights is modelled with exactly those whatever configuration is under
# test (samples::LightSelection), the others with the configuration: the sweep
# chooses C and kd comes out as in the full OLAT run. Measured kd RMSE 0.0225
# (full OLAT 0.0225); when the own lights outside the configuration were
# dropped, frames 1..8 were modelled unlit, the sweep chose N,E,W,S,NE,NW,SE,SW
# and kd RMSE was 0.133 (0.044 with --config C).
cp -r "$work/olat" "$work/mixed"
python3 - "$work/mixed/scene.json" <<'EOF_PY'
import json, sys
scene = json.load(open(sys.argv[1]))
scene["frameLighting"] = scene["frameLighting"][1:]
json.dump(scene, open(sys.argv[1], "w"))
EOF_PY
check "mixed frame lighting: the sweep runs and chooses C" 0 "configuration: C (the next best" -- \
  "$bin" run --direct "$work/mixed/scene.json" --no-powell --atlas 256 --out "$work/mixed_direct"
check "mixed frame lighting through the service" 0 "configuration: C (the next best" -- \
  "$bin" run "$work/mixed/scene.json" --no-powell --atlas 256 --out "$work/mixed_service"
expect "mixed frame lighting: no warning about own lights" \
  python3 -c 'import json, sys
sys.exit(any("frame_lighting" in w for w in json.load(open(sys.argv[1])).get("warnings", [])))' "$work/mixed_direct/result.json"
read -r kd_mixed _ _ _ < <(errors "$work/mixed_direct" "$work/olat")
read -r kd_mixed_service _ _ _ < <(errors "$work/mixed_service" "$work/olat")
echo "     kd RMSE: mixed --direct $kd_mixed, mixed service $kd_mixed_service, full OLAT $kd_direct"
expect "mixed kd RMSE within 0.005 of the full OLAT run's" \
  python3 -c "import sys; sys.exit(not abs($kd_mixed - $kd_direct) <= 0.005)"
expect "mixed: the service path gives the same kd RMSE" \
  python3 -c "import sys; sys.exit(not abs($kd_mixed_service - $kd_mixed) <= 1e-6)"

# The resample evaluation renders the truth with each frame's own light
# (measured RMSE 0.0097 per camera; 0.20 with every light on).
check "resample against the truth" 0 "wrote" -- "$bin" resample "$olat" --atlas 256 --out "$work/resample"
expect "resample RMSE against the truth under each frame's own light < 0.03" python3 -c '
import json, sys
r = json.load(open(sys.argv[1]))
sys.exit(not all(c["rmse"] < 0.03 for c in r["cameras"]))' "$work/resample/resample.json"

# The report's input frame beside its reconstruction, lit by the frame's own light.
check "report of the per-frame lighting run" 0 "wrote" -- "$bin" report "$work/direct" --relit-frames 2 \
  --out "$work/report.html"

summary
