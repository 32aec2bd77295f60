#!/usr/bin/env bash
# Hostile input through the CLI (issue #19): names that try to leave --out or
# to inject markup, output directories that hold the scene, full disks,
# concurrent writers of one directory, inputs that are no regular files and
# SIGINT. Nothing may be written outside --out, no command may abort (an exit
# code >= 128 is a crash), every string in report.html is escaped.
# Usage: cli_hostile_input_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
rm -rf "$work"
mkdir -p "$work/sentinel" "$work/tmp"
source "$(dirname "$0")/lib.sh"
export TMPDIR="$work/tmp"
opts=(--atlas 64 --no-powell --config "NE,NW,SE,SW")

# no_abort NAME CMD...: the command may fail, but not by a signal or an abort;
# its exit code is left in $rc, its output in $work/last.out.
no_abort() {
  local name=$1
  shift
  "$@" > "$work/last.out" 2>&1
  rc=$?
  if [ "$rc" -ge 128 ]; then
    echo "FAIL $name: exit $rc (aborted)"; tail -3 "$work/last.out"; failures=$((failures + 1)); return 1
  fi
  return 0
}
sentinel_empty() { test -z "$(ls -A "$work/sentinel")"; }

check "generate a tiny sequence" 0 "" -- "$bin" synth --cameras 2 --frames 2 --width 64 --height 48 \
  --actor-segments 6 --out "$work/b"
scene="$work/b/scene.json"
sha_before=$(cd "$work/b" && find . -type f -print0 | sort -z | xargs -0 sha256sum | sha256sum)

# rename FIELD NAME OUT_DIR: a copy of the scene with one name replaced
# everywhere it is used (camera 0, light "NE", configuration "NE,NW,SE,SW",
# seed "cloth", segment "torso"). NAME is a JSON string body (\u0000 allowed).
rename() {
  local field=$1 name=$2 dir=$3
  rm -rf "$dir"
  cp -r "$work/b" "$dir"
  /usr/bin/python3 - "$dir" "$field" "$name" <<'PY'
import json, sys
d, field, raw = sys.argv[1], sys.argv[2], sys.argv[3]
name = json.loads('"' + raw + '"')
s = json.load(open(d + "/scene.json"))
if field == "camera":
    s["cameras"][0]["name"] = name
elif field == "light":
    for l in s["lights"]:
        if l["name"] == "NE": l["name"] = name
    for c in s.get("lightConfigurations", []) + s.get("frameLighting", []):
        c["lights"] = [name if x == "NE" else x for x in c["lights"]]
elif field == "configuration":
    for c in s["lightConfigurations"]:
        if c["name"] == "NE,NW,SE,SW": c["name"] = name
elif field == "seed":
    for m in s["materialSeeds"]:
        if m["name"] == "cloth": m["name"] = name
    for g in s["segmentMaterials"]:
        g["materials"] = [name if x == "cloth" else x for x in g["materials"]]
elif field == "segment":
    for g in s["segmentMaterials"]:
        if g["segment"] == "torso": g["segment"] = name
    lines = open(d + "/segments.txt", encoding="utf-8", errors="surrogateescape").read().split("\n")
    safe = name if "\n" not in name and "\0" not in name else "x"
    open(d + "/segments.txt", "w", encoding="utf-8", errors="surrogateescape").write(
        "\n".join(safe if l == "torso" else l for l in lines))
json.dump(s, open(d + "/scene.json", "w"), indent=1)
PY
}

# --- Defect 1 and 13: names that cannot be file names are refused, naming the field.
long=$(printf 'n%.0s' $(seq 1 200))
rejected=('../x' '../../../sentinel/pwn' "$work/sentinel/abs" 'a\u0000b' 'a\nb' 'a\tb' '\u001b[31mred'
          '<script>alert(1)</script>' '..' '' "$long")
accepted=('café' '<img src=x onerror=alert(1)>' '\"quote'"'" '<script>alert(1)')
declare -A field_path=([camera]="scene.cameras[0].name" [light]="scene.lights[" [configuration]="scene.light_configurations["
                       [seed]="scene.material_seeds[" [segment]="scene.segment_materials[")
n=0
for field in camera light configuration seed segment; do
  for name in "${rejected[@]}"; do
    n=$((n + 1))
    rename "$field" "$name" "$work/h$n"
    no_abort "validate $field '$name'" "$bin" validate "$work/h$n/scene.json" || continue
    if [ "$rc" -ne 3 ] || grep -q "^valid" "$work/last.out" || ! grep -qF "${field_path[$field]}" "$work/last.out"; then
      echo "FAIL validate $field '$name': exit $rc, not refused with the field named"; cat "$work/last.out"
      failures=$((failures + 1))
    else
      passes=$((passes + 1))
    fi
    if [ "$field" = camera ]; then  # the name would become frames/0000/<name>.exr
      check "resample refuses camera '$name' (exit 3)" 3 "scene.cameras\[0\].name" -- \
        "$bin" resample "$work/h$n/scene.json" --atlas 64 --out "$work/h$n.out"
    fi
  done
  for name in "${accepted[@]}"; do
    n=$((n + 1))
    rename "$field" "$name" "$work/h$n"
    no_abort "validate $field '$name'" "$bin" validate "$work/h$n/scene.json" || continue
    [ "$rc" -eq 0 ] && passes=$((passes + 1)) || { echo "FAIL $field '$name' refused"; cat "$work/last.out"; failures=$((failures + 1)); }
  done
done
echo "     ($n name cases through validate; $passes passed so far)"
for k in 1 2 3; do  # ../x, ../../../sentinel/pwn, an absolute path: run (both paths) and run --report refuse them
  check "run --direct --report refuses camera '${rejected[$((k - 1))]}'" 3 "scene.cameras\[0\].name" -- \
    "$bin" run "$work/h$k/scene.json" --direct --atlas 64 --report --out "$work/h$k.run"
  check "run refuses camera '${rejected[$((k - 1))]}'" 3 "scene.cameras\[0\].name" -- \
    "$bin" run "$work/h$k/scene.json" --atlas 64 --out "$work/h$k.run"
done
rename camera 'a\u0000b' "$work/nul"
check "a NUL in a camera name is not 'valid' (defect 13)" 3 "scene.cameras\[0\].name: must not contain control" -- \
  "$bin" validate "$work/nul/scene.json"
check "a 200-byte name names the limit" 3 "at most 128 bytes" -- "$bin" validate "$work/h${#rejected[@]}/scene.json"
/usr/bin/python3 -c "
import json, sys
s = json.load(open(sys.argv[1])); s['name'] = 'ab\u0000cd\u001b[31m'
json.dump(s, open(sys.argv[2], 'w'))" "$scene" "$work/b_named.json"
cp "$work/b_named.json" "$work/b/named.json"
check "a NUL and ESC in the free-form scene.name: validate's summary is whole and escaped" 0 'ab\\x00cd\\x1b\[31m' -- \
  "$bin" validate "$work/b/named.json"
/usr/bin/python3 -c "
import json, sys
s = json.load(open(sys.argv[1])); s['name'] = 'n' * 1000000
json.dump(s, open(sys.argv[2], 'w'))" "$scene" "$work/b/long_named.json"
check "a 1 MB scene.name: validate's summary elides it" 0 "(1000000 characters)" -- "$bin" validate "$work/b/long_named.json"
expect "and stays short (it was 1 MB)" test "$("$bin" validate "$work/b/long_named.json" | wc -c)" -lt 20000
rm -f "$work/b/named.json" "$work/b/long_named.json"
cp -r "$work/b" "$work/dupe"
sed -i 's/"cam1"/"cam0"/' "$work/dupe/scene.json"
check "duplicate camera names are refused" 3 "duplicate" -- "$bin" validate "$work/dupe/scene.json"
expect "nothing was written to the sentinel directory" sentinel_empty

# Names that are fine (non-ASCII, markup, quotes) go through every command.
all="$work/all"
rm -rf "$all"
cp -r "$work/b" "$all"
/usr/bin/python3 - "$all" <<'PY'
import json, sys
d = sys.argv[1]
s = json.load(open(d + "/scene.json"))
s["name"] = "<script>alert('scene')</script>"
s["cameras"][0]["name"] = "<img src=x onerror=alert(1)>"
s["cameras"][1]["name"] = "café \"quote'"
for c in s["lightConfigurations"]:
    if c["name"] == "NE,NW,SE,SW": c["name"] = "<script>alert(2)"
for m in s["materialSeeds"]:
    if m["name"] == "cloth": m["name"] = "<b onmouseover=alert(3)>"
for g in s["segmentMaterials"]:
    g["materials"] = ["<b onmouseover=alert(3)>" if x == "cloth" else x for x in g["materials"]]
json.dump(s, open(d + "/scene.json", "w"), indent=1)
# The truth synth wrote names the same cameras (evaluate checks it is of this scene).
t = json.load(open(d + "/ground_truth/truth.json"))
renamed = {"cam0": s["cameras"][0]["name"], "cam1": s["cameras"][1]["name"]}
for c in t.get("cameras", []) + t.get("scene", {}).get("cameras", []):
    c["name"] = renamed.get(c["name"], c["name"])
json.dump(t, open(d + "/ground_truth/truth.json", "w"), indent=1)
PY
check "validate: markup, quotes and non-ASCII are valid names" 0 "valid" -- "$bin" validate "$all/scene.json"
check "resample with those names" 0 "wrote" -- "$bin" resample "$all/scene.json" --atlas 64 --out "$work/all_resample"
expect "resample wrote frames/0000/<camera>.exr inside --out" \
  test -f "$work/all_resample/frames/0000/<img src=x onerror=alert(1)>.exr" -a -f "$work/all_resample/frames/0000/café \"quote'_grown.exr"
check "run --direct --report with those names" 0 "report.html" -- "$bin" run "$all/scene.json" --direct --atlas 64 \
  --no-powell --config "<script>alert(2)" --report --relit-frames 2 --out "$work/all_run"
cat > "$work/tradeoff.json" <<'JSON'
{"scene": "</script><script>alert(4)</script>", "points": [
 {"knob": "<img src=x onerror=alert(5)>", "setting": "\"'><script>alert(6)</script>", "seconds": 1, "kdRmse": 0.1},
 {"knob": "atlas", "setting": "<svg onload=alert(7)>", "seconds": 2, "kdRmse": 0.05, "chosen": true}]}
JSON
check "report with a hostile --tradeoff" 0 "wrote" -- "$bin" report "$work/all_run" --tradeoff "$work/tradeoff.json" \
  --relit-frames 2 --out "$work/all_run/tradeoff.html"
for page in "$work/all_run/report.html" "$work/all_run/tradeoff.html"; do
  p=$(basename "$page")
  expect "$p: no <img from a name" bash -c "! grep -qF '<img src=x' '$page'"
  expect "$p: the only <script> is the page's own" test "$(grep -o '<script' "$page" | wc -l)" -eq 1
  expect "$p: no raw markup from names" bash -c "! grep -qE '<b onmouseover|<svg onload|alert\([0-9]\)</script>' '$page'"
done
expect "report.html shows the camera name as text" grep -qF '&lt;img src=x onerror=alert(1)&gt;' "$work/all_run/report.html"
expect "tradeoff.html shows the knob as text" grep -qF '&lt;img src=x onerror=alert(5)&gt;' "$work/all_run/tradeoff.html"

# render names its camera by the scene's (hostile but valid) name; nothing is written but --out.
cat > "$work/all_lights.json" <<'JSON'
{"lights": [{"name": "<script>k", "position": [2.0, 3.0, 2.0], "intensity": [1.0, 0.9, 0.8]}]}
JSON
check "render --camera with a markup name" 0 "wrote" -- "$bin" render "$work/all_run" \
  --camera "<img src=x onerror=alert(1)>" --lights "$work/all_lights.json" --out "$work/all_run/rendered.png"
check "render --camera café" 0 "wrote" -- "$bin" render "$work/all_run" --camera "café \"quote'" \
  --lights "$work/all_lights.json" --out "$work/all_run/rendered_cafe.exr"
check "render --camera with an ESC is refused, shown escaped" 3 "x1b" -- "$bin" render "$work/all_run" \
  --camera $'\e[2J' --lights "$work/all_lights.json" --out "$work/all_run/rendered_esc.png"
expect "nothing was written to the sentinel directory" sentinel_empty

cat > "$work/bad_lights.json" <<'JSON'
{"lights": [{"name": "k", "position": [2.0, 3.0, 2.0], "intensity": [1.0, 1e30, 0.8]}]}
JSON
check "render --lights: an error names the file's field, not the scene's" 3 "bad_lights.json: lights\[0\].intensity\[1\]" -- \
  "$bin" render "$work/all_run" --camera "café \"quote'" --lights "$work/bad_lights.json" --out "$work/all_run/x.png"

# submit to a loopback server: refused names are refused there too.
expect "server starts" start_server "$work/server.log"
check "submit of markup names is accepted" 0 "" -- "$bin" submit "$all/scene.json" --server "$address" --client t \
  --config "<script>alert(2)"
for k in 1 2 4 6 7; do
  check "submit refuses camera '${rejected[$((k - 1))]}'" 3 "scene.cameras\[0\].name" -- \
    "$bin" submit "$work/h$k/scene.json" --server "$address" --client t
done
# What the user typed is echoed escaped in every error line, not only in ReportFailure's (an ESC in a job id,
# an artifact name, a flag, its value or a command reached the terminal raw).
esc=$'\e[2J'
no_esc() {  # no_esc NAME CMD...: the command fails and no ESC byte reaches its output
  local out rc
  out=$("${@:2}" 2>&1)
  rc=$?
  if [ "$rc" -eq 0 ] || [ "$rc" -ge 128 ] || grep -q $'\e' <<<"$out"; then
    echo "FAIL $1: exit $rc, or a raw ESC in: $(cat -v <<<"$out" | head -2)"; failures=$((failures + 1))
  else
    echo "ok   $1"; passes=$((passes + 1))
  fi
}
no_esc "an unknown command with an ESC" "$bin" "x$esc"
no_esc "an unknown flag with an ESC" "$bin" validate "--x$esc"
no_esc "an unexpected argument with an ESC" "$bin" validate "$scene" "x$esc"
no_esc "a flag value with an ESC" "$bin" run "$scene" --atlas "1$esc" --out "$work/esc"
no_esc "fetch of a job id with an ESC" "$bin" fetch "j$esc" result.json --server "$address" --out "$work/esc"
no_esc "fetch of an artifact name with an ESC" "$bin" fetch 0123 "n$esc" --server "$address" --out "$work/esc"
no_esc "fetch of a name leaving --out, with an ESC" "$bin" fetch 0123 "../$esc" --server "$address" --out "$work/esc"
no_esc "cancel of a job id with an ESC" "$bin" cancel "j$esc" --server "$address"
no_esc "watch of a job id with an ESC" "$bin" watch "j$esc" --server "$address"
no_esc "submit of a --config with an ESC (the server's answer echoes it)" "$bin" submit "$scene" --server "$address" \
  --client t --config "c$esc"
kill -TERM "$pid" 2>/dev/null
wait "$pid" 2>/dev/null

# --- Defect 5: an output directory that holds the scene or its inputs.
check "run --out the scene's directory is refused" 3 "holds the scene file" -- \
  "$bin" run "$scene" --direct "${opts[@]}" --out "$work/b"
check "run --out the scene's directory, embedded" 3 "holds the scene file" -- \
  "$bin" run "$scene" "${opts[@]}" --out "$work/b"
check "run --out a parent of the scene's directory" 3 "holds the scene file" -- \
  "$bin" run "$scene" --direct "${opts[@]}" --out "$work"
check "run --out the videos' directory" 3 "video.path" -- "$bin" run "$scene" --direct "${opts[@]}" --out "$work/b/videos"
ln -s "$work/b" "$work/link"
check "run --out a symlink to the scene's directory" 3 "holds the scene file" -- \
  "$bin" run "$scene" --direct "${opts[@]}" --out "$work/link"
check "run --out DIR/.. back into the scene's directory" 3 "holds the scene file" -- \
  "$bin" run "$scene" --direct "${opts[@]}" --out "$work/b/meshes/.."
check "resample --out the scene's directory" 3 "holds the scene file" -- \
  "$bin" resample "$scene" --atlas 64 --out "$work/b"
check "resample --out the meshes' directory" 3 "scene.mesh.path" -- \
  "$bin" resample "$scene" --atlas 64 --out "$work/b/meshes"
# run --data (the in-process server's state) likewise: not in the scene's directory, not mixed with --out.
check "run --data the scene's directory is refused" 3 "^mvbrdf: error: --data $work/b: holds the scene file" -- \
  "$bin" run "$scene" "${opts[@]}" --data "$work/b" --out "$work/data_run"
check "run --data equal to --out is refused" 3 "--data $work/data_run: holds --out" -- \
  "$bin" run "$scene" "${opts[@]}" --data "$work/data_run" --out "$work/data_run"
check "run --out holding --data is refused" 3 "--out $work/data_run: holds --data" -- \
  "$bin" run "$scene" "${opts[@]}" --data "$work/data_run/state" --out "$work/data_run"
sha_after=$(cd "$work/b" && find . -type f -print0 | sort -z | xargs -0 sha256sum | sha256sum)
expect "the scene's directory is unchanged" test "$sha_before" = "$sha_after"

# A good run for render and evaluate.
mkdir -p "$work/dir.png"
check "run --direct" 0 "wrote" -- "$bin" run "$scene" --direct "${opts[@]}" --out "$work/run"
cat > "$work/lights.json" <<'JSON'
{"lights": [{"name": "key", "position": [2.0, 3.0, 2.0], "intensity": [1.0, 0.9, 0.8]}]}
JSON
check "render --out the run's kd atlas is refused" 3 "would overwrite" -- "$bin" render "$work/run" --camera cam0 \
  --lights "$work/lights.json" --out "$work/run/atlases/kd.exr"
check "render --out the run's triangle ids, through a symlink and .., is refused" 3 "would overwrite" -- \
  "$bin" render "$work/run" --camera cam0 --lights "$work/lights.json" --out "$work/link/../run/atlas/triangle_id.exr"
check "render --out a correction atlas is refused" 3 "would overwrite" -- "$bin" render "$work/run" \
  --camera cam0 --lights "$work/lights.json" --out "$work/run/atlases/correction/0001.exr"
check "render --out a directory is refused" 3 "is a directory" -- "$bin" render "$work/run" --camera cam0 \
  --lights "$work/lights.json" --out "$work/dir.png"
# render --camera FILE is checked as a scene's camera (NaN or non-orthonormal rotations, an infinite cx, 3
# distortion values rendered silently; 100000 pixels wide exited 1 with GL_INVALID_VALUE).
/usr/bin/python3 - "$scene" "$work" <<'PY2'
import json, sys
cam = json.load(open(sys.argv[1]))["cameras"][0]
def variant(name, edit):
    c = json.loads(json.dumps(cam)); edit(c); json.dump(c, open(f"{sys.argv[2]}/cam_{name}.json", "w"))
variant("rot_nan", lambda c: c["camFromWorld"]["rotation"].__setitem__(0, "NaN"))
variant("rot_scaled", lambda c: c["camFromWorld"].__setitem__("rotation", [2, 0, 0, 0, 2, 0, 0, 0, 2]))
variant("cx_inf", lambda c: c["intrinsics"].__setitem__("cx", "Infinity"))
variant("dist3", lambda c: c["intrinsics"].__setitem__("distortion", [0, 0, 0]))
variant("wide", lambda c: c.__setitem__("width", 100000))
variant("wider", lambda c: c.__setitem__("width", 20000))
PY2
for v in "rot_nan:cam_from_world.rotation\[0\]: must be a finite number" "rot_scaled:must be orthonormal" \
         "cx_inf:intrinsics.cx: must be a finite number" "dist3:intrinsics.distortion: expected 0, 4, 5 or 8" \
         "wide:camera.width: must be in 1..65536" "wider:exceeds the largest render target"; do
  check "render --camera a JSON camera with ${v%%:*} is refused" 3 "${v#*:}" -- "$bin" render "$work/run" \
    --camera "$work/cam_${v%%:*}.json" --lights "$work/lights.json" --out "$work/cam_${v%%:*}.png"
done

# report --out and evaluate --error-atlas likewise spare what they read (report --out DIR/result.json or
# the scene file, evaluate --error-atlas DIR/atlases/kd.exr exited 0 and destroyed the run or the scene).
run_sha=$(cd "$work/run" && find . -type f ! -name .mvbrdf.lock -print0 | sort -z | xargs -0 sha256sum | sha256sum)
check "report --out the run's result.json is refused" 3 "would overwrite the run's result.json" -- \
  "$bin" report "$work/run" --no-render --out "$work/run/result.json"
check "report --out the scene file is refused" 3 "would overwrite the scene file" -- \
  "$bin" report "$work/run" --no-render --out "$scene"
check "report --out a video, through a symlink, is refused" 3 "would overwrite scene.cameras\[0\].video.path" -- \
  "$bin" report "$work/run" --no-render --out "$work/link/videos/cam0.mkv"
check "report --out an atlas preview is refused" 3 "would overwrite the run's atlases/\*.png" -- \
  "$bin" report "$work/run" --no-render --out "$work/run/atlases/kd.png"
check "report --out the --tradeoff file is refused" 3 "would overwrite --tradeoff" -- \
  "$bin" report "$work/run" --no-render --tradeoff "$work/tradeoff.json" --out "$work/tradeoff.json"
check "evaluate --error-atlas the run's kd atlas is refused" 3 "would overwrite the run's atlases/\*.exr" -- \
  "$bin" evaluate "$work/run" --truth "$work/b" --error-atlas "$work/run/atlases/kd.exr"
check "evaluate --error-atlas in the run's atlas/ is refused" 3 "would overwrite the run's atlas/\*.exr" -- \
  "$bin" evaluate "$work/run" --truth "$work/b" --error-atlas "$work/run/atlas/kd.exr"
check "render --out an atlas preview is refused" 3 "would overwrite the run's atlases/\*.png" -- "$bin" render \
  "$work/run" --camera cam0 --lights "$work/lights.json" --out "$work/run/atlases/kd.png"
run_sha_after=$(cd "$work/run" && find . -type f ! -name .mvbrdf.lock -print0 | sort -z | xargs -0 sha256sum | sha256sum)
expect "the run's directory is unchanged" test "$run_sha" = "$run_sha_after"
sha_after=$(cd "$work/b" && find . -type f -print0 | sort -z | xargs -0 sha256sum | sha256sum)
expect "the scene's directory is still unchanged" test "$sha_before" = "$sha_after"

# --- Defect 4 (part): --error-atlas that is no .png/.exr file.
check "evaluate --error-atlas x.txt" 3 "expected a file name ending in .png or .exr" -- \
  "$bin" evaluate "$work/run" --truth "$work/b" --error-atlas "$work/x.txt"
check "evaluate --error-atlas without extension" 3 "ending in .png or .exr" -- \
  "$bin" evaluate "$work/run" --truth "$work/b" --error-atlas "$work/x"
check "evaluate --error-atlas a directory" 3 "is a directory" -- \
  "$bin" evaluate "$work/run" --truth "$work/b" --error-atlas "$work/dir.png"

# --- Defect 6: full disks. A 64 KiB tmpfs, filled, in a private mount
# namespace (root and unshare -m, as cli_disk_full needs).
if [ "$(id -u)" -eq 0 ] && unshare -m true 2>/dev/null; then
  mkdir -p "$work/full"
  full() {  # full CMD...: runs CMD with $work/full a full tmpfs; prints its exit code last
    unshare -m --propagation private sh -c "mount -t tmpfs -o size=64k full '$work/full' && \
      (dd if=/dev/zero of='$work/full/filler' bs=4k 2>/dev/null; true) && \"\$@\" > '$work/full.out' 2>&1; rc=\$?; \
      cat '$work/full.out'; \
      find '$work/full' -type f ! -name filler ! -name .mvbrdf.lock -size +0 > '$work/full.left'; \
      find '$work/full' -name '*.tmp*' >> '$work/full.left'; exit \$rc" sh "$@"
  }
  for ext in png exr; do
    check "render --out a full disk ($ext) fails, exit 4" 4 "No space left on device" -- \
      full "$bin" render "$work/run" --camera cam0 --lights "$work/lights.json" --out "$work/full/x.$ext"
    expect "no half-written or temporary file is left ($ext)" test ! -s "$work/full.left"
    expect "render does not say it wrote ($ext)" bash -c "! grep -q '^wrote' '$work/full.out'"
  done
  check "evaluate --error-atlas to a full disk fails, exit 4" 4 "No space left on device" -- \
    full "$bin" evaluate "$work/run" --truth "$work/b" --error-atlas "$work/full/e.png"
  check "run --direct to a full disk fails, exit 4" 4 "No space left on device" -- \
    full "$bin" run "$scene" --direct "${opts[@]}" --out "$work/full/run"
  expect "no truncated kd.exr or other file is left" test ! -s "$work/full.left"
  # The embedded run copies the job's artifacts to --out: a disk that fills halfway through (100 KiB of the run's
  # ~150) left a truncated kd.exr under its name and said "Input/output error".
  partial() {  # partial CMD...: as full, on a 100 KiB tmpfs left empty; lists what is left with its size
    unshare -m --propagation private sh -c "mount -t tmpfs -o size=100k full '$work/full' && \
      \"\$@\" > '$work/full.out' 2>&1; rc=\$?; cat '$work/full.out'; \
      (cd '$work/full' && find . -type f ! -name .mvbrdf.lock) > '$work/full.files'; \
      (cd '$work/full' && for f in \$(cat '$work/full.files'); do cmp -s \"\$f\" '$work/run/'\"\${f#./r/}\" || echo \"\$f\"; done) \
        > '$work/full.left'; exit \$rc" sh "$@"
  }
  check "run (embedded) to a disk that fills while copying fails, exit 4" 4 "No space left on device" -- \
    partial "$bin" run "$scene" "${opts[@]}" --out "$work/full/r"
  expect "every file it left is whole (no truncated kd.exr, no temporary, no result.json)" test ! -s "$work/full.left"
  expect "it did copy some files before the disk filled" grep -q atlas "$work/full.files"
  check "resample to a full disk fails, exit 4" 4 "No space left on device" -- \
    full "$bin" resample "$scene" --atlas 64 --out "$work/full/rs"
  check "report to a full disk fails, exit 4" 4 "No space left on device" -- \
    full "$bin" report "$work/run" --no-render --out "$work/full/report.html"
else
  echo "FAIL the full-disk cases need root and unshare -m"; failures=$((failures + 1))
fi

# --- Defect 10: one writer per output directory.
mkdir -p "$work/locked"
flock -n "$work/locked/.mvbrdf.lock" sleep 30 &
holder=$!
sleep 0.3
check "run into a directory another command writes fails at once, exit 4" 4 "another mvbrdf command is writing" -- \
  "$bin" run "$scene" --direct "${opts[@]}" --out "$work/locked"
check "resample likewise" 4 "$work/locked" -- "$bin" resample "$scene" --atlas 64 --out "$work/locked"
check "synth likewise (two synths into one --out would mix their files)" 4 "another mvbrdf command is writing" -- \
  "$bin" synth --cameras 2 --frames 2 --width 64 --height 48 --actor-segments 6 --out "$work/locked"
expect "synth wrote nothing there" test ! -e "$work/locked/scene.json"
kill "$holder" 2>/dev/null
wait "$holder" 2>/dev/null
"$bin" run "$scene" --direct "${opts[@]}" --out "$work/twice" > "$work/first.log" 2>&1 &
first=$!
holds_lock() {  # holds_lock FILE: some process holds a flock on FILE (/proc/locks, without taking it)
  [ -e "$1" ] && grep -q ":$(stat -c %i "$1") " /proc/locks
}
for _ in $(seq 1 200); do holds_lock "$work/twice/.mvbrdf.lock" && break; sleep 0.02; done
check "a second run into the same --out at once fails, exit 4" 4 "another mvbrdf command is writing" -- \
  "$bin" run "$scene" --direct "${opts[@]}" --out "$work/twice"
wait "$first"
expect "the first run succeeds alone" test "$?" -eq 0
check "once it is done the directory can be written again (--force)" 0 "wrote" -- \
  "$bin" run "$scene" --direct "${opts[@]}" --out "$work/twice" --force

# --- Weak spots: inputs that are no regular files; SIGINT of run.
check "validate a directory as the scene" 3 "is a directory" -- "$bin" validate "$work/b"
check "validate /dev/zero as the scene" 3 "is a character device, not a regular file" -- "$bin" validate /dev/zero
cp -r "$work/b" "$work/fifo"
rm "$work/fifo/videos/cam0.mkv"
mkfifo "$work/fifo/videos/cam0.mkv"
check "a FIFO as a video is named as one" 3 "is a FIFO, not a regular file" -- \
  timeout 20 "$bin" validate "$work/fifo/scene.json"
cp -r "$work/b" "$work/meshdir"
rm "$work/meshdir/meshes/mesh_0000.obj"
mkdir "$work/meshdir/meshes/mesh_0000.obj"
check "a directory as a mesh is named as one" 3 "is a directory" -- "$bin" validate "$work/meshdir/scene.json"

# A background job of a script starts with SIGINT ignored: python resets it to
# the default, as an interactive shell's Ctrl-C would find it.
for sig in INT TERM; do
  rm -rf "$work/tmp"/* "$work/interrupted"
  cp -r "$work/run" "$work/interrupted"  # a previous run's outputs: its result.json must not survive beside new atlases
  /usr/bin/python3 -c 'import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); os.execv(sys.argv[1], sys.argv[1:])' \
    "$bin" run "$scene" --atlas 256 --no-powell --config "NE,NW,SE,SW" --out "$work/interrupted" --force > "$work/int.log" 2>&1 &
  runner=$!
  for _ in $(seq 1 400); do ls "$work/tmp" | grep -q mvbrdf-run- && break; sleep 0.02; done
  expect "run made its temporary state directory" bash -c "ls '$work/tmp' | grep -q mvbrdf-run-"
  sleep 0.2
  kill -"$sig" "$runner"
  wait "$runner"
  rc=$?
  expect "SIG$sig ends run by the signal (exit $rc)" test "$rc" -eq $((128 + $(kill -l "$sig")))
  expect "SIG$sig leaves no temporary state directory" test -z "$(ls -A "$work/tmp")"
  expect "SIG$sig leaves no previous result.json beside the new outputs" test ! -e "$work/interrupted/result.json"
done

# Nothing outside --out: the sentinel is empty and no file appeared beside
# the work directory's own entries.
expect "the sentinel directory is still empty" sentinel_empty
expect "no file was written outside the work directory's subdirectories" \
  test -z "$(find "$work" -maxdepth 1 -type f ! -name '*.json' ! -name '*.log' ! -name '*.out' ! -name 'full.left' ! -name 'full.files')"
expect "no file named after a hostile name anywhere" test -z "$(find "$work" -name 'pwn*' -o -name 'abs*')"
expect "no file named after a hostile name beside the frames" test -z "$(find "$work" -path '*/frames/x*')"
summary
