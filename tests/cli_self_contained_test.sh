#!/usr/bin/env bash
# Issue #20 item 3: self-contained, reproducible outputs. result.json names its
# scene relative to itself (the tree can be moved), records the version, the
# commit and every option; a used --out is refused unless --force, which
# clears only a directory mvbrdf wrote; atlas/mesh.obj is in the input's
# vertex order with the seam map. Item 5: counts are JSON numbers.
# Usage: cli_self_contained_test.sh MVBRDF_BINARY WORK_DIR
set -u
bin=$1
work=$2
src=$(cd "$(dirname "$0")/.." && pwd)
rm -rf "$work"
mkdir -p "$work"
source "$(dirname "$0")/lib.sh"
json() { python3 -c 'import json, sys; d = json.load(open(sys.argv[1])); print(eval(sys.argv[2]))' "$1" "$2"; }

mkdir -p "$work/tree"
"$bin" synth --cameras 2 --frames 4 --width 160 --height 120 --actor-segments 12 --out "$work/tree/b" >/dev/null || exit 1
cat > "$work/lights.json" <<'JSON'
{"lights": [{"name": "key", "position": [2.0, 3.0, 2.0], "intensity": [1.0, 0.9, 0.8]}]}
JSON

# --- version, commit, options (item 2), counts as numbers (item 5) ---
check "run --direct" 0 "" -- "$bin" run "$work/tree/b/scene.json" --direct --atlas 128 --max-iterations 30 \
  --out "$work/tree/r" --report --relit-frames 2
version=$(sed -n 's/^project(mvbrdf VERSION \([0-9.]*\).*/\1/p' "$src/CMakeLists.txt")
commit=$(git -C "$src" rev-parse HEAD 2>/dev/null || echo unknown)
expect "result.json has the version ($version)" test "$(json "$work/tree/r/result.json" 'd["mvbrdfVersion"]')" = "$version"
expect "result.json has the commit ($commit, modulo -dirty)" \
  test "$(json "$work/tree/r/result.json" 'd["gitCommit"].replace("-dirty", "")')" = "$commit"
expect "options: --atlas 128 as fitting.atlasSize 128, --max-iterations 30, defaults resolved, direct" \
  test "$(json "$work/tree/r/result.json" 'd["options"]["fitting"]["atlasSize"], d["options"]["fitting"]["maxIterations"], d["options"]["fitting"]["maxClusterSamples"], d["options"]["direct"]')" \
  = "(128, 30, 100000, True)"
expect "options: the command line" test "$(json "$work/tree/r/result.json" '" ".join(d["options"]["commandLine"][:3])')" \
  = "mvbrdf run $work/tree/b/scene.json"
expect "counts are JSON numbers (texelsSeen, peakRssBytes, cameras[].samples)" python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
ok = isinstance(d["texelsSeen"], int) and isinstance(d["peakRssBytes"], int)
ok = ok and all(isinstance(c["samples"], int) for c in d["cameras"] if "samples" in c)
sys.exit(0 if ok and d["texelsSeen"] > 0 else 1)' "$work/tree/r/result.json"
check "run via the in-process service records the same options, not direct" 0 "" -- \
  "$bin" run "$work/tree/b/scene.json" --atlas 128 --outputs light --out "$work/tree/rs"
expect "service run: atlasSize 128, no direct flag, no bundle, scene relative" \
  test "$(json "$work/tree/rs/result.json" 'd["options"]["fitting"]["atlasSize"], d["options"].get("direct", False), d.get("bundleSha256", "-"), d["scene"]')" \
  = "(128, False, '-', '../b/scene.json')"

# --- the scene relative to result.json: move the whole tree (item 1) ---
expect "result.json names the scene relative to itself" test "$(json "$work/tree/r/result.json" 'd["scene"]')" = "../b/scene.json"
mv "$work/tree" "$work/moved"
check "render after moving input and output" 0 "wrote" -- "$bin" render "$work/moved/r" --camera cam0 \
  --lights "$work/lights.json" --out "$work/moved_render.png"
check "report after moving input and output" 0 "wrote" -- "$bin" report "$work/moved/r" --relit-frames 2 \
  --out "$work/moved_report.html"
expect "the moved report still finds the ground truth beside the scene" grep -q "kdRmse\|kd RMSE" "$work/moved_report.html"
mv "$work/moved/b" "$work/elsewhere_b"
check "render with the scene gone names result.json's scene and --scene" 3 "--scene FILE" -- "$bin" render \
  "$work/moved/r" --camera cam0 --lights "$work/lights.json" --out "$work/x.png"
check "render --scene gives the scene explicitly" 0 "wrote" -- "$bin" render "$work/moved/r" --camera cam0 \
  --lights "$work/lights.json" --out "$work/x.png" --scene "$work/elsewhere_b/scene.json"
mv "$work/elsewhere_b" "$work/moved/b"

# --- a used --out (item 3) ---
b="$work/moved/b"
check "a re-run into a used --out is refused" 3 "not empty (it holds .*--force" -- \
  "$bin" run "$b/scene.json" --direct --atlas 128 --out "$work/moved/r"
expect "the refused run left the old result" test -s "$work/moved/r/result.json" -a -s "$work/moved/r/report.html"
cp -r "$b" "$work/b2"
sed -i 's/"count": 4/"count": 2/' "$work/b2/scene.json"
check "--force re-runs with fewer frames" 0 "" -- "$bin" run "$work/b2/scene.json" --direct --atlas 128 \
  --out "$work/moved/r" --force
expect "--force: only the new run's correction atlases remain (0000, 0001)" \
  test "$(cd "$work/moved/r/atlases/correction" && ls | tr '\n' ' ')" = "0000.exr 0001.exr "
expect "--force: the old report is gone" test ! -e "$work/moved/r/report.html"
expect "--force: result.json is the new run's (2 frames)" test "$(json "$work/moved/r/result.json" 'd["frames"]')" = 2
mkdir -p "$work/home/docs" && echo precious > "$work/home/docs/letter.txt"
check "--force on a directory mvbrdf did not write refuses, naming a file" 3 "holds no .mvbrdf-output (it holds .*docs" -- \
  "$bin" run "$b/scene.json" --direct --atlas 128 --out "$work/home" --force
expect "... and deletes nothing, adds nothing" test "$(cd "$work/home" && find . | sort | tr '\n' ' ')" = \
  ". ./docs ./docs/letter.txt "
check "resample into a used --out is refused" 3 "not empty" -- "$bin" resample "$b/scene.json" --atlas 128 \
  --out "$work/moved/r"
check "synth into a used --out is refused" 3 "not empty" -- "$bin" synth --cameras 2 --frames 2 --width 64 \
  --height 48 --out "$work/moved/r"
check "synth --force into its own output" 0 "wrote" -- "$bin" synth --cameras 2 --frames 2 --width 64 --height 48 \
  --actor-segments 8 --out "$work/b2" --force
check "help states the --force rule" 0 "only one an mvbrdf command wrote" -- "$bin" run --help

# --- atlas/mesh.obj in the input's vertex order, and the seam map (item 4) ---
# The bundle with its mesh files' vertices permuted (and an unused vertex in
# front): the same surface, numbered otherwise than by first use.
cp -r "$b" "$work/bp"
python3 - "$work/bp/meshes" <<'PY'
import os, random, sys
d = sys.argv[1]
n = None
for name in sorted(os.listdir(d)):
    lines = open(os.path.join(d, name)).read().splitlines()
    v = [l for l in lines if l.startswith("v ")]
    if n is None:
        n = len(v)
        perm = list(range(n)); random.Random(7).shuffle(perm)  # new position of old vertex i
        inv = [0] * n
        for old, new in enumerate(perm): inv[new] = old
    out = ["# permuted", "v 9 9 9"] + [v[inv[k]] for k in range(n)]
    for l in lines:
        if l.startswith("f "):
            out.append("f " + " ".join(str(perm[int(c.split("/")[0]) - 1] + 2) for c in l.split()[1:]))
    open(os.path.join(d, name), "w").write("\n".join(out) + "\n")
PY
check "run on the permuted bundle" 0 "" -- "$bin" run "$work/bp/scene.json" --direct --atlas 128 --outputs brdf \
  --out "$work/rp"
check "run on the original bundle" 0 "" -- "$bin" run "$b/scene.json" --direct --atlas 128 --outputs brdf \
  --out "$work/ro"
expect "mesh.obj: v i = the input's v i, faces = the input's faces, UVs = the atlas's, seams.txt agrees" python3 - \
  "$work/bp/meshes" "$work/rp/atlas" "$work/ro/atlas" <<'PY'
import os, sys
meshes, atlas, original = sys.argv[1:]
def obj(path):
    v, vt, f = [], [], []
    for l in open(path):
        p = l.split()
        if not p: continue
        if p[0] == "v": v.append(tuple(float(x) for x in p[1:4]))
        elif p[0] == "vt": vt.append(tuple(float(x) for x in p[1:3]))
        elif p[0] == "f": f.append([tuple(int(i) - 1 for i in c.split("/")) for c in p[1:]])
    return v, vt, f
inp_v, _, inp_f = obj(os.path.join(meshes, "mesh_0000.obj"))
v, vt, f = obj(os.path.join(atlas, "mesh.obj"))
_, ovt, of = obj(os.path.join(original, "mesh.obj"))
bad = []
if v != inp_v: bad.append("v lines differ from the input's (%d vs %d)" % (len(v), len(inp_v)))
if [[c[0] for c in face] for face in f] != [[c[0] for c in face] for face in inp_f]: bad.append("face v indices differ")
# The atlas is the one the unpermuted input gets (same surface): the same UV per corner.
if [[vt[c[1]] for c in face] for face in f] != [[ovt[c[1]] for c in face] for face in of]: bad.append("UVs differ")
seams = [int(l) for l in open(os.path.join(atlas, "seams.txt")) if not l.startswith("#")]
pairs = {c[1]: c[0] for face in f for c in face}
if len(seams) != len(vt) or any(seams[t] != pairs.get(t, seams[t]) for t in range(len(vt))): bad.append("seams.txt disagrees")
if len(set(seams)) == len(seams): bad.append("no seam vertex (one v with several vt)")
# Re-applying frame 3's input vertices by index gives frame 3's surface.
v3, _, f3 = obj(os.path.join(meshes, "mesh_0003.obj"))
if [[v3[c[0]] for c in face] for face in f] != [[v3[c[0]] for c in face] for face in f3]: bad.append("frame 3")
if v3 == v: bad.append("frame 3 equals the rest pose (the test proves nothing)")
print("\n".join(bad), file=sys.stderr)
sys.exit(1 if bad else 0)
PY
check "render reads the new mesh.obj" 0 "wrote" -- "$bin" render "$work/rp" --camera cam0 --lights "$work/lights.json" \
  --out "$work/rp.png"
check "render of the original run" 0 "wrote" -- "$bin" render "$work/ro" --camera cam0 --lights "$work/lights.json" \
  --out "$work/ro.png"
expect "the permuted input renders as the original (same atlas, same surface)" cmp -s "$work/rp.png" "$work/ro.png"

summary
