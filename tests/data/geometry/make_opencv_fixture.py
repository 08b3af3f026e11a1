"""Reference contours and moments from OpenCV for tests/geometry_fixtures.rs.

Run: /work/peers/venv/bin/python tests/data/geometry/make_opencv_fixture.py
Writes tests/data/geometry/opencv_contours.json: for each mask (rows of '0'/'1', drawn inside
an image with an empty border so OpenCV's image-border handling plays no part), the outer
borders (even depth in RETR_TREE, i.e. not holes) with CHAIN_APPROX_SIMPLE, and cv2.moments
with binaryImage=True (m00, m10, m01, mu20, mu02, mu11; pixel-index coordinates).
"""
import json
import os

import cv2
import numpy as np

rng = np.random.default_rng(20240601)


def blob(h, w):
    noise = rng.random((h, w)).astype(np.float32)
    k = int(rng.integers(1, 4)) * 2 + 1
    sm = cv2.GaussianBlur(noise, (k, k), 0)
    return (sm > np.quantile(sm, rng.uniform(0.3, 0.7))).astype(np.uint8)


def ellipses(h, w):
    m = np.zeros((h, w), np.uint8)
    for _ in range(int(rng.integers(1, 4))):
        c = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        ax = (int(rng.integers(1, w // 2)), int(rng.integers(1, h // 2)))
        cv2.ellipse(m, c, ax, float(rng.uniform(0, 180)), 0, 360, 1, -1)
    return m


def lines(h, w):
    m = np.zeros((h, w), np.uint8)
    for _ in range(int(rng.integers(1, 4))):
        p = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        q = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        cv2.line(m, p, q, 1, int(rng.integers(1, 3)))
    return m


def ring(h, w):
    m = np.zeros((h, w), np.uint8)
    c = (w // 2, h // 2)
    cv2.circle(m, c, min(h, w) // 2 - 1, 1, -1)
    cv2.circle(m, c, min(h, w) // 4, 0, -1)
    cv2.circle(m, c, max(1, min(h, w) // 10), 1, -1)  # island inside the hole
    return m


def sparse(h, w):
    return (rng.random((h, w)) > 0.85).astype(np.uint8)


cases = []
gens = [blob, ellipses, lines, ring, sparse]
for i in range(30):
    h, w = int(rng.integers(4, 28)), int(rng.integers(4, 28))
    m = gens[i % len(gens)](h, w)
    if m.sum() == 0:
        m[h // 2, w // 2] = 1
    img = np.zeros((h + 2, w + 2), np.uint8)
    img[1:-1, 1:-1] = m * 255
    contours, hier = cv2.findContours(img, cv2.RETR_TREE, cv2.CHAIN_APPROX_SIMPLE)
    outer = []
    for k, c in enumerate(contours):
        depth, p = 0, hier[0][k][3]
        while p >= 0:
            depth += 1
            p = hier[0][p][3]
        if depth % 2 == 0:
            outer.append(c.reshape(-1, 2).tolist())
    mo = cv2.moments(img, binaryImage=True)
    cases.append({
        "width": w + 2,
        "height": h + 2,
        "rows": ["".join("1" if v else "0" for v in row) for row in img],
        "outer_contours": outer,
        "moments": {k: mo[k] for k in ["m00", "m10", "m01", "mu20", "mu02", "mu11"]},
    })

out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "opencv_contours.json")
with open(out, "w") as f:
    json.dump({"opencv": cv2.__version__, "cases": cases}, f, separators=(",", ":"))
print("wrote", out, len(cases), "cases")
