# png_read.py: read_png(PATH[, alpha]) decodes an 8-bit grey, RGB or RGBA PNG (or a 16-bit grey one) into rows of
# channel tuples (RGB, or every channel with alpha=True; one for grey) with the standard library only; imported by
# the tests' PNG checks.
import struct, zlib

def read_png(path, alpha=False):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, w = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, color = struct.unpack(">IIBB", body[:10])
            assert (depth == 8 and color in (0, 2, 6)) or (depth == 16 and color == 0), (depth, color)
            bpp = {0: 1, 2: 3, 6: 4}[color] * depth // 8
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
    if depth == 16:  # grey: big-endian pairs
        return [[(r[2 * x] << 8 | r[2 * x + 1],) for x in range(w)] for r in rows]
    n = bpp if alpha or bpp == 1 else 3
    return [[tuple(r[x * bpp:x * bpp + n]) for x in range(w)] for r in rows]


def linear(code):
    """An sRGB 8-bit code value as linear light in [0, 1]."""
    c = code / 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def covered_linear(path):
    """Per pixel the linear RGB of an RGBA render where its alpha is 255 (the mesh covers it), else None."""
    return [[tuple(linear(px[k]) for k in range(3)) if px[3] == 255 else None for px in row]
            for row in read_png(path, alpha=True)]
