#!/usr/bin/env python
"""Run OC-SORT (PyPI `ocsort` 0.0.2, the authors' code packaged by kadirnar) with its defaults
on a MOTChallenge det.txt and write MOT-format results, like ../shared/tools/peers/run_baseline.py
does for the other peers. Usage: ocsort_runner.py DET_TXT OUT_TXT

The package's `OCSort.update(dets, _)` expects torch tensors (it calls `.numpy()` on column
slices); a numpy array subclass whose `.numpy()` returns itself stands in, so no torch is
needed. `OCSort()` is called with no arguments: det_thresh 0.05, max_age 30, min_hits 3,
iou_threshold 0.3, delta_t 3, inertia 0.2. Prints frames, tracker-only wall time and FPS."""
import sys, time
import numpy as np
from ocsort.ocsort import OCSort


class Tensorish(np.ndarray):
    """A numpy array with torch's `.numpy()`."""

    def numpy(self):
        return np.asarray(self)


det_path, out_path = sys.argv[1:3]
d = np.loadtxt(det_path, delimiter=",", ndmin=2)
nframes = int(d[:, 0].max()) if len(d) else 0
trk = OCSort()
rows, t_total = [], 0.0
for f in range(1, nframes + 1):
    fd = d[d[:, 0] == f]
    dets = np.zeros((len(fd), 6))
    if len(fd):
        dets[:, 0:2] = fd[:, 2:4]
        dets[:, 2:4] = fd[:, 2:4] + fd[:, 4:6]
        dets[:, 4] = fd[:, 6]
    t0 = time.perf_counter()
    out = trk.update(dets.view(Tensorish), None)
    t_total += time.perf_counter() - t0
    # Rows: x1, y1, x2, y2, id, class, score (the package appends class and score).
    for r in out:
        x1, y1, x2, y2, tid = r[:5]
        score = r[6] if len(r) > 6 else 1.0
        rows.append((f, int(tid), x1, y1, x2 - x1, y2 - y1, score))
with open(out_path, "w") as fh:
    for r in rows:
        fh.write("%d,%d,%.2f,%.2f,%.2f,%.2f,%.4f,-1,-1,-1\n" % r)
print("ocsort frames=%d dets=%d out_rows=%d tracker_time=%.4fs FPS=%.1f"
      % (nframes, len(d), len(rows), t_total, nframes / t_total if t_total > 0 else float("inf")))
