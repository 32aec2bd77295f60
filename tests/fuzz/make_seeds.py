#!/usr/bin/env python3
"""Writes generated seed inputs for the binary formats (scripts/fuzz runs it).

Usage: make_seeds.py CORPUS_ROOT
Writes CORPUS_ROOT/sample_set/*.mvss (encoded Sample sets, the layout in
core/samples/sample_set.cc) and CORPUS_ROOT/bundle/*.tar (bundles as
PackBundle writes them: uncompressed ustar, sorted, mtime 0, mode 0644, ending
in the two zero blocks). Generated rather than committed so the repository
holds no binaries; the text seeds live in tests/fuzz/corpus/.
"""
import io
import os
import struct
import sys
import tarfile


def half(x):
    return struct.pack('<e', x)


def sample_set(lights, samples, compact, falloff, half_vector=False, version=3):
    """lights: [(name, (r, g, b))]; samples: [(element, frame, camera, rgb, g[], h[], a[])] as dense rows.

    Version 3 (2 without half_vector reads alike): a sample's terms are the
    lights with g != 0 (counts, then per term light u16, g, h and a); with
    half_vector (flag 4) n.v per sample, n.h and v.h per term follow, made up
    from the rows (n.v = 0.75, n.h = (1 + h) / 2, v.h = (1 + g) / 2).
    """
    flags = (1 if compact else 0) | (2 if falloff else 0) | (4 if half_vector else 0)
    terms = [[k for k, g in enumerate(s[4]) if g != 0.0] for s in samples]
    out = b'MVSS' + struct.pack('<IIIQQ', version, flags, len(lights), len(samples), sum(len(t) for t in terms))
    for name, rgb in lights:
        raw = name.encode()
        out += struct.pack('<I', len(raw)) + raw + struct.pack('<3f', *rgb)
    real = half if compact else (lambda x: struct.pack('<f', x))
    out += b''.join(struct.pack('<I', s[0]) for s in samples)
    out += b''.join(struct.pack('<H', s[1]) for s in samples)
    out += b''.join(struct.pack('<B', s[2]) for s in samples)
    out += b''.join(real(c) for s in samples for c in s[3])
    out += b''.join(struct.pack('<H', len(t)) for t in terms)
    out += b''.join(struct.pack('<H', k) for t in terms for k in t)
    for column in (4, 5) + ((6,) if falloff else ()):
        out += b''.join(real(s[column][k]) for s, t in zip(samples, terms) for k in t)
    if half_vector:
        out += b''.join(real(0.75) for s in samples)
        out += b''.join(real((1 + s[5][k]) / 2) for s, t in zip(samples, terms) for k in t)
        out += b''.join(real((1 + s[4][k]) / 2) for s, t in zip(samples, terms) for k in t)
    return out


def bundle(files):
    """files: {name: bytes}; a PackBundle-like tar trimmed to its end marker."""
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode='w', format=tarfile.USTAR_FORMAT) as tar:
        for name in sorted(files):
            info = tarfile.TarInfo(name)
            info.size = len(files[name])
            info.mtime = 0
            info.mode = 0o644
            tar.addfile(info, io.BytesIO(files[name]))
    data = buf.getvalue()
    used = sum(512 + (len(v) + 511) // 512 * 512 for v in files.values())
    return data[:used] + b'\0' * 1024


def write(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, 'wb') as f:
        f.write(data)


def main():
    root = sys.argv[1]
    two = [('NE', (1.0, 1.0, 1.0)), ('sun', (2.0, 2.0, 1.8))]
    rows = [(7, 0, 0, (0.5, 0.25, 0.125), (0.5, 0.0), (0.9, 0.0), (0.16, 1.0)),
            (8, 3, 1, (1.0, 0.0, 65504.0), (1.0, 0.25), (0.0, 1.0), (1.0, 1.0))]
    seeds = {
        'empty_compact': sample_set([], [], True, False),
        'no_lights': sample_set([], [(1, 2, 3, (0.1, 0.2, 0.3), (), (), ())], True, False),
        'compact': sample_set(two, rows, True, False),
        'float32': sample_set(two, rows, False, False),
        'falloff_compact': sample_set(two, rows, True, True),
        'falloff_float32': sample_set(two, rows, False, True),
        'version2_compact': sample_set(two, rows, True, False, version=2),
        'half_vector_compact': sample_set(two, rows, True, False, half_vector=True),
        'half_vector_falloff_float32': sample_set(two, rows, False, True, half_vector=True),
        # 40 lights (three shadow channels), one on per sample (OLAT).
        'olat_40': sample_set([('L%d' % k, (1.0, 1.0, 1.0)) for k in range(40)],
                              [(i, i, 0, (0.5, 0.5, 0.5), tuple(0.5 if k == (7 * i) % 40 else 0.0 for k in range(40)),
                                tuple(0.25 if k == (7 * i) % 40 else 0.0 for k in range(40)), ()) for i in range(6)],
                              True, False),
    }
    for name, data in seeds.items():
        write(os.path.join(root, 'sample_set', name + '.mvss'), data)

    scene = (b'{"name": "b", "mesh": {"path": "mesh.obj"}, "frames": {"count": 1, "fps": 25}, "cameras": '
             b'[{"name": "c", "width": 8, "height": 8, "intrinsics": {"fx": 10, "fy": 10, "cx": 3.5, "cy": 3.5}, '
             b'"video": {"path": "video/c.mp4"}}], "lights": [{"name": "L", "position": [0, 2, 2]}]}\n')
    mesh = b'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n'
    bundles = {
        'scene_and_mesh': {'scene.json': scene, 'mesh.obj': mesh},
        'nested': {'scene.json': scene, 'mesh.obj': mesh, 'video/c.mp4': b'\0' * 16, 'ground_truth/truth.json': b'{}'},
        'other_json': {'take1.json': scene, 'mesh.obj': mesh},
        'empty_file': {'scene.json': b''},
    }
    for name, files in bundles.items():
        write(os.path.join(root, 'bundle', name + '.tar'), bundle(files))


if __name__ == '__main__':
    main()
