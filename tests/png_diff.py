# png_diff.py A.png B.png: prints "LIT DIFFERING": pixels of A with a channel > 10, and pixels whose
# channels differ by more than 3 code values (8-bit RGB or RGBA PNGs of one size; no libraries needed).
import os, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from png_read import read_png  # noqa: E402

a, b = read_png(sys.argv[1]), read_png(sys.argv[2])
assert len(a) == len(b) and len(a[0]) == len(b[0])
lit = sum(max(p) > 10 for row in a for p in row)
differing = sum(max(abs(x - y) for x, y in zip(p, q)) > 3 for ra, rb in zip(a, b) for p, q in zip(ra, rb))
print(lit, differing)
