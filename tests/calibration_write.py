#!/usr/bin/env python3
"""Writes a scene's cameras as other tools' calibration files, by each format's
own rules, and compares imported cameras with the truth (stdlib only).

  calibration_write.py write SCENE OUT_DIR
      OUT_DIR/opencv_yaml/<camera>.yml  OpenCV FileStorage YAML (%YAML:1.0,
          !!opencv-matrix), OpenCV's calibration sample's keys; even cameras
          with R, odd ones with a Rodrigues rvec; world-to-camera.
      OUT_DIR/opencv.json  one OpenCV FileStorage JSON file, a `cameras`
          sequence; camera 1 stored camera-to-world (extrinsics_convention).
      OUT_DIR/metashape.xml  an Agisoft Metashape camera export: one sensor per
          camera (f, cx, cy as offsets from the image centre, corner pixel
          origin, Metashape's p1/p2 order), camera transforms camera-to-chunk,
          and a chunk transform (rotation, translation, scale 2.5) world from
          chunk.
      OUT_DIR/expected.json  the truth: the scene's cameras with the
          distortion written into the files (OpenCV order k1, k2, p1, p2, k3).
  calibration_write.py compare EXPECTED IMPORTED_SCENE [TOLERANCE]
      Every expected camera's width, height, intrinsics, distortion and
      cam_from_world against the imported scene's camera of that name; prints
      the largest difference; exit 1 above TOLERANCE (default 1e-9).
"""
import json
import math
import os
import sys

# Distinct, camera-dependent distortion (p1 != p2 so an exchange shows).
def distortion(i):
    return [0.01 * (i + 1), -0.003 * (i + 1), 0.0007 * (i + 1), -0.0011 * (i + 1), 0.002]


def transpose(r):
    return [r[0], r[3], r[6], r[1], r[4], r[7], r[2], r[5], r[8]]


def mat_mul(a, b):
    return [sum(a[i * 3 + k] * b[k * 3 + j] for k in range(3)) for i in range(3) for j in range(3)]


def mat_vec(a, v):
    return [sum(a[i * 3 + k] * v[k] for k in range(3)) for i in range(3)]


def rodrigues(r):
    """The rotation vector of r, accurate also near 180 degrees."""
    cos_t = max(-1.0, min(1.0, (r[0] + r[4] + r[8] - 1.0) / 2.0))
    v = [(r[7] - r[5]) / 2.0, (r[2] - r[6]) / 2.0, (r[3] - r[1]) / 2.0]  # sin(theta) * axis
    sin_t = math.sqrt(sum(x * x for x in v))
    theta = math.atan2(sin_t, cos_t)
    if theta < 1e-12:
        return [0.0, 0.0, 0.0]
    if cos_t > 0.0:
        return [x * theta / sin_t for x in v]
    # Near pi: the axis from the symmetric part, (R + R^T)/2 - cos I = (1 - cos) a a^T.
    b = [(r[i * 3 + j] + r[j * 3 + i]) / 2.0 - (cos_t if i == j else 0.0) for i in range(3) for j in range(3)]
    k = max(range(3), key=lambda i: b[i * 4])
    a_k = math.sqrt(b[k * 4] / (1.0 - cos_t))
    a = [b[k * 3 + j] / ((1.0 - cos_t) * a_k) for j in range(3)]
    a[k] = a_k
    if sum(a[i] * v[i] for i in range(3)) < 0.0:
        a = [-x for x in a]
    return [x * theta for x in a]


def num(x):
    return repr(float(x))


def yaml_matrix(key, rows, cols, values):
    data = ", ".join(num(v) for v in values)
    return f"{key}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {data} ]\n"


def json_matrix(rows, cols, values):
    return {"type_id": "opencv-matrix", "rows": rows, "cols": cols, "dt": "d", "data": [float(v) for v in values]}


def write(scene_file, out):
    scene = json.load(open(scene_file))
    cameras = scene["cameras"]
    os.makedirs(os.path.join(out, "opencv_yaml"), exist_ok=True)
    expected = []
    json_cameras = []
    # World from chunk: a rotation about (1, 2, 2)/3 by 40 degrees, scale 2.5.
    axis = [1 / 3, 2 / 3, 2 / 3]
    angle = math.radians(40)
    c, s = math.cos(angle), math.sin(angle)
    x, y, z = axis
    chunk_r = [c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s,
               y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s,
               z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)]
    chunk_t = [0.3, -1.2, 4.0]
    chunk_s = 2.5
    sensors_xml, cameras_xml = [], []
    for i, cam in enumerate(cameras):
        name, w, h = cam["name"], cam["width"], cam["height"]
        k = cam["intrinsics"]
        fx, fy, cx, cy = k.get("fx", 0.0), k.get("fy", 0.0), k.get("cx", 0.0), k.get("cy", 0.0)
        d = distortion(i)
        r = [float(v) for v in cam["camFromWorld"]["rotation"]]
        t = [float(v) for v in cam["camFromWorld"]["translation"]]
        truth = json.loads(json.dumps(cam))
        truth["intrinsics"]["distortion"] = d
        truth.pop("video", None)
        expected.append(truth)

        # OpenCV YAML, one file per camera (directory import).
        text = "%YAML:1.0\n---\n"
        text += f"image_width: {w}\nimage_height: {h}\n"
        text += yaml_matrix("camera_matrix", 3, 3, [fx, 0, cx, 0, fy, cy, 0, 0, 1])
        text += yaml_matrix("distortion_coefficients", 5, 1, d)
        if i % 2 == 0:
            text += yaml_matrix("R", 3, 3, r)
        else:
            text += yaml_matrix("rvec", 3, 1, rodrigues(r))
        text += yaml_matrix("tvec", 3, 1, t)
        with open(os.path.join(out, "opencv_yaml", f"{name}.yml"), "w") as f:
            f.write(text)

        # OpenCV JSON, one file with a `cameras` sequence.
        entry = {"name": name, "image_width": w, "image_height": h,
                 "camera_matrix": json_matrix(3, 3, [fx, 0, cx, 0, fy, cy, 0, 0, 1]),
                 "distortion_coefficients": json_matrix(1, 5, d)}
        if i == 1:
            rt = transpose(r)
            centre = [-v for v in mat_vec(rt, t)]
            entry.update({"extrinsics_convention": "camera_to_world", "R": json_matrix(3, 3, rt),
                          "T": json_matrix(3, 1, centre)})
        else:
            entry.update({"R": json_matrix(3, 3, r), "T": json_matrix(3, 1, t)})
        json_cameras.append(entry)

        # Metashape: u = w/2 + cx + x'(f + b1) + y' b2 from the image corner,
        # so cx_ms = cx_mvbrdf + 0.5 - w/2; p1 (Metashape) = p2 (OpenCV).
        sensors_xml.append(
            f'      <sensor id="{i}" label="{name} sensor" type="frame">\n'
            f'        <resolution width="{w}" height="{h}"/>\n'
            f'        <calibration type="frame" class="adjusted">\n'
            f'          <resolution width="{w}" height="{h}"/>\n'
            f'          <f>{num(fy)}</f>\n          <cx>{num(cx + 0.5 - w / 2)}</cx>\n'
            f'          <cy>{num(cy + 0.5 - h / 2)}</cy>\n          <b1>{num(fx - fy)}</b1>\n'
            f'          <k1>{num(d[0])}</k1>\n          <k2>{num(d[1])}</k2>\n          <k3>{num(d[4])}</k3>\n'
            f'          <p1>{num(d[3])}</p1>\n          <p2>{num(d[2])}</p2>\n'
            f'        </calibration>\n      </sensor>\n')
        # chunk_from_camera = (world_from_chunk)^-1 world_from_camera.
        world_r = transpose(r)
        centre = [-v for v in mat_vec(world_r, t)]
        rct = transpose(chunk_r)
        m_r = mat_mul(rct, world_r)
        m_t = [v / chunk_s for v in mat_vec(rct, [centre[j] - chunk_t[j] for j in range(3)])]
        m = [m_r[0], m_r[1], m_r[2], m_t[0], m_r[3], m_r[4], m_r[5], m_t[1], m_r[6], m_r[7], m_r[8], m_t[2],
             0, 0, 0, 1]
        cameras_xml.append(f'      <camera id="{i}" sensor_id="{i}" label="{name}">\n'
                           f'        <transform>{" ".join(num(v) for v in m)}</transform>\n      </camera>\n')
    with open(os.path.join(out, "opencv.json"), "w") as f:
        json.dump({"cameras": json_cameras}, f, indent=2)
    with open(os.path.join(out, "metashape.xml"), "w") as f:
        f.write('<?xml version="1.0" encoding="UTF-8"?>\n<document version="1.5.0">\n  <chunk label="Chunk 1" '
                'enabled="true">\n    <sensors next_id="%d">\n%s    </sensors>\n    <cameras next_id="%d">\n%s'
                '      <camera id="%d" sensor_id="0" label="not_aligned"/>\n    </cameras>\n'
                '    <transform>\n      <rotation locked="true">%s</rotation>\n      <translation locked="true">%s'
                '</translation>\n      <scale locked="true">%s</scale>\n    </transform>\n  </chunk>\n</document>\n'
                % (len(cameras), "".join(sensors_xml), len(cameras) + 1, "".join(cameras_xml), len(cameras),
                   " ".join(num(v) for v in chunk_r), " ".join(num(v) for v in chunk_t), num(chunk_s)))
    with open(os.path.join(out, "expected.json"), "w") as f:
        json.dump({"cameras": expected}, f, indent=2)


def compare(expected_file, imported_file, tolerance):
    expected = json.load(open(expected_file))["cameras"]
    imported = {c["name"]: c for c in json.load(open(imported_file))["cameras"]}
    if sorted(imported) != sorted(c["name"] for c in expected):
        print(f"FAIL camera names: imported {sorted(imported)}, expected {[c['name'] for c in expected]}")
        return 1
    worst, where = 0.0, ""
    for e in expected:
        got = imported[e["name"]]
        for key in ("width", "height"):
            if got.get(key) != e.get(key):
                print(f"FAIL {e['name']}.{key}: {got.get(key)} != {e.get(key)}")
                return 1
        pairs = [(f"intrinsics.{k}", got["intrinsics"].get(k, 0.0), e["intrinsics"].get(k, 0.0))
                 for k in ("fx", "fy", "cx", "cy")]
        gd, ed = got["intrinsics"].get("distortion", []), e["intrinsics"].get("distortion", [])
        if len(gd) != len(ed):
            print(f"FAIL {e['name']}.intrinsics.distortion: {gd} != {ed}")
            return 1
        pairs += [(f"distortion[{i}]", gd[i], ed[i]) for i in range(len(ed))]
        for part in ("rotation", "translation"):
            g, x = got["camFromWorld"][part], e["camFromWorld"][part]
            pairs += [(f"camFromWorld.{part}[{i}]", g[i], x[i]) for i in range(len(x))]
        for field, g, x in pairs:
            if abs(g - x) > worst:
                worst, where = abs(g - x), f"{e['name']}.{field}"
    print(f"max difference {worst:.3g} ({where or 'none'}) over {len(expected)} cameras")
    return 0 if worst <= tolerance else 1


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "write":
        write(sys.argv[2], sys.argv[3])
    elif len(sys.argv) in (4, 5) and sys.argv[1] == "compare":
        sys.exit(compare(sys.argv[2], sys.argv[3], float(sys.argv[4]) if len(sys.argv) == 5 else 1e-9))
    else:
        sys.exit(__doc__)
