#!/usr/bin/env bash
# `mvbrdf import opencv|metashape` (issue #20 item 1): calibration files written
# by each format's own rules (tests/calibration_write.py) from a synthetic
# bundle's cameras are imported back; every camera must equal the bundle's
# (plus the distortion written into the files) to 1e-9, and the imported
# scene must validate. Bad inputs exit 3 naming the file and the key/element.
# Usage: cli_import_calibrations_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"
writer="$(dirname "$0")/calibration_write.py"

check "synth" 0 "ground truth" -- \
  "$bin" synth --preset sphere --cameras 3 --frames 2 --width 64 --height 48 --out "$work/b"
scene="$work/b/scene.json"
read -r first frames fps < <(python3 -c 'import json,sys; f=json.load(open(sys.argv[1]))["frames"]; print(f.get("first",0), f["count"], f["fps"])' "$scene")
cal="$work/b/calibration"
expect "write the calibration files" python3 "$writer" write "$scene" "$cal"

# import FORMAT INPUT OUT: the bundle's lights, mesh and videos with INPUT's cameras.
import_cal() {
  "$bin" import "$1" "$2" --lights "$scene" --mesh "$work/b/meshes/mesh_%04d.obj" --video "$work/b/videos/{camera}.mkv" \
    --first "$first" --frames "$frames" --fps "$fps" --out "$3" "${@:4}"
}
for input in "opencv $cal/opencv_yaml" "opencv $cal/opencv.json" "metashape $cal/metashape.xml"; do
  set -- $input
  out="$work/b/imported_$(basename "${2%.*}").json"
  check "import $1 $(basename "$2")" 0 "imported" -- import_cal "$1" "$2" "$out"
  check "$(basename "$2"): cameras equal the truth to 1e-9" 0 "max difference" -- \
    python3 "$writer" compare "$cal/expected.json" "$out" 1e-9
  python3 "$writer" compare "$cal/expected.json" "$out" 1e-9 | sed 's/^/     /'
  check "$(basename "$2"): imported scene validates" 0 "valid: " -- "$bin" validate --quick "$out"
done
# The reconstruction from the imported OpenCV and Metashape scenes equals the
# one from the bundle's own scene with the written cameras (expected.json, the
# bundle's cameras plus the injected distortion), to 1e-6 (tests/scene_compare.py).
python3 - "$scene" "$cal/expected.json" "$work/b/expected_scene.json" <<'PY'
import json, sys
scene = json.load(open(sys.argv[1]))
expected = {c["name"]: c for c in json.load(open(sys.argv[2]))["cameras"]}
for c in scene["cameras"]:
    c["intrinsics"] = expected[c["name"]]["intrinsics"]
    c["camFromWorld"] = expected[c["name"]]["camFromWorld"]
json.dump(scene, open(sys.argv[3], "w"), indent=1)
PY
fit=(--direct --atlas 64 --no-powell)
"$bin" run "$work/b/expected_scene.json" "${fit[@]}" --out "$work/run_expected" >/dev/null 2>&1
for imported in opencv_yaml metashape; do
  "$bin" run "$work/b/imported_$imported.json" "${fit[@]}" --out "$work/run_$imported" >/dev/null 2>&1
  check "$imported: the reconstruction equals the bundle's to 1e-6" 0 "max relative difference" -- \
    python3 "$(dirname "$0")/scene_compare.py" results "$work/run_$imported/result.json" "$work/run_expected/result.json"
done

check "--camera-name outside colmap is a usage error (it would change nothing)" 2 "--camera-name is for colmap only" -- \
  import_cal opencv "$cal/opencv.json" "$work/b/o.json" --camera-name dir
check "metashape: the unaligned camera is left out with a warning" 0 "camera\[label=not_aligned\]: no transform" -- \
  import_cal metashape "$cal/metashape.xml" "$work/b/imported_again.json"

# Bad inputs: exit 3, the file and the key or element named.
bad="$work/b/bad"
mkdir -p "$bad"
sed 's/^camera_matrix:/camera_mat:/' "$cal/opencv_yaml/cam0.yml" > "$bad/no_k.yml"
check "missing camera_matrix" 3 "no_k.yml: camera_matrix: missing" -- import_cal opencv "$bad/no_k.yml" "$bad/o.json"
sed '0,/rows: 3/s//rows: 1/; 0,/cols: 3/s//cols: 9/' "$cal/opencv_yaml/cam0.yml" > "$bad/k_size.yml"
check "wrong matrix size" 3 "k_size.yml: camera_matrix: must be 3x3, got 1x9" -- \
  import_cal opencv "$bad/k_size.yml" "$bad/o.json"
sed 's/<document version="1.5.0">/<opencv_storage>/; s#</document>#</opencv_storage>#' "$cal/metashape.xml" > "$bad/root.xml"
check "unknown XML root" 3 "root.xml: <opencv_storage>: unknown root element" -- \
  import_cal metashape "$bad/root.xml" "$bad/o.json"
sed 's/sensor_id="1" label="cam1"/sensor_id="9" label="cam1"/' "$cal/metashape.xml" > "$bad/sensor.xml"
check "unknown sensor_id" 3 "sensor.xml: chunk/cameras/camera\[label=cam1\]: sensor_id \"9\" names no sensor" -- \
  import_cal metashape "$bad/sensor.xml" "$bad/o.json"
expect "nothing written for bad inputs" test ! -e "$bad/o.json"

summary
