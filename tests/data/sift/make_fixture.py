"""Produce the OpenCV reference fixture for tests/sift_opencv.rs.

Run with any Python that has numpy and OpenCV 4.x (the float SIFT path that the Rust port
follows; OpenCV 5 switched SIFT to a fixed-point pyramid):

    python3 -m venv /tmp/cvvenv && /tmp/cvvenv/bin/pip install "opencv-python-headless<5"
    /tmp/cvvenv/bin/python tests/data/sift/make_fixture.py

Writes, next to this script:
- scene.png:   160x120 grey test image (seeded blobs, rectangles, stripes, mild noise);
- warped.png:  scene.png rotated by 20 degrees and scaled by 1.2 about its centre (warpAffine);
- opencv_sift.json: cv2.SIFT_create() defaults on both images: keypoints (x, y, size, angle,
  response, octave, layer; OpenCV coordinates, pixel centres at integers), descriptors as hex
  strings (OpenCV's float descriptors hold byte values), and the scene->warped matches that pass
  Lowe's ratio test 0.8 with a brute-force L2 matcher.
"""
import json
import os

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def scene(w=160, h=120, seed=12345):
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    f = np.full((h, w), 120.0)
    for _ in range(90):
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
        s = rng.uniform(1.2, 5.0)
        a = rng.uniform(-90, 90)
        sy = s * rng.uniform(0.6, 1.0)
        d2 = ((xx - cx) / s) ** 2 + ((yy - cy) / sy) ** 2
        f += a * np.exp(-0.5 * d2) * (d2 < 16)
    for _ in range(30):
        x0, y0 = rng.integers(0, w), rng.integers(0, h)
        rw, rh = rng.integers(3, 14), rng.integers(3, 14)
        f[y0:y0 + rh, x0:x0 + rw] += rng.uniform(-70, 70)
    for _ in range(3):
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
        rad, period, th = rng.uniform(8, 16), rng.uniform(5, 10), rng.uniform(0, np.pi)
        u = (xx - cx) * np.cos(th) + (yy - cy) * np.sin(th)
        disc = np.hypot(xx - cx, yy - cy) < rad
        f[disc] += 50 * np.sin(2 * np.pi * u[disc] / period)
    f += rng.normal(0, 2.0, f.shape)
    return np.clip(np.round(f), 0, 255).astype(np.uint8)


def octave_layer(kp):
    octave = kp.octave & 255
    octave = octave if octave < 128 else octave - 256
    return octave, (kp.octave >> 8) & 255


def features(img):
    sift = cv2.SIFT_create()
    kps, des = sift.detectAndCompute(img, None)
    out = []
    for k, d in zip(kps, des):
        o, l = octave_layer(k)
        out.append({
            "x": k.pt[0], "y": k.pt[1], "size": k.size, "angle": k.angle,
            "response": k.response, "octave": o, "layer": l,
            "descriptor": bytes(int(v) for v in d).hex(),
        })
    return kps, des, out


def main():
    a = scene()
    h, w = a.shape
    m = cv2.getRotationMatrix2D((w / 2, h / 2), 20, 1.2)
    b = cv2.warpAffine(a, m, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
    cv2.imwrite(os.path.join(HERE, "scene.png"), a)
    cv2.imwrite(os.path.join(HERE, "warped.png"), b)
    ka, da, ja = features(a)
    kb, db, jb = features(b)
    knn = cv2.BFMatcher(cv2.NORM_L2).knnMatch(da, db, k=2)
    matches = [
        {"query": p[0].queryIdx, "train": p[0].trainIdx, "distance": p[0].distance}
        for p in knn
        if len(p) == 2 and p[0].distance < 0.8 * p[1].distance
    ]
    fixture = {
        "opencv_version": cv2.__version__,
        "images": {"scene.png": ja, "warped.png": jb},
        "matches": matches,
    }
    with open(os.path.join(HERE, "opencv_sift.json"), "w") as fh:
        json.dump(fixture, fh, indent=None, separators=(",", ":"))
        fh.write("\n")
    print(f"OpenCV {cv2.__version__}: {len(ja)} + {len(jb)} keypoints, {len(matches)} matches")


if __name__ == "__main__":
    main()
