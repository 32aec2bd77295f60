# report_relit_check.py REPORT.HTML [FRACTION]: the relit sequence of `mvbrdf report` (section id="relit") must
# show the model lit in every frame: each embedded image's mean brightness (8-bit, over all pixels) is at least
# FRACTION (default 0.25) of the brightest one's. Prints "frames N means M1 M2 ..." and exits 1 when one is darker.
import base64, re, struct, sys, tempfile, zlib

def read_png(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, w = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, color = struct.unpack(">IIBB", body[:10])
            assert depth == 8 and color in (2, 6), (depth, color)
            bpp = 3 if color == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw, stride, rows, prev = zlib.decompress(idat), w * bpp, [], bytearray(w * bpp)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], prev[i - bpp] if i >= bpp else 0
            if f == 1: line[i] = (line[i] + a) & 255
            elif f == 2: line[i] = (line[i] + b) & 255
            elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return [[tuple(r[x * bpp:x * bpp + 3]) for x in range(w)] for r in rows]


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
