# gltf_three_compare.py: draws a glTF export with three.js in headless Chromium
# (tests/gltf_viewer.html) and runs with `mvbrdf render`, each view from one
# camera under one light, and prints, a line per view, their difference over
# the pixels both cover, in linear RGB: "MEAN P95 MEAN_RADIANCE" (issue #16's
# acceptance measure). SCENE.json (the runs' scene, or a copy, e.g. with
# lighting.inverseSquareFalloff) gives the light and is the scene `mvbrdf
# render` draws with. One Chromium start draws every view (each start ~6 s
# of CPU on llvmpipe); views that differ only in RUN_DIR share one image.
# Usage: gltf_three_compare.py MVBRDF MODEL.glb THREE_DIR SCENE.json WORK_DIR --view CAMERA LIGHT RUN_DIR 0|1 ...
# (the view's last field 1: three.js's direct diffuse weighted by glTF's 1 - F, tests/gltf_viewer.html)
import base64, json, os, re, subprocess, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from png_read import linear, read_png  # noqa: E402

mvbrdf, model, three, scene_file, work = sys.argv[1:6]
rest = sys.argv[6:]
if not rest or len(rest) % 5 or any(rest[i] != "--view" for i in range(0, len(rest), 5)):
    sys.exit("usage: gltf_three_compare.py MVBRDF MODEL.glb THREE_DIR SCENE.json WORK_DIR "
             "--view CAMERA LIGHT RUN_DIR 0|1 [--view ...]")
views = [tuple(rest[i + 1:i + 5]) for i in range(0, len(rest), 5)]  # (camera, light, run, gltf-diffuse)
drawn = list(dict.fromkeys((c, l, d) for c, l, _, d in views))  # three.js images: one per (camera, light, diffuse)
here = os.path.dirname(os.path.abspath(__file__))
url = "file://%s/gltf_viewer.html?three=file://%s&model=file://%s&views=%s" % (
    here, os.path.abspath(three), os.path.abspath(model), ";".join(":".join(v) for v in drawn))
m = None
for attempt in range(5):  # a page whose loads outlast the virtual time budget stays "pending": draw again (loaded CI machines: 3 were once not enough)
    dom = subprocess.run(
        ["/usr/bin/chromium", "--headless", "--no-sandbox", "--disable-quic", "--no-first-run",
         "--allow-file-access-from-files", "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         "--virtual-time-budget=60000", "--dump-dom", url],
        capture_output=True, text=True, timeout=300).stdout
    m = re.search(r'<pre id="out">(data:image/png;base64,[^<]+)</pre>', dom)
    if m or '<pre id="out">pending' not in dom:
        break
if not m:
    shown = re.search(r'<pre id="out">([^<]*)', dom)
    sys.exit("three.js drew nothing: %s" % (shown.group(1)[:300] if shown else dom[-500:]))
images = m.group(1).split("\n")
if not all(i.startswith("data:image/png;base64,") for i in images):
    sys.exit("three.js drew something else: %s" % m.group(1)[:300])
if len(images) != len(drawn):
    sys.exit("three.js drew %d images for %d views" % (len(images), len(drawn)))
viewers = {}
for (camera, light, diffuse), image in zip(drawn, images):
    viewers[(camera, light, diffuse)] = os.path.join(work, "three-%s-%s-%s.png" % (camera, light, diffuse))
    open(viewers[(camera, light, diffuse)], "wb").write(base64.b64decode(image[len("data:image/png;base64,"):]))


def compare(viewer, run, camera, light):
    lights = [l for l in json.load(open(scene_file))["lights"] if l["name"] == light]
    lights_file = os.path.join(work, "light-%s.json" % light)
    json.dump({"lights": lights}, open(lights_file, "w"))
    reference = os.path.join(work, "render-%s-%s.png" % (camera, light))
    subprocess.run([mvbrdf, "render", run, "--scene", scene_file, "--camera", camera, "--lights", lights_file, "--alpha",
                    "--out", reference],
                   check=True, capture_output=True)
    a, b = read_png(viewer, True), read_png(reference, True)
    if len(a) != len(b) or len(a[0]) != len(b[0]):
        sys.exit("sizes differ: three.js %dx%d, render %dx%d" % (len(a[0]), len(a), len(b[0]), len(b)))
    errors, radiance = [], 0.0
    for ra, rb in zip(a, b):
        for pa, pb in zip(ra, rb):
            if pa[3] == 255 and pb[3] == 255:
                for k in range(3):
                    errors.append(abs(linear(pa[k]) - linear(pb[k])))
                    radiance += linear(pb[k])
    if not errors:
        sys.exit("no pixel covered in both images")
    errors.sort()
    print("%.6g %.6g %.6g" % (sum(errors) / len(errors), errors[int(0.95 * len(errors))], radiance / len(errors)))


for camera, light, run, diffuse in views:
    compare(viewers[(camera, light, diffuse)], run, camera, light)
