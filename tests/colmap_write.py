#!/usr/bin/env python3
"""Writes a COLMAP sparse model (text or binary) of a scene.json's cameras.

Follows COLMAP's documented layout (https://colmap.github.io/format.html), not
mvbrdf's reader: cameras.txt / images.txt / points3D.txt, or cameras.bin /
images.bin / points3D.bin (little endian). One COLMAP camera and one image per
scene camera, IMAGE_ID and CAMERA_ID 1, 2, ... in the scene's order.

- Pose: cam_from_world as a Hamilton quaternion QW QX QY QZ (from the
  row-major rotation) and T.
- Pixels: COLMAP's top-left pixel centre is (0.5, 0.5): cx_colmap = cx + 0.5.
- Model: PINHOLE without distortion, OPENCV for k1 k2 p1 p2 (and a zero k3),
  FULL_OPENCV otherwise (k4..k6 zero when the scene gives 5 values).

Usage: colmap_write.py SCENE OUT_DIR [--binary] [--image-name stem|dir]
                       [--transform FILE]
--transform FILE: a 4x4 row-major similarity world_from_calibration (JSON, 16
numbers); the model is written in the calibration's world, so that importing
it with the same --transform gives back the scene's cameras:
  R_c = R' R, t_c = (t' + R' t) / s   (R', t' the scene's pose).
Stdlib only.
"""
import json
import math
import os
import struct
import sys

MODEL_IDS = {"PINHOLE": 1, "OPENCV": 4, "FULL_OPENCV": 6}


def quaternion(r):
    """Hamilton (w, x, y, z) of a row-major rotation (Shepperd's method)."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = r
    trace = m00 + m11 + m22
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        return (0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s)
    if m00 > m11 and m00 > m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        return ((m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s)
    if m11 > m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        return ((m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s)
    s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
    return ((m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s)


def matmul(a, b):
    return [sum(a[3 * i + k] * b[3 * k + j] for k in range(3)) for i in range(3) for j in range(3)]


def to_calibration(rotation, translation, transform):
    """The pose in the calibration's world (see --transform)."""
    a = [transform[0], transform[1], transform[2], transform[4], transform[5], transform[6],
         transform[8], transform[9], transform[10]]
    det = (a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) +
           a[2] * (a[3] * a[7] - a[4] * a[6]))
    s = det ** (1.0 / 3.0)
    r = [v / s for v in a]
    t = [transform[3], transform[7], transform[11]]
    rc = matmul(rotation, r)
    rt = [sum(rotation[3 * i + k] * t[k] for k in range(3)) for i in range(3)]
    tc = [(translation[i] + rt[i]) / s for i in range(3)]
    return rc, tc


def colmap_camera(cam):
    intr = cam["intrinsics"]
    fx, fy = intr["fx"], intr["fy"]
    cx, cy = intr.get("cx", 0.0) + 0.5, intr.get("cy", 0.0) + 0.5
    d = list(intr.get("distortion", []))
    if not any(d):
        return "PINHOLE", [fx, fy, cx, cy]
    if len(d) == 4 or (len(d) == 5 and d[4] == 0.0):
        return "OPENCV", [fx, fy, cx, cy] + d[:4]
    d = d + [0.0] * (8 - len(d))
    return "FULL_OPENCV", [fx, fy, cx, cy] + d


def main(argv):
    scene_file, out_dir = argv[1], argv[2]
    binary = "--binary" in argv
    image_name = argv[argv.index("--image-name") + 1] if "--image-name" in argv else "stem"
    transform = json.load(open(argv[argv.index("--transform") + 1])) if "--transform" in argv else None
    cams = json.load(open(scene_file))["cameras"]
    os.makedirs(out_dir, exist_ok=True)
    cameras, images = [], []
    for i, cam in enumerate(cams, start=1):
        model, params = colmap_camera(cam)
        cameras.append((i, model, cam["width"], cam["height"], params))
        pose = cam["camFromWorld"]
        r, t = pose["rotation"], pose["translation"]
        if transform is not None:
            r, t = to_calibration(r, t, transform)
        name = cam["name"] + ".png" if image_name == "stem" else cam["name"] + "/0000.png"
        images.append((i, quaternion(r), t, i, name))
    if binary:
        with open(os.path.join(out_dir, "cameras.bin"), "wb") as f:
            f.write(struct.pack("<Q", len(cameras)))
            for cid, model, w, h, params in cameras:
                f.write(struct.pack("<IiQQ", cid, MODEL_IDS[model], w, h))
                f.write(struct.pack("<%dd" % len(params), *params))
        with open(os.path.join(out_dir, "images.bin"), "wb") as f:
            f.write(struct.pack("<Q", len(images)))
            for iid, q, t, cid, name in images:
                f.write(struct.pack("<I4d3dI", iid, *q, *t, cid))
                f.write(name.encode() + b"\0")
                # Two 2D points (X, Y, POINT3D_ID), one of them unmatched (-1).
                f.write(struct.pack("<Q", 2))
                f.write(struct.pack("<ddq", 10.5, 20.5, -1))
                f.write(struct.pack("<ddq", 30.5, 40.5, 7))
        with open(os.path.join(out_dir, "points3D.bin"), "wb") as f:
            f.write(struct.pack("<Q", 0))
    else:
        with open(os.path.join(out_dir, "cameras.txt"), "w") as f:
            f.write("# Camera list with one line of data per camera:\n")
            f.write("#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n")
            f.write("# Number of cameras: %d\n" % len(cameras))
            for cid, model, w, h, params in cameras:
                f.write("%d %s %d %d %s\n" % (cid, model, w, h, " ".join(repr(float(p)) for p in params)))
        with open(os.path.join(out_dir, "images.txt"), "w") as f:
            f.write("# Image list with two lines of data per image:\n")
            f.write("#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n")
            f.write("#   POINTS2D[] as (X, Y, POINT3D_ID)\n")
            f.write("# Number of images: %d, mean observations per image: 0\n" % len(images))
            for n, (iid, q, t, cid, name) in enumerate(images):
                f.write("%d %s %s %d %s\n" % (iid, " ".join(repr(v) for v in q), " ".join(repr(float(v)) for v in t),
                                              cid, name))
                # Every other image has no points: an empty POINTS2D line.
                f.write("" if n % 2 else "10.5 20.5 -1 30.5 40.5 7")
                f.write("\n")
        with open(os.path.join(out_dir, "points3D.txt"), "w") as f:
            f.write("# 3D point list with one line of data per point:\n")
            f.write("#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n")
            f.write("# Number of points: 0, mean track length: 0\n")


if __name__ == "__main__":
    main(sys.argv)
