#!/usr/bin/env bash
# Issue #13 items 5, 6 and 9: what a real capture brings, tested against the
# truth of small synthetic scenes: validation catches what a run would refuse
# or get wrong (lights, an inside-out mesh, frames.step / indices, symlinks),
# invalid pixels (mask, saturation) never become Samples, and the resampling's
# job options (depth tolerance, grazing margin) change the output.
# Usage: cli_capture_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"

small=(--cameras 4 --width 160 --height 120 --actor-segments 12)
fit=(--config NE,NW,SE,SW --no-powell --atlas 128 --no-render --outputs brdf)
"$bin" synth "${small[@]}" --frames 4 --out "$work/s" >/dev/null || exit 1

# edit SCENE_IN SCENE_OUT PYTHON: writes SCENE_OUT, scene.json with `d` changed by PYTHON.
edit() {
  python3 -c 'import json, sys
d = json.load(open(sys.argv[1]))
exec(sys.argv[3])
json.dump(d, open(sys.argv[2], "w"), indent=1)' "$1" "$2" "$3"
}
# json FILE EXPR: prints EXPR of the JSON document `d` in FILE.
json() { python3 -c 'import json, sys; d = json.load(open(sys.argv[1])); print(eval(sys.argv[2]))' "$1" "$2"; }
# kd_rmse RUN TRUTH_DIR
kd_rmse() { "$bin" evaluate "$1" --truth "$2" | python3 -c 'import json, sys; print(json.load(sys.stdin)["kdRmse"])'; }
# close A B TOLERANCE: |A - B| <= TOLERANCE
close() { python3 -c 'import sys; a, b, t = map(float, sys.argv[1:]); sys.exit(0 if abs(a - b) <= t else 1)' "$@"; }
less() { python3 -c 'import sys; a, b = map(float, sys.argv[1:]); sys.exit(0 if a < b else 1)' "$@"; }

# --- Lights: the run's limit and directions near unit length.
edit "$work/s/scene.json" "$work/s/many_lights.json" '
for i in range(1030): d["lights"].append(dict(d["lights"][0], name="extra%d" % i))'
check "validate refuses more lights than a run takes, as the run would" 3 "scene.lights: at most 1024 lights" -- \
  "$bin" validate "$work/s/many_lights.json"
edit "$work/s/scene.json" "$work/s/directional.json" '
for l in d["lights"]: l.pop("position", None); l["direction"] = [0.0, 1.0 + 6e-5, 0.0]'
check "validate renormalises a direction off unit length by 6e-5, with a note" 0 \
  "note: scene.lights\[0\].direction has length 1.00006, renormalised to unit length" -- \
  "$bin" validate "$work/s/directional.json"
check "run warns that it renormalised the direction" 0 "warning: scene.lights\[0\].direction has length 1.00006: renormalised" -- \
  "$bin" run --direct "$work/s/directional.json" "${fit[@]}" --out "$work/r_directional"
edit "$work/s/scene.json" "$work/s/far_direction.json" '
for l in d["lights"]: l.pop("position", None); l["direction"] = [0.0, 1.01, 0.0]'
check "validate refuses a direction 1e-2 off unit length" 3 \
  "scene.lights\[0\].direction: must have unit length (within 0.001" -- "$bin" validate "$work/s/far_direction.json"

# --- A mesh whose triangles face inwards.
"$bin" run --direct "$work/s/scene.json" "${fit[@]}" --out "$work/r_base" >/dev/null 2>&1 || exit 1
cp -r "$work/s" "$work/inward"
for f in "$work"/inward/meshes/*.obj; do awk '$1 == "f" { print $1, $2, $4, $3; next } { print }' "$f" > "$f.t" && mv "$f.t" "$f"; done
check "validate refuses an inside-out mesh, naming mesh.flipWinding" 3 \
  "triangles face inwards .*set scene.mesh.flipWinding to true" -- "$bin" validate "$work/inward/scene.json"
check "run refuses it too (it fitted the initial guess, exit 0)" 3 "triangles face inwards" -- \
  "$bin" run --direct "$work/inward/scene.json" "${fit[@]}" --out "$work/r_inward"
edit "$work/inward/scene.json" "$work/inward/scene.json" 'd["mesh"]["flipWinding"] = True'
check "with flipWinding the inside-out mesh runs" 0 "wrote" -- \
  "$bin" run --direct "$work/inward/scene.json" "${fit[@]}" --out "$work/r_flipped"
kd_base=$(kd_rmse "$work/r_base" "$work/s")
kd_flipped=$(kd_rmse "$work/r_flipped" "$work/inward")
echo "     kd RMSE: original $kd_base, inside-out mesh with flipWinding $kd_flipped"
expect "flipWinding recovers kd like the original mesh" close "$kd_base" "$kd_flipped" 1e-4

# --- Job options of the resampling (run goes through the service and a worker).
seen() { json "$1/result.json" 'd["texelsSeen"]'; }
"$bin" run "$work/s/scene.json" "${fit[@]}" --out "$work/o_default" >/dev/null 2>&1 || exit 1
check "run --grazing-margin 80" 0 "wrote" -- \
  "$bin" run "$work/s/scene.json" "${fit[@]}" --grazing-margin 80 --out "$work/o_grazing"
check "run --depth-tolerance-absolute 100 (bigger than the object)" 0 "wrote" -- \
  "$bin" run "$work/s/scene.json" "${fit[@]}" --depth-tolerance-absolute 100 --out "$work/o_absolute"
echo "     texels seen: default $(seen "$work/o_default"), grazing margin 80 $(seen "$work/o_grazing"), absolute tolerance 100 $(seen "$work/o_absolute")"
expect "a huge grazing margin leaves fewer texels seen" less "$(seen "$work/o_grazing")" "$(seen "$work/o_default")"
expect "an absolute tolerance bigger than the object makes hidden texels seen" \
  less "$(seen "$work/o_default")" "$(seen "$work/o_absolute")"
# The relative tolerance through the job: 1 (hidden only when twice as far as
# the depth map) lets hidden texels through as well.
"$bin" run "$work/s/scene.json" "${fit[@]}" --depth-tolerance-relative 1 --out "$work/o_relative" >/dev/null 2>&1
echo "     texels seen: default $(seen "$work/o_default"), relative tolerance 1: $(seen "$work/o_relative")"
expect "run --depth-tolerance-relative 1 makes hidden texels seen" \
  less "$(seen "$work/o_default")" "$(seen "$work/o_relative")"
# Against the resample evaluator's truth: the texels marked valid though hidden.
"$bin" resample "$work/s/scene.json" --atlas 128 --save none --out "$work/rs_default" >/dev/null 2>&1
# (The depth map's tolerance alone: the exact occluder test, below, refuses
# hidden texels at any tolerance.)
"$bin" resample "$work/s/scene.json" --atlas 128 --save none --depth-tolerance-absolute 100 --no-exact-occluders \
  --out "$work/rs_absolute" >/dev/null 2>&1
false_valid() { json "$1/resample.json" 'max(c["falseValidFraction"] for c in d["cameras"])'; }
echo "     worst false-valid fraction: default $(false_valid "$work/rs_default"), absolute 100 $(false_valid "$work/rs_absolute")"
expect "resample --depth-tolerance-absolute 100 --no-exact-occluders marks truly hidden texels valid" \
  less "$(python3 -c "print(5 * $(false_valid "$work/rs_default"))")" "$(false_valid "$work/rs_absolute")"
# The exact occluder test (core/resample/resampler.h): without it, texels just
# inside another part of the actor (its ellipsoids overlap at the joints) pass
# the depth map within the tolerance (measured: worst false-valid fraction
# 0.0099 with it, 0.035 without).
"$bin" resample "$work/s/scene.json" --atlas 128 --save none --no-exact-occluders --out "$work/rs_depth_map" >/dev/null 2>&1
echo "     worst false-valid fraction: default $(false_valid "$work/rs_default"), --no-exact-occluders $(false_valid "$work/rs_depth_map")"
expect "resample --no-exact-occluders marks more hidden texels valid" \
  less "$(python3 -c "print(2 * $(false_valid "$work/rs_default"))")" "$(false_valid "$work/rs_depth_map")"
check "both tolerances at once: a usage error" 2 "give at most one" -- \
  "$bin" run "$work/s/scene.json" --depth-tolerance-absolute 1 --depth-tolerance-relative 0.01 --out "$work/x"
check "submit: a negative absolute tolerance is a usage error" 2 \
  "--depth-tolerance-absolute: must be a finite number >= 0 (world units)" -- \
  "$bin" submit "$work/s/scene.json" --server 127.0.0.1:1 --depth-tolerance-absolute -1
check "submit: --grazing-margin 90 is a usage error" 2 "--grazing-margin: must be in \[0, 90) degrees, got 90" -- \
  "$bin" submit "$work/s/scene.json" --server 127.0.0.1:1 --grazing-margin 90
check "run --help names the resampling options" 0 "--depth-tolerance-absolute" -- "$bin" run --help
check "submit --help names the resampling options" 0 "--grazing-margin" -- "$bin" submit --help

# --- Frames selected by frames.step and frames.indices: synth 8 frames, use
# every other one, and get the same result as a scene of those 4 frames.
"$bin" synth "${small[@]}" --frames 8 --format png --out "$work/p8" >/dev/null || exit 1
"$bin" synth "${small[@]}" --frames 8 --out "$work/v8" >/dev/null || exit 1
python3 - "$work/p8" "$work/p4" <<'PY'
import json, os, shutil, sys
src, dst = sys.argv[1:]
shutil.copytree(src, dst, ignore=shutil.ignore_patterns("*.png", "mesh_*.obj"))
for t in range(4):
    for c in range(4):
        shutil.copy("%s/videos/cam%d/%04d.png" % (src, c, 2 * t), "%s/videos/cam%d/%04d.png" % (dst, c, t))
    shutil.copy("%s/meshes/mesh_%04d.obj" % (src, 2 * t), "%s/meshes/mesh_%04d.obj" % (dst, t))
d = json.load(open(dst + "/scene.json")); d["frames"]["count"] = 4; json.dump(d, open(dst + "/scene.json", "w"))
PY
edit "$work/p8/scene.json" "$work/p8/step2.json" 'd["frames"].update(count=4, step=2)'
edit "$work/p8/scene.json" "$work/p8/indices.json" 'd["frames"].update(count=0, indices=[0, 2, 4, 6])'
edit "$work/v8/scene.json" "$work/v8/step2.json" 'd["frames"].update(count=4, step=2)'
check "validate: frames.step 2" 0 "Frames: 4 from frame 0 .*file frames first + t \* 2 up to frame 6" -- \
  "$bin" validate "$work/p8/step2.json"
"$bin" run --direct "$work/p4/scene.json" "${fit[@]}" --out "$work/f_p4" >/dev/null 2>&1
"$bin" run --direct "$work/p8/step2.json" "${fit[@]}" --out "$work/f_step" >/dev/null 2>&1
"$bin" run --direct "$work/p8/indices.json" "${fit[@]}" --out "$work/f_indices" >/dev/null 2>&1
"$bin" run "$work/v8/step2.json" "${fit[@]}" --out "$work/f_video" >/dev/null 2>&1
"$bin" run --direct "$work/p8/scene.json" "${fit[@]}" --out "$work/f_all" >/dev/null 2>&1
kd_p4=$(kd_rmse "$work/f_p4" "$work/p8")
kd_step=$(kd_rmse "$work/f_step" "$work/p8")
kd_indices=$(kd_rmse "$work/f_indices" "$work/p8")
kd_video=$(kd_rmse "$work/f_video" "$work/p8")
kd_all=$(kd_rmse "$work/f_all" "$work/p8")
echo "     kd RMSE: 4 copied frames $kd_p4, step 2 $kd_step, indices $kd_indices, step 2 on video through the service $kd_video, all 8 $kd_all"
expect "frames.step 2 gives the result of the 4 frames it selects" test "$kd_step" = "$kd_p4"
expect "frames.indices [0, 2, 4, 6] likewise" test "$kd_indices" = "$kd_p4"
expect "a video skips to the selected frames (run through the service, packed bundle)" test "$kd_video" = "$kd_p4"
expect "and that differs from all 8 frames" test "$kd_all" != "$kd_p4"
# Decision: a frame_lighting entry for a frame the selection skips is ignored, with a note.
edit "$work/p8/step2.json" "$work/p8/step2_lit.json" '
d["frameLighting"] = [dict(frame=t, lights=["C"]) for t in range(8)]'
check "frame_lighting entries of skipped frames are ignored, with a note" 0 \
  "note: 4 scene.frame_lighting entries are for frames the selection skips: ignored" -- \
  "$bin" validate "$work/p8/step2_lit.json"
check "... and the selected ones are every frame's lights" 0 "Frame lighting: 4 frames with their own lights (every frame" -- \
  "$bin" validate "$work/p8/step2_lit.json"
edit "$work/p8/scene.json" "$work/p8/step_too_far.json" 'd["frames"].update(count=5, step=2)'
check "a step past the last file is refused as a run would" 3 "scene.mesh.path (frame 8): mesh file not found" -- \
  "$bin" validate "$work/p8/step_too_far.json"

# --- Saturation: --exposure 4 clips highlights at code 255. The default
# saturation level (255 for 8-bit) refuses them; 256 (none saturated) fits
# them as valid, as before.
"$bin" synth "${small[@]}" --frames 6 --exposure 4 --out "$work/e4" >/dev/null || exit 1
edit "$work/e4/scene.json" "$work/e4/nosat.json" '
for c in d["cameras"]: c["video"]["saturationLevel"] = 256'
check "run with the default saturation level counts saturated observations" 0 \
  "refused texel observations: 0 outside a camera's mask, [1-9][0-9]* saturated" -- \
  "$bin" run --direct "$work/e4/scene.json" "${fit[@]}" --outputs brdf,errors --report --out "$work/sat"
"$bin" run --direct "$work/e4/nosat.json" "${fit[@]}" --out "$work/nosat" >/dev/null 2>&1
saturated=$(json "$work/sat/result.json" 'int(d["saturatedObservations"])')
per_camera=$(json "$work/sat/result.json" 'sum(int(c.get("saturatedObservations", 0)) for c in d["cameras"])')
echo "     saturated observations: $saturated (cameras sum to $per_camera)"
expect "saturated observations > 0, per camera summing to the total" test "$saturated" -gt 0 -a "$per_camera" = "$saturated"
expect "the report says it" grep -q "Refused texel observations</abbr>: 0 outside a camera's mask, $saturated saturated" "$work/sat/report.html"
# worst ke relative error (ke does not scale with exposure).
ke_error() { "$bin" evaluate "$1" --truth "$work/e4" | python3 -c 'import json, sys; print(max(c["keRelError"] for c in json.load(sys.stdin)["clusters"]))'; }
ke_sat=$(ke_error "$work/sat")
ke_nosat=$(ke_error "$work/nosat")
echo "     worst ke relative error: saturated pixels refused $ke_sat, fitted as valid $ke_nosat"
# Measured after the scale-free fits (#13 item 4): at --exposure 4 the red
# channel clips over much of the diffuse too, so refusing saturated pixels
# leaves cloth's red lobe without data: its fit ends on the ke bound and says
# so (at_bound) instead of fitting clipped values (ke error 833 vs 53 in red;
# green/blue within 3-20 % either way). What must hold: the refusal changes
# the fit, and a fit it starves is flagged, never printed as a result.
expect "refusing saturated pixels changes the fit" python3 -c "import sys; sys.exit(not abs($ke_sat - $ke_nosat) > 1e-6)"
expect "a cluster fit starved by the refusal is flagged, with a warning" \
  python3 -c 'import json, sys; d = json.load(open(sys.argv[1]))
sys.exit(not (any(c.get("flags") for c in d["clusters"]) and d.get("warnings")))' "$work/sat/result.json"

# --- Masks: cam0 masked entirely gives no Samples from cam0; half of every
# camera's image masked (a per-frame pattern) gives fewer, and counts them.
python3 - "$work/s" <<'PY'
import os, struct, sys, zlib
def png(path, w, h, value):
    raw = b"".join(b"\0" + bytes(value(x, y) for x in range(w)) for y in range(h))
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    open(path, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
d = sys.argv[1]
os.makedirs(d + "/masks", exist_ok=True)
png(d + "/masks/none.png", 160, 120, lambda x, y: 0)
for t in range(4):
    png(d + "/masks/left_%04d.png" % t, 160, 120, lambda x, y: 0 if x < 80 else 255)
PY
edit "$work/s/scene.json" "$work/s/mask_cam0.json" 'd["cameras"][0]["video"]["maskPath"] = "masks/none.png"'
edit "$work/s/scene.json" "$work/s/mask_left.json" '
for c in d["cameras"]: c["video"]["maskPath"] = "masks/left_%04d.png"'
check "validate names the mask" 0 "mask masks/none.png" -- "$bin" validate "$work/s/mask_cam0.json"
"$bin" run --direct "$work/s/scene.json" "${fit[@]}" --outputs brdf,errors --out "$work/m_none" >/dev/null 2>&1
check "run: cam0 masked entirely (through the service: the mask is packed)" 0 "[1-9][0-9]* outside a camera's mask" -- \
  "$bin" run "$work/s/mask_cam0.json" "${fit[@]}" --outputs brdf,errors --out "$work/m_cam0"
"$bin" run --direct "$work/s/mask_left.json" "${fit[@]}" --outputs brdf,errors --out "$work/m_left" >/dev/null 2>&1
cam() { json "$1/result.json" "int([c for c in d['cameras'] if c['name'] == '$2'][0].get('$3', 0))"; }
echo "     cam0 samples: no mask $(cam "$work/m_none" cam0 samples), masked $(cam "$work/m_cam0" cam0 samples) ($(cam "$work/m_cam0" cam0 maskedObservations) refused); left half masked $(cam "$work/m_left" cam0 samples) ($(cam "$work/m_left" cam0 maskedObservations) refused)"
expect "cam0 masked entirely: no Sample from cam0" test "$(cam "$work/m_cam0" cam0 samples)" = 0
expect "... every observation it had is counted as masked" \
  test "$(cam "$work/m_cam0" cam0 maskedObservations)" -ge "$(cam "$work/m_none" cam0 samples)"
expect "... and nothing of the other cameras" test "$(cam "$work/m_cam0" cam1 maskedObservations)" = 0 -a \
  "$(cam "$work/m_cam0" cam1 samples)" -gt 0
expect "left half masked: fewer Samples, the refused ones counted" \
  test "$(cam "$work/m_left" cam0 samples)" -lt "$(cam "$work/m_none" cam0 samples)" -a "$(cam "$work/m_left" cam0 maskedObservations)" -gt 0
expect "... refused + kept covers what the unmasked run had" test $(( $(cam "$work/m_left" cam0 samples) + $(cam "$work/m_left" cam0 maskedObservations) )) -ge "$(cam "$work/m_none" cam0 samples)"
edit "$work/s/scene.json" "$work/s/mask_missing.json" 'd["cameras"][1]["video"]["maskPath"] = "masks/nowhere.png"'
check "a missing mask is refused naming the field" 3 "scene.cameras\[1\].video.mask_path" -- \
  "$bin" validate "$work/s/mask_missing.json"
edit "$work/s/scene.json" "$work/s/sat_zero.json" 'd["cameras"][1]["video"]["saturationLevel"] = 0'
check "saturation level 0 is refused" 3 "scene.cameras\[1\].video.saturation_level: must be in \[1, 256\]" -- \
  "$bin" validate "$work/s/sat_zero.json"

# --- Symlinks, treated alike by validate, run --direct, run and submit:
# a link inside the scene's folder is followed (and its target packed as a
# regular file), one that resolves outside it is refused with one message.
cp -r "$work/p4" "$work/ln"
mkdir -p "$work/ln/store" "$work/outside"
mv "$work/ln/videos/cam1/0002.png" "$work/ln/store/f2.png"
ln -s ../../store/f2.png "$work/ln/videos/cam1/0002.png"
expect "server starts" start_server "$work/server.log"
check "validate follows a symlinked frame inside the scene's folder" 0 "valid" -- "$bin" validate "$work/ln/scene.json"
check "run --direct follows it" 0 "wrote" -- "$bin" run --direct "$work/ln/scene.json" "${fit[@]}" --out "$work/ln_direct"
check "run packs its target" 0 "wrote" -- "$bin" run "$work/ln/scene.json" "${fit[@]}" --out "$work/ln_service"
check "submit packs its target" 0 "" -- "$bin" submit "$work/ln/scene.json" --config NE,NW,SE,SW --atlas 128 --server "$address"
expect "the symlinked frame gives the result of the copied one" \
  test "$(kd_rmse "$work/ln_direct" "$work/p8")" = "$kd_p4" -a "$(kd_rmse "$work/ln_service" "$work/p8")" = "$kd_p4"
cp "$work/ln/store/f2.png" "$work/outside/f3.png"
rm "$work/ln/videos/cam1/0003.png"
ln -s "$work/outside/f3.png" "$work/ln/videos/cam1/0003.png"
outside="scene.cameras\[1\].video.path (frame 3): \"videos/cam1/0003.png\" resolves to .*outside/f3.png, outside the scene's folder (a bundle is self-contained)"
check "validate refuses a symlink that leaves the scene's folder" 3 "$outside" -- "$bin" validate "$work/ln/scene.json"
check "run --direct refuses it alike" 3 "$outside" -- "$bin" run --direct "$work/ln/scene.json" "${fit[@]}" --out "$work/x"
check "run refuses it alike" 3 "$outside" -- "$bin" run "$work/ln/scene.json" "${fit[@]}" --out "$work/x"
check "submit refuses it alike" 3 "$outside" -- "$bin" submit "$work/ln/scene.json" --config NE,NW,SE,SW --atlas 128 --server "$address"
kill "$pid" 2>/dev/null
wait "$pid" 2>/dev/null

summary
