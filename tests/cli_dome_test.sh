#!/usr/bin/env bash
# Issue #13 items 3 and 4: `synth --preset sphere --dome N --lighting olat`
# (a static sphere of one material, N directional lights over the upper
# hemisphere, frame t lit by dome light t mod N) reconstructed end to end
# against the truth; the dome with every light on at once (more than 16
# lights through the renderer); and the same scene with the world scaled by
# 1000, which reconstructs and renders the same image (with the old fixed
# clip planes, near 0.05 and far 100, `render` drew it black, exit 0).
# Usage: cli_dome_test.sh MVBRDF_BINARY WORK_DIR [N]   (N: dome lights, default 16)
set -u
bin=$1
work=$2
n=${3:-16}
rm -rf "$work"
mkdir -p "$work"
here=$(dirname "$0")
source "$here/lib.sh"

small=(--preset sphere --cameras 2 --width 160 --height 120)
check "synth --preset sphere --dome $n --lighting olat" 0 "sphere preset" -- \
  "$bin" synth "${small[@]}" --frames "$n" --dome "$n" --lighting olat --out "$work/olat"
scene="$work/olat/scene.json"
expect "scene.json: $n directional lights D000.., frame t lit by light t mod $n" python3 - "$scene" "$n" <<'EOF_PY'
import json, math, sys
s, n = json.load(open(sys.argv[1])), int(sys.argv[2])
names = ["D%03d" % k for k in range(n)]
lights = s["lights"]
ok = [l["name"] for l in lights] == names
ok = ok and all("position" not in l and abs(math.hypot(*l["direction"]) - 1) < 1e-6 and l["direction"][1] > 0 for l in lights)
ok = ok and [f["lights"] for f in s["frameLighting"]] == [[names[t % n]] for t in range(n)]
sys.exit(not ok)
EOF_PY
expect "the truth records the dome's lights and frame lighting" python3 - "$scene" "$work/olat/ground_truth/truth.json" <<'EOF_PY'
import json, sys
s, t = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
sys.exit(not (t["lights"] == s["lights"] and t["frameLighting"] == s["frameLighting"] and t["preset"] == "sphere"))
EOF_PY

check "run --direct on the OLAT sphere" 0 "configuration: per-frame lighting" -- \
  "$bin" run --direct "$scene" --atlas 128 --out "$work/run"
read -r kd ks ke < <("$bin" evaluate "$work/run" --truth "$work/olat" | python3 -c '
import json, sys
d = json.load(sys.stdin)
print(d["kdRmse"], max(c["ksRelError"] for c in d["clusters"]), max(c["keRelError"] for c in d["clusters"]))')
echo "     OLAT sphere, $n lights: kd RMSE $kd, ks rel error $ks, ke rel error $ke"
# Measured (16 lights): kd RMSE 0.0012, ks 0.08 %, ke 0.3 %.
expect "kd RMSE against the truth <= 0.01" python3 -c "import sys; sys.exit(not $kd <= 0.01)"
expect "ks and ke within 5 % of the truth" python3 -c "import sys; sys.exit(not ($ks <= 0.05 and $ke <= 0.05))"
# The memory check up front counts the lights (shadow atlas channels, pass 1's
# sums, the kept Samples' terms): at 4096² the run needs ~5.2 GiB, not the
# 2.5 GiB of resampling with one light, and is refused under ulimit -v 4.3 GiB
# before any allocation (it used to pass the check and fail mid-run).
if [ "${MVBRDF_SANITIZED:-0}" != 1 ]; then
  check "run: the memory check up front counts the $n lights" 4 "MiB for $n lights, but only" -- \
    bash -c "ulimit -v 4500000 && exec '$bin' run --direct '$scene' --atlas 4096 --out '$work/run4096'"
fi

# Every dome light at once: 40 lights through the renderer's passes of 16.
check "synth --dome 40 --lighting studio (all 40 lights on)" 0 "active configuration all" -- \
  "$bin" synth "${small[@]}" --frames 1 --dome 40 --out "$work/studio40"
check "resample the 40-light sphere against the truth" 0 "wrote" -- \
  "$bin" resample "$work/studio40/scene.json" --atlas 128 --out "$work/resample40"
# Measured: RMSE 0.0037 per camera (the truth rendered with all 40 lights, shadow atlas in 3 channels).
expect "resample RMSE against the truth < 0.02" python3 -c '
import json, sys
sys.exit(not all(c["rmse"] < 0.02 for c in json.load(open(sys.argv[1]))["cameras"]))' "$work/resample40/resample.json"
expect "the shadow atlas of 40 lights is saved as one file, one channel per 16 lights" \
  python3 -c 'import sys; h = open(sys.argv[1], "rb").read(4096)
sys.exit(not all(n in h for n in (b"lights0000-0015", b"lights0016-0031", b"lights0032-0047")) or b"lights0048" in h)' \
  "$work/resample40/frames/0000/shadows.exr"
check "synth --dome 40 --config D000,D031: two of them" 0 "active configuration D000,D031" -- \
  "$bin" synth "${small[@]}" --frames 1 --dome 40 --config D000,D031 --out "$work/studio2"
expect "the truth holds the configuration's lights" python3 -c '
import json, sys
t = json.load(open(sys.argv[1]))
sys.exit(not [l["name"] for l in t["lights"]] == ["D000", "D031"])' "$work/studio2/ground_truth/truth.json"
check "synth --dome with a ceiling light's name is invalid input" 3 'no dome light "NE"' -- \
  "$bin" synth "${small[@]}" --frames 1 --dome 4 --config NE --out "$work/x"
check "synth --dome out of range is a usage error" 2 "--dome: must be in \[0, 1024\]" -- \
  "$bin" synth "${small[@]}" --frames 1 --dome 2000 --out "$work/x"

# The world scaled by 1000: mesh and camera translations (directional lights keep their directions).
cp -r "$work/olat" "$work/big"
python3 - "$work/big" <<'EOF_PY'
import glob, json, sys
d = sys.argv[1]
s = json.load(open(d + "/scene.json"))
for c in s["cameras"]:
    c["camFromWorld"]["translation"] = [1000 * x for x in c["camFromWorld"]["translation"]]
json.dump(s, open(d + "/scene.json", "w"))
for f in glob.glob(d + "/meshes/*.obj"):
    lines = [("v " + " ".join(repr(1000 * float(x)) for x in l.split()[1:4]) + "\n") if l.startswith("v ") else l
             for l in open(f)]
    open(f, "w").write("".join(lines))
EOF_PY
check "run --direct on the scene scaled by 1000" 0 "configuration: per-frame lighting" -- \
  "$bin" run --direct "$work/big/scene.json" --atlas 128 --out "$work/big_run"
python3 -c '
import json, sys
s = json.load(open(sys.argv[1]))
json.dump({"lights": s["lights"][1:4]}, open(sys.argv[2], "w"))' "$scene" "$work/lights.json"
check "render the reconstruction" 0 "wrote" -- \
  "$bin" render "$work/run" --camera cam0 --lights "$work/lights.json" --out "$work/run.png"
check "render the reconstruction of the scaled scene" 0 "wrote" -- \
  "$bin" render "$work/big_run" --camera cam0 --lights "$work/lights.json" --out "$work/big.png"
read -r lit differing < <(python3 "$here/png_diff.py" "$work/run.png" "$work/big.png")
echo "     scaled by 1000: $differing of $lit lit pixels differ by more than 3 code values"
# Measured: 9 of 5017 (silhouette pixels).
expect "the scaled scene renders the same image (not black)" \
  python3 -c "import sys; sys.exit(not ($lit > 2000 and $differing <= $lit // 100))"

summary
