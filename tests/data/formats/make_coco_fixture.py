"""Makes the COCO-video cross-check fixture with pycocotools (run once, output committed).

    /work/peers/venv/bin/python tests/data/formats/make_coco_fixture.py

Writes `coco_video_pycocotools.json` (a YouTube-VIS style file whose segmentations are
compressed RLE strings, uncompressed `counts` lists and polygons) and
`coco_video_pycocotools_expected.json`: for every (annotation, frame) the mask pycocotools
decodes (`frPyObjects` then `merge`, as the YouTube-VIS API's annToRLE), as a compressed
string, with `toBbox` and `area`.
"""
import json
import os

import numpy as np
from pycocotools import mask as mu

rng = np.random.default_rng(20240611)
here = os.path.dirname(os.path.abspath(__file__))


def blob(h, w):
    m = np.zeros((h, w), dtype=np.uint8)
    for _ in range(3):
        y0, x0 = rng.integers(0, h - 3), rng.integers(0, w - 3)
        y1, x1 = y0 + rng.integers(2, h // 2), x0 + rng.integers(2, w // 2)
        m[y0:y1, x0:x1] = 1
    m[rng.random((h, w)) < 0.05] ^= 1
    return m


def polygon(h, w):
    n = int(rng.integers(3, 9))
    c = np.array([w / 2, h / 2]) + rng.normal(0, 2, 2)
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    rad = rng.uniform(2, min(h, w) / 1.5, n)
    pts = np.stack([c[0] + rad * np.cos(ang), c[1] + rad * np.sin(ang)], 1)
    return [round(float(v), 3) for v in pts.reshape(-1)]


videos = [
    {"id": 1, "width": 23, "height": 17, "length": 4, "file_names": [f"a/{i:05d}.jpg" for i in range(4)]},
    {"id": 2, "width": 31, "height": 12, "length": 3, "file_names": [f"b/{i:05d}.jpg" for i in range(3)]},
]
annotations = []
expected = []
ann_id = 1
for v in videos:
    h, w, n = v["height"], v["width"], v["length"]
    for kind in ["compressed", "uncompressed", "polygon", "multipolygon"]:
        segs, boxes, areas = [], [], []
        for f in range(n):
            if (f + ann_id) % 4 == 0:
                segs.append(None)
                boxes.append(None)
                areas.append(None)
                continue
            if kind == "compressed":
                m = blob(h, w)
                r = mu.encode(np.asfortranarray(m))
                seg = {"size": [h, w], "counts": r["counts"].decode()}
                rle = r
            elif kind == "uncompressed":
                m = blob(h, w)
                flat = m.flatten(order="F")
                counts, prev, run = [], 0, 0
                for px in flat:
                    if px != prev:
                        counts.append(run)
                        run, prev = 0, px
                    run += 1
                counts.append(run)
                seg = {"size": [h, w], "counts": counts}
                rle = mu.frPyObjects(seg, h, w)
            else:
                polys = [polygon(h, w)] if kind == "polygon" else [polygon(h, w), polygon(h, w)]
                seg = polys
                rle = mu.merge(mu.frPyObjects(polys, h, w))
            segs.append(seg)
            bbox = [float(x) for x in mu.toBbox(rle)]
            boxes.append(bbox)
            areas.append(float(mu.area(rle)))
            expected.append({
                "video_id": v["id"], "id": ann_id, "frame": f + 1,
                "counts": rle["counts"].decode() if isinstance(rle["counts"], bytes) else rle["counts"],
                "bbox": bbox, "area": int(mu.area(rle)),
            })
        annotations.append({
            "id": ann_id, "video_id": v["id"], "category_id": 1 + ann_id % 2, "iscrowd": 0,
            "segmentations": segs, "bboxes": boxes if kind != "multipolygon" else None, "areas": areas,
        })
        ann_id += 1

data = {"videos": videos, "annotations": annotations,
        "categories": [{"id": 1, "name": "cat"}, {"id": 2, "name": "dog"}]}
with open(os.path.join(here, "coco_video_pycocotools.json"), "w") as fp:
    json.dump(data, fp, indent=1)
with open(os.path.join(here, "coco_video_pycocotools_expected.json"), "w") as fp:
    json.dump(expected, fp, indent=1)
print(len(expected), "masks")
