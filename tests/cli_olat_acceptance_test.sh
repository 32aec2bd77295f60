#!/usr/bin/env bash
# Issue #13 acceptance, against the truth: synthetic one-light-at-a-time
# captures of a static sphere of one material under a dome of directional
# lights (one light per frame), as photometric stages record them:
#   - one orthographic camera, 96 lights;
#   - eight pinhole cameras, 48 lights.
# kd RMSE <= 0.01 over texels seen >= 10 times, ks and ke within 5 % of the
# truth, one cluster (a one-material object).
# Usage: cli_olat_acceptance_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

# errors RUN TRUTH: "kd_rmse max_ks_rel_error max_ke_rel_error clusters"
errors() {
  "$bin" evaluate "$1" --truth "$2" | python3 -c '
import json, sys
d = json.load(sys.stdin)
for c in d["clusters"]:
    print("  %-8s ks rel error %.4f, ke rel error %.4f, kd RMSE %.4f" % (c["cluster"], c["ksRelError"], c["keRelError"], c["kdRmse"]), file=sys.stderr)
print(d["kdRmse"], max(c["ksRelError"] for c in d["clusters"]), max(c["keRelError"] for c in d["clusters"]), len(d["clusters"]))'
}

acceptance() {  # NAME SYNTH_FLAGS...
  local name=$1
  shift
  check "$name: synth" 0 "wrote" -- "$bin" synth --preset sphere --lighting olat "$@" --out "$work/$name"
  check "$name: validate" 0 "Frame lighting" -- "$bin" validate "$work/$name/scene.json"
  check "$name: run" 0 "skip  light_sweep: lighting is given per frame" -- \
    "$bin" run "$work/$name/scene.json" --no-powell --atlas 256 --out "$work/$name/run"
  read -r kd ks ke k < <(errors "$work/$name/run" "$work/$name")
  echo "     $name: kd RMSE $kd, ks rel error $ks, ke rel error $ke, $k cluster(s)"
  expect "$name: kd RMSE <= 0.01" python3 -c "import sys; sys.exit(not $kd <= 0.01)"
  expect "$name: ks within 5 %" python3 -c "import sys; sys.exit(not $ks <= 0.05)"
  expect "$name: ke within 5 %" python3 -c "import sys; sys.exit(not $ke <= 0.05)"
  expect "$name: one cluster on a one-material object" test "$k" = 1
}

acceptance ortho96 --camera-model orthographic --cameras 1 --dome 96 --frames 96 --width 256 --height 256
acceptance pinhole48 --camera-model pinhole --cameras 8 --dome 48 --frames 48 --width 200 --height 150

summary
