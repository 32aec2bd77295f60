#!/usr/bin/env python3
"""The layering of docs/architecture.md, checked on every #include.

The table "Layers (bottom to top)" lists folders bottom to top; "A folder may
include only the layers listed above it in this table." A source file belongs
to the row whose folder is its longest prefix; each of its project includes
("core/...", "server/...", "worker/...", "client/...", "shaders/...") must name a file of its
own folder or of a row above its own. Folders on one row (`server/`, `worker/`)
sit beside each other and include neither. Generated messages ("mvbrdf/v1/...")
are the bottom layer and always allowed; files in no listed folder (tests/) are
not checked.

Usage: layers_test.py [REPO]   (default: this file's repository)
"""
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parent.parent)
text = (root / "docs" / "architecture.md").read_text()
section = text.split("## Layers (bottom to top)", 1)[1].split("\n## ", 1)[0]

rows = []  # per row: its folders, without a trailing slash
for line in section.splitlines():
    cells = [c.strip() for c in line.strip().strip("|").split("|")]
    if len(cells) < 4 or cells[0] in ("layer",) or set(cells[0]) <= set("-"):
        continue
    folders = [f.rstrip("/") for f in re.findall(r"`([^`]+)`", cells[1])]
    if folders:
        rows.append(folders)
if len(rows) < 10:
    sys.exit("layers_test: could not read the layer table of docs/architecture.md (%d rows)" % len(rows))


def place(path):
    """(row index, folder) of a repository path: the longest matching folder."""
    best = None
    for i, folders in enumerate(rows):
        for f in folders:
            if path == f or path.startswith(f + "/"):
                if best is None or len(f) > len(best[1]):
                    best = (i, f)
    return best


include = re.compile(r'^\s*#\s*include\s+"((?:core|server|worker|client|shaders)/[^"]+)"', re.M)
problems = []
checked = 0
# Only the table's own top folders are read (not the build trees beside them).
tops = sorted({f.split("/")[0] for folders in rows for f in folders})
sources = sorted(p for top in tops for ext in ("cc", "h") for p in (root / top).glob("**/*." + ext))
for source in sources:
    rel = source.relative_to(root).as_posix()
    own = place(rel)
    if own is None:
        continue
    for target in include.findall(source.read_text(errors="replace")):
        there = place(target)
        checked += 1
        if there is None:
            problems.append("%s includes %s, in no layer of the table" % (rel, target))
        elif there[1] == own[1]:
            continue
        elif there[0] >= own[0]:
            problems.append("%s (layer %s) includes %s (layer %s, %s)" % (
                rel, own[1], target, there[1], "beside it" if there[0] == own[0] else "above it"))

for p in problems:
    print("layers_test: " + p)
print("layers_test: %d includes checked, %d across layers the wrong way" % (checked, len(problems)))
sys.exit(1 if problems else 0)
