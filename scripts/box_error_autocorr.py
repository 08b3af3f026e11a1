#!/usr/bin/env python3
"""How much a detector's box error persists from frame to frame, per sequence and coordinate.

  python3 scripts/box_error_autocorr.py [MOT_ROOT]     (default ../shared/data/mot15-train)

Each ground-truth box (considered, gt.txt column 7 ≠ 0) is matched to its frame's detection of
highest IoU (≥ 0.5) in det/det.txt; the error of the centre (x, y) and size (w, h) relative to
the ground-truth width or height is taken per object, its mean over the object removed, and
the lag-1 autocorrelation pooled over consecutive frames of every object with ≥ 10 matches.
Independent errors give 0; the synthetic detector models of `src/grid/detector.rs` draw them
that way. The ground truth has smooth errors of its own (interpolated boxes), which this
counts as the detector's: read the figures as an upper bound. Only the standard library.
"""
import collections, os, statistics, sys


def load(path):
    frames = collections.defaultdict(list)
    for line in open(path):
        f = line.strip().split(",")
        if len(f) >= 7:
            frames[int(float(f[0]))].append((int(float(f[1])), *map(float, f[2:7])))
    return frames


def iou(a, b):
    x1, y1 = max(a[0], b[0]), max(a[1], b[1])
    x2, y2 = min(a[0] + a[2], b[0] + b[2]), min(a[1] + a[3], b[1] + b[3])
    i = max(0.0, x2 - x1) * max(0.0, y2 - y1)
    u = a[2] * a[3] + b[2] * b[3] - i
    return i / u if u > 0 else 0.0


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "mot15-train")
    every = []
    print("sequence            centre-x centre-y    width   height")
    for seq in sorted(os.listdir(root)):
        gt_path, det_path = (os.path.join(root, seq, d) for d in ("gt/gt.txt", "det/det.txt"))
        if not (os.path.isfile(gt_path) and os.path.isfile(det_path)):
            continue
        gt, det = load(gt_path), load(det_path)
        errors = collections.defaultdict(dict)  # object -> frame -> (cx, cy, w, h)
        for frame, objects in gt.items():
            for obj, x, y, w, h, considered in objects:
                if considered == 0 or w <= 0 or h <= 0:
                    continue
                g = (x, y, w, h)
                best = max(det.get(frame, []), key=lambda d: iou(g, d[1:5]), default=None)
                if best is None or iou(g, best[1:5]) < 0.5:
                    continue
                dx, dy, dw, dh = best[1:5]
                errors[obj][frame] = (
                    (dx + dw / 2 - x - w / 2) / w,
                    (dy + dh / 2 - y - h / 2) / h,
                    (dw - w) / w,
                    (dh - h) / h,
                )
        row = []
        for c in range(4):
            num = den = 0.0
            for e in errors.values():
                if len(e) < 10:
                    continue
                m = statistics.mean(v[c] for v in e.values())
                den += sum((v[c] - m) ** 2 for v in e.values())
                num += sum((e[f][c] - m) * (e[f + 1][c] - m) for f in e if f + 1 in e)
            row.append(num / den if den else float("nan"))
        every += row
        print(f"{seq:18}" + "".join(f"{r:9.2f}" for r in row))
    print(f"median over sequences and coordinates: {statistics.median(every):.2f}")


if __name__ == "__main__":
    main()
