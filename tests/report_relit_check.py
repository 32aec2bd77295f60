# report_relit_check.py REPORT.HTML [FRACTION]: the relit sequence of `mvbrdf report` (section id="relit") must
# show the model lit in every frame: each embedded image's mean brightness (8-bit, over all pixels) is at least
# FRACTION (default 0.25) of the brightest one's. Prints "frames N means M1 M2 ..." and exits 1 when one is darker.
import base64, os, re, sys, tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from png_read import read_png  # noqa: E402

html = open(sys.argv[1], encoding="utf-8").read()
fraction = float(sys.argv[2]) if len(sys.argv) > 2 else 0.25
section = html[html.index('id="relit"'):]
section = section[:section.index("</section>")]
means = []
for b64 in re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', section):
    with tempfile.NamedTemporaryFile(suffix=".png") as f:
        f.write(base64.b64decode(b64))
        f.flush()
        pixels = read_png(f.name)
    means.append(sum(sum(p) / 3.0 for row in pixels for p in row) / (len(pixels) * len(pixels[0])))
print("frames", len(means), "means", " ".join("%.2f" % m for m in means))
if not means or min(means) < fraction * max(means):
    print("darkest frame %.2f < %.2f x brightest %.2f" % (min(means) if means else 0, fraction, max(means) if means else 0))
    sys.exit(1)
