#!/usr/bin/env python3
"""Random search that chose the tracker's default Config (round 3 of 3, see README.md).

Prints one JSON config per line: `python3 search.py > configs.jsonl`, then
`tune.py train configs.jsonl` ranks them on the six training sequences. Seeded, so the list is
reproducible. Keys not sampled take the Config defaults; the re-identification stage is either
off or IoU-with-last-box at a sampled gate.
"""
import json
import random

random.seed(6)
OFF = {k: {"weight": 0} for k in
       ("iou", "last_iou", "centre", "size", "shape_context", "colour", "mask_iou")}
SPACE = {
    "motion.std_velocity": [0.0075, 0.01, 0.0125, 0.015],
    "motion.std_position": [0.02, 0.025, 0.035],
    "motion.std_measurement": [0.04, 0.05, 0.06, 0.075],
    "min_hits": [4, 5, 6],
    "new_track_score": [0.8, 0.85, 0.9, 0.95],
    "high_score": [0.6, 0.7, 0.8],
    "max_lost": [15, 20, 30, 45],
    "max_cost": [0.7, 0.75],
    "max_cost_low": [0.5, 0.6],
    "max_cost_tentative": [0.6, 0.7],
    "lost_second": [True, False],
    "unmatched_cost": [None, 0.45],
    "reid": [None, 0.5, 0.6],
}
for _ in range(100):
    c = {"motion": {}}
    for k, vs in SPACE.items():
        v = random.choice(vs)
        if k.startswith("motion."):
            c["motion"][k[7:]] = v
        elif k == "reid":
            r = dict(OFF)
            if v is not None:
                r["last_iou"] = {"weight": 1}
                c["reid_max_cost"] = v
            c["reid_terms"] = r
        else:
            c[k] = v
    print(json.dumps(c))
