#!/usr/bin/env bash
# `mvbrdf import colmap`: a COLMAP model written by COLMAP's documented layout
# (tests/colmap_write.py, text and binary) of a synthetic bundle's cameras
# gives back the bundle's cameras to 1e-9, and a run on the imported scene the
# bundle's own run to 1e-6; the options; bad inputs exit 3 naming file, line
# or field; the shipped example (docs/examples/colmap/README.md) runs as written.
# Usage: cli_import_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$work"
mkdir -p "$work"
source "$here/lib.sh"
writer="$here/colmap_write.py"

"$bin" synth --cameras 4 --frames 3 --width 160 --height 120 --actor-segments 12 --out "$work/b" >/dev/null || exit 1
scene="$work/b/scene.json"
python3 "$writer" "$scene" "$work/txt" || exit 1
python3 "$writer" "$scene" "$work/bin" --binary || exit 1
common=(--mesh "$work/b/meshes/mesh_%04d.obj" --video "$work/b/videos/{camera}.mkv" --frames 3 --fps 15)

# same_cameras [--geometry] A B [NAMES], same_results A B: tests/scene_compare.py.
same_cameras() { python3 "$here/scene_compare.py" cameras "$@"; }
same_results() { python3 "$here/scene_compare.py" results "$@"; }

check "import help states the half-pixel shift" 0 "cx = cx_colmap - 0.5" -- "$bin" import --help
check "import a COLMAP text model" 0 "imported 4 of 4 cameras" -- \
  "$bin" import colmap "$work/txt" "${common[@]}" --lights "$scene" --out "$work/b/text.json"
check "import a COLMAP binary model" 0 "imported 4 of 4 cameras" -- \
  "$bin" import colmap "$work/bin" "${common[@]}" --lights "$scene" --out "$work/b/binary.json"
check "text import: the bundle's cameras to 1e-9" 0 "max camera difference" -- same_cameras "$work/b/text.json" "$scene"
check "binary import: the bundle's cameras to 1e-9" 0 "max camera difference" -- \
  same_cameras "$work/b/binary.json" "$scene"
check "the imported scene validates (every frame, every video)" 0 "valid:" -- "$bin" validate "$work/b/binary.json"

# The reconstruction from the imported scene is the bundle's (same options).
run_opts=(--no-powell --atlas 128 --direct)
"$bin" run "$scene" "${run_opts[@]}" --out "$work/run_bundle" >/dev/null 2>&1 || echo "FAIL run on the bundle"
"$bin" run "$work/b/text.json" "${run_opts[@]}" --out "$work/run_text" >/dev/null 2>&1 || echo "FAIL run on the import"
check "run on the text import: result.json equal to 1e-6" 0 "max relative difference" -- \
  same_results "$work/run_text/result.json" "$work/run_bundle/result.json"
"$bin" evaluate "$work/run_bundle" --truth "$work/b" > "$work/eval_bundle.json" 2>/dev/null
"$bin" evaluate "$work/run_text" --truth "$work/b" > "$work/eval_text.json" 2>/dev/null
check "evaluate (kd rmse, clusters vs truth) equal to 1e-6" 0 "max relative difference" -- \
  same_results "$work/eval_text.json" "$work/eval_bundle.json"

# Distortion: synth's radial k1 becomes an OPENCV camera (k1 k2 p1 p2), text and binary.
"$bin" synth --cameras 2 --frames 1 --width 64 --height 48 --actor-segments 6 --distortion -0.1 --out "$work/d" \
  >/dev/null || exit 1
python3 "$writer" "$work/d/scene.json" "$work/d_txt" || exit 1
python3 "$writer" "$work/d/scene.json" "$work/d_bin" --binary || exit 1
expect "the distorted cameras are written as OPENCV" grep -q '^1 OPENCV 64 48 ' "$work/d_txt/cameras.txt"
for m in txt bin; do
  check "distortion ($m): imported" 0 "imported 2 of 2" -- "$bin" import colmap "$work/d_$m" \
    --mesh "$work/d/meshes/mesh_%04d.obj" --video "$work/d/videos/{camera}.mkv" --frames 1 --fps 15 \
    --lights "$work/d/scene.json" --out "$work/d/$m.json"
  check "distortion ($m): the bundle's cameras to 1e-9" 0 "max camera difference" -- \
    same_cameras "$work/d/$m.json" "$work/d/scene.json"
done

# --transform: a model written in another world (scale 2, a rotation, a
# shift) imports with the same world_from_calibration into the bundle's cameras.
echo '[0, -2, 0, 0.5,  2, 0, 0, -1.0,  0, 0, 2, 0.25,  0, 0, 0, 1]' > "$work/transform.json"
python3 "$writer" "$scene" "$work/moved" --transform "$work/transform.json" || exit 1
check "import with --transform" 0 "imported" -- \
  "$bin" import colmap "$work/moved" "${common[@]}" --lights "$scene" --transform "$work/transform.json" \
  --out "$work/b/moved.json"
check "--transform round trip: the bundle's cameras" 0 "max camera difference" -- \
  same_cameras "$work/b/moved.json" "$scene"
"$bin" import colmap "$work/moved" "${common[@]}" --out "$work/b/unmoved.json" >/dev/null 2>&1
check "without --transform the cameras are the calibration's, not the bundle's" 1 "max camera difference" -- \
  same_cameras "$work/b/unmoved.json" "$scene"

# --cameras, --video, --lights, --encoding, --bit-depth.
check "--cameras subset" 0 "imported 2 of 4 cameras" -- \
  "$bin" import colmap "$work/txt" "${common[@]}" --lights "$scene" --cameras cam3,cam1 --out "$work/b/subset.json"
check "--cameras keeps the calibration's order" 0 "max camera difference" -- \
  same_cameras "$work/b/subset.json" "$scene" cam1,cam3
check "--cameras: an unknown name lists the valid ones" 3 'no camera "cam9" (it has cam0, cam1, cam2, cam3)' -- \
  "$bin" import colmap "$work/txt" "${common[@]}" --cameras cam9 --out "$work/x.json"
check "--video without {camera} for 4 cameras" 3 'must contain {camera}' -- \
  "$bin" import colmap "$work/txt" --mesh "$work/b/meshes/mesh_%04d.obj" --video "$work/b/videos/cam0.mkv" \
  --frames 3 --fps 15 --out "$work/x.json"
cat > "$work/lights.json" <<'JSON'
{"lights": [{"name": "key", "position": [2.0, 3.0, 2.0], "intensity": [1.0, 0.9, 0.8]}]}
JSON
check "--lights from a LightList, --encoding linear --bit-depth 16" 0 "imported" -- \
  "$bin" import colmap "$work/txt" "${common[@]}" --lights "$work/lights.json" --encoding linear --bit-depth 16 \
  --out "$work/b/lightlist.json"
expect "the LightList's light, linear 16-bit videos" python3 -c '
import json, sys
s = json.load(open(sys.argv[1]))
assert [l["name"] for l in s["lights"]] == ["key"] and "lightConfigurations" not in s, s.get("lights")
assert all(c["video"]["encoding"] == "LINEAR" and c["video"]["bitDepth"] == 16 for c in s["cameras"])' \
  "$work/b/lightlist.json"
expect "--lights from a scene copies lights, configurations, seeds, segments" python3 -c '
import json, sys
a, b = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
for k in ("lights", "lightConfigurations", "materialSeeds", "segmentMaterials", "segmentationPath"):
    assert a[k] == b[k], k' "$work/b/text.json" "$scene"
check "no --lights: written with a warning" 0 "warning: scene.lights: none" -- \
  "$bin" import colmap "$work/txt" "${common[@]}" --out "$work/b/unlit.json"
check "a scene without lights does not validate" 3 "scene.lights" -- "$bin" validate "$work/b/unlit.json"

# Paths relative to --out's directory, whatever the working directory.
mkdir -p "$work/elsewhere"
check "--out in another directory, relative flags" 0 "imported" -- bash -c "cd '$work/elsewhere' && '$bin' import \
  colmap ../txt --mesh ../b/meshes/mesh_%04d.obj --video '../b/videos/{camera}.mkv' --frames 3 --fps 15 \
  --lights ../b/scene.json --out ../top.json"
expect "paths in the scene are relative to it" python3 -c '
import json, sys
s = json.load(open(sys.argv[1]))
assert s["mesh"]["path"] == "b/meshes/mesh_%04d.obj", s["mesh"]
assert s["cameras"][2]["video"]["path"] == "b/videos/cam2.mkv"
assert s["segmentationPath"] == "b/segments.txt", s["segmentationPath"]' "$work/top.json"
check "the scene one directory up validates" 0 "valid:" -- "$bin" validate "$work/top.json"
check "a mesh outside the scene's directory is refused" 3 "scene.mesh.path" -- \
  "$bin" import colmap "$work/txt" "${common[@]}" --out "$work/deeper/scene.json"

# Bad inputs: exit 3, naming file, line or field.
mkdir -p "$work/fisheye" && cp "$work/txt/images.txt" "$work/fisheye/"
sed 's/^2 PINHOLE 160 120 \([^ ]*\) \([^ ]*\)/2 OPENCV_FISHEYE 160 120 \1 \2 0 0 0 0/' "$work/txt/cameras.txt" \
  > "$work/fisheye/cameras.txt"
check "unknown camera model names file, line and model" 3 'fisheye/cameras.txt:5: unsupported camera model "OPENCV_FISHEYE"' -- \
  "$bin" import colmap "$work/fisheye" "${common[@]}" --out "$work/x.json"
mkdir -p "$work/zero" && cp "$work/txt/images.txt" "$work/zero/"
sed 's/^1 PINHOLE 160 120 [^ ]*/1 PINHOLE 160 120 0/' "$work/txt/cameras.txt" > "$work/zero/cameras.txt"
check "the scene's validation names the field" 3 'scene.cameras\[0\].intrinsics.fx: must be > 0' -- \
  "$bin" import colmap "$work/zero" "${common[@]}" --out "$work/x.json"
check "a mesh that is not there: written, but exit 3" 3 'wrote .*nomesh.json, but it does not load: .*nomesh.obj' -- \
  "$bin" import colmap "$work/txt" --mesh "$work/b/nomesh.obj" --video "$work/b/videos/{camera}.mkv" --frames 3 \
  --fps 15 --lights "$scene" --out "$work/b/nomesh.json"
mkdir -p "$work/trunc" && cp "$work/bin/cameras.bin" "$work/trunc/"
head -c -30 "$work/bin/images.bin" > "$work/trunc/images.bin"
check "truncated images.bin" 3 'trunc/images.bin: truncated: ends at byte' -- \
  "$bin" import colmap "$work/trunc" "${common[@]}" --out "$work/x.json"
mkdir -p "$work/noimages" && cp "$work/txt/cameras.txt" "$work/noimages/"
check "missing images.txt" 3 'noimages/images.txt' -- "$bin" import colmap "$work/noimages" "${common[@]}" --out "$work/x.json"
mkdir -p "$work/both" && cp "$work/txt/"*.txt "$work/bin/"*.bin "$work/both/"
check "text and binary model together" 3 'holds both a text' -- "$bin" import colmap "$work/both" "${common[@]}" --out "$work/x.json"
check "no model" 3 'no COLMAP model' -- "$bin" import colmap "$work/elsewhere" "${common[@]}" --out "$work/x.json"
python3 "$writer" "$scene" "$work/dirs" --image-name dir || exit 1
check "duplicate camera names name both images" 3 'image "cam1/0000.png" and image "cam0/0000.png".*both make camera "0000"' -- \
  "$bin" import colmap "$work/dirs" "${common[@]}" --camera-name stem --out "$work/x.json"
check "--camera-name dir" 0 "imported 4 of 4" -- \
  "$bin" import colmap "$work/dirs" "${common[@]}" --camera-name dir --lights "$scene" --out "$work/b/dirs.json"
check "--camera-name dir: the bundle's cameras" 0 "max camera difference" -- same_cameras "$work/b/dirs.json" "$scene"
echo '[1, 0.2, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]' > "$work/shear.json"
check "--transform: a shear is not a similarity" 3 'shear.json: not a similarity' -- \
  "$bin" import colmap "$work/txt" "${common[@]}" --transform "$work/shear.json" --out "$work/x.json"
echo '[1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0]' > "$work/short.json"
check "--transform: 15 numbers" 3 'expected 16 numbers (a 4x4 row-major world_from_calibration), got 15' -- \
  "$bin" import colmap "$work/txt" "${common[@]}" --transform "$work/short.json" --out "$work/x.json"
check "unknown format" 2 'unknown FORMAT "bundler"' -- "$bin" import bundler "$work/txt" "${common[@]}" --out "$work/x.json"
check "--video is required" 2 '--video is required' -- \
  "$bin" import colmap "$work/txt" --mesh "$work/b/meshes/mesh_%04d.obj" --frames 3 --fps 15 --out "$work/x.json"
check "--first, --frames, --name" 0 "imported" -- "$bin" import colmap "$work/txt" --mesh "$work/b/meshes/mesh_%04d.obj" \
  --video "$work/b/videos/{camera}.mkv" --first 1 --frames 2 --fps 30 --name "imported studio" --lights "$scene" \
  --out "$work/b/later.json"
expect "frames 1 and 2 at 30 fps, the scene's name" python3 -c '
import json, sys
s = json.load(open(sys.argv[1]))
assert s["frames"] == {"first": 1, "count": 2, "fps": 30} and s["name"] == "imported studio", (s["frames"], s.get("name"))' \
  "$work/b/later.json"
check "--first 1 --frames 2 validates (frames 1, 2 of the videos and meshes)" 0 "valid:" -- \
  "$bin" validate "$work/b/later.json"
check "--mesh is required" 2 '--mesh is required' -- "$bin" import colmap "$work/txt" --frames 3 --fps 15 --out "$work/x.json"

# The shipped example: the commands of docs/examples/colmap/README.md's sh
# block, exactly as written (mvbrdf this binary, EXAMPLE the folder), in an
# empty directory; then its cameras are synth's to 1e-9.
example="$here/../docs/examples/colmap"
mkdir -p "$work/example"
python3 - "$example/README.md" > "$work/example/commands.sh" <<'EOF_PY'
import re, sys
block = re.search(r"```sh\n(.*?)```", open(sys.argv[1]).read(), re.S).group(1)
for line in block.replace("\\\n", " ").splitlines():
    if line.startswith("EXAMPLE="):
        continue  # set by the test
    print(line)
EOF_PY
check "the example's README commands run" 0 '"configurationCorrect": true' -- bash -c "cd '$work/example' && \
  mvbrdf() { '$bin' \"\$@\"; } && EXAMPLE='$example' && set -e && source ./commands.sh"
expect "the example runs synth, import, validate, run and evaluate" \
  test "$(grep -c '^mvbrdf \(synth\|import\|validate\|run\|evaluate\) ' "$work/example/commands.sh")" -eq 5
check "the example's cameras are synth's to 1e-9" 0 "max camera difference" -- \
  same_cameras --geometry "$work/example/scene.json" "$work/example/capture/scene.json"

summary
