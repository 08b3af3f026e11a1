#!/usr/bin/env python
"""Makes the TrackEval reference fixtures under tests/data/eval/ (run from anywhere):

    /work/peers/venv/bin/python tests/data/eval/make_fixtures.py

Each case is a TrackEval layout plus TrackEval's own figures:
  <case>/gt/<BENCH>-train/<seq>/{gt/gt.txt,seqinfo.ini}, <case>/gt/seqmaps/<BENCH>-train.txt
  <case>/trackers/<BENCH>-train/test/data/<seq>.txt
  <case>/expected.json  {"benchmark", "masks", "sequences": {seq: row}, "combined": row}
Rows hold every summary field of TrackEval's HOTA, CLEAR, Identity and Count metrics, with
ratios in percent (HOTA-family averaged over alpha) and counts as integers, the way
`shapetrack eval --json` writes them.

Cases:
  mot17  MOT17 rules: distractor classes (2, 7, 8, 12), non-pedestrian classes (3, 6), zero-marked
         rows, boxes exactly at IoU 0.5, id switches, misses and false positives.
  mot20  the same data under MOT20 rules (class 6, non-MOT vehicle, becomes a distractor).
  mots   MOTSChallenge: RLE masks from numpy + pycocotools, cars (class 1) filtered out,
         class-10 ignore regions that swallow unmatched tracker masks.
  nonmonotone  MOT15 rules: two pairs of sequences showing that TrackEval's recall is not
         monotone in the tracker's rows: removing one row raises CLEAR recall (clear-removed vs
         clear-full, via IDSW-avoiding matching) and DetRe (hota-removed vs hota-full, via the
         global alignment score).
  edge   MOT15 rules: an empty tracker, gt with empty frames, no gt at all, ids that appear,
         vanish and come back, and a sequence with nothing in it.
Seeds are fixed, so the output is reproducible. Needs TrackEval, numpy and pycocotools.
"""
import json
import os
import shutil
import sys

import numpy as np

for _a, _t in (("float", float), ("int", int), ("bool", bool)):
    if not hasattr(np, _a):
        setattr(np, _a, _t)
import trackeval  # noqa: E402
from pycocotools import mask as mask_utils  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def write(path, text):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write(text)


def layout(case, bench, seqs, size=(640, 480)):
    """seqs: {name: (num_frames, gt_lines, tracker_lines)} -> writes the TrackEval layout;
    size: the seqinfo's imWidth, imHeight."""
    root = os.path.join(HERE, case)
    shutil.rmtree(root, ignore_errors=True)
    for name, (n, gt, tr) in seqs.items():
        d = os.path.join(root, "gt", bench + "-train", name)
        write(os.path.join(d, "gt", "gt.txt"), "".join(l + "\n" for l in gt))
        write(os.path.join(d, "seqinfo.ini"),
              "[Sequence]\nname=%s\nimDir=img1\nframeRate=25\nseqLength=%d\nimWidth=%d\n"
              "imHeight=%d\nimExt=.jpg\n" % (name, n, size[0], size[1]))
        write(os.path.join(root, "trackers", bench + "-train", "test", "data", name + ".txt"),
              "".join(l + "\n" for l in tr))
    write(os.path.join(root, "gt", "seqmaps", bench + "-train.txt"),
          "name\n" + "".join(s + "\n" for s in seqs))
    return root


def run_trackeval(root, bench, masks):
    ec = trackeval.Evaluator.get_default_eval_config()
    ec.update({"USE_PARALLEL": False, "PLOT_CURVES": False, "PRINT_CONFIG": False,
               "OUTPUT_DETAILED": False, "OUTPUT_SUMMARY": False, "PRINT_RESULTS": False,
               "LOG_ON_ERROR": None, "TIME_PROGRESS": False})
    if masks:
        dc = trackeval.datasets.MOTSChallenge.get_default_dataset_config()
        dc.update({"GT_FOLDER": os.path.join(root, "gt"),
                   "TRACKERS_FOLDER": os.path.join(root, "trackers"),
                   "SPLIT_TO_EVAL": "train", "TRACKERS_TO_EVAL": ["test"], "PRINT_CONFIG": False})
        ds = trackeval.datasets.MOTSChallenge(dc)
    else:
        dc = trackeval.datasets.MotChallenge2DBox.get_default_dataset_config()
        dc.update({"GT_FOLDER": os.path.join(root, "gt"),
                   "TRACKERS_FOLDER": os.path.join(root, "trackers"), "BENCHMARK": bench,
                   "SPLIT_TO_EVAL": "train", "TRACKERS_TO_EVAL": ["test"], "PRINT_CONFIG": False})
        ds = trackeval.datasets.MotChallenge2DBox(dc)
    mc = {"METRICS": ["HOTA", "CLEAR", "Identity"], "THRESHOLD": 0.5, "PRINT_CONFIG": False}
    metrics = [trackeval.metrics.HOTA(mc), trackeval.metrics.CLEAR(mc),
               trackeval.metrics.Identity(mc)]  # the Evaluator adds Count itself
    res, _ = trackeval.Evaluator(ec).evaluate([ds], metrics)
    out = {}
    for seq, v in res[ds.get_name()]["test"].items():
        p = v["pedestrian"]
        h, c, i, n = p["HOTA"], p["CLEAR"], p["Identity"], p["Count"]
        row = {}
        for k in ["HOTA", "DetA", "AssA", "LocA", "DetRe", "DetPr", "AssRe", "AssPr", "OWTA"]:
            row[k] = 100 * float(np.mean(h[k]))
        for k in ["HOTA(0)", "LocA(0)", "HOTALocA(0)"]:
            row[k] = 100 * float(h[k])
        for k in ["MOTA", "MOTP", "MODA", "sMOTA", "MOTAL", "CLR_Re", "CLR_Pr", "CLR_F1", "MTR",
                  "PTR", "MLR"]:
            row[k] = 100 * float(c[k])
        row["FP_per_frame"] = float(c["FP_per_frame"])
        for k in ["IDF1", "IDP", "IDR"]:
            row[k] = 100 * float(i[k])
        for ours, theirs in [("CLR_TP", "CLR_TP"), ("FN", "CLR_FN"), ("FP", "CLR_FP"),
                             ("IDSW", "IDSW"), ("Frag", "Frag"), ("MT", "MT"), ("PT", "PT"),
                             ("ML", "ML"), ("CLR_Frames", "CLR_Frames")]:
            row[ours] = int(c[theirs])
        for k in ["IDTP", "IDFN", "IDFP"]:
            row[k] = int(i[k])
        for k in ["Dets", "GT_Dets", "IDs", "GT_IDs"]:
            row[k] = int(n[k])
        out[seq] = row
    combined = out.pop("COMBINED_SEQ")
    return {"benchmark": bench, "masks": masks, "sequences": out, "combined": combined}


def save_expected(root, data):
    write(os.path.join(root, "expected.json"), json.dumps(data, indent=1, sort_keys=True) + "\n")


def f2(v):
    return "%.2f" % v


def box_case(rng, n_frames, n_peds, classes_extra):
    """A MOT16+-style sequence: pedestrians and other classes moving, tracker = noisy gt."""
    objs = []
    oid = 1
    for k in range(n_peds + len(classes_extra)):
        cls = 1 if k < n_peds else classes_extra[k - n_peds]
        start = int(rng.integers(1, n_frames // 2))
        end = int(rng.integers(start + 5, n_frames + 1))
        objs.append(dict(id=oid, cls=cls, start=start, end=end,
                         x=float(rng.uniform(0, 500)), y=float(rng.uniform(0, 300)),
                         vx=float(rng.uniform(-4, 4)), vy=float(rng.uniform(-2, 2)),
                         w=float(rng.uniform(20, 60)), h=float(rng.uniform(50, 150))))
        oid += 1
    gt, tr = [], []
    next_tid = 100
    tid_of = {}
    for f in range(1, n_frames + 1):
        for o in objs:
            if not (o["start"] <= f <= o["end"]):
                continue
            x = o["x"] + o["vx"] * (f - o["start"])
            y = o["y"] + o["vy"] * (f - o["start"])
            # A few pedestrian rows are zero-marked (conf 0), like MOT17's occluded people.
            conf = 0 if (o["cls"] == 1 and rng.random() < 0.08) else 1
            gt.append(",".join([str(f), str(o["id"]), f2(x), f2(y), f2(o["w"]), f2(o["h"]),
                                str(conf), str(o["cls"]), f2(rng.uniform(0, 1))]))
            if rng.random() < 0.15:
                continue  # missed
            if o["id"] not in tid_of or rng.random() < 0.04:
                tid_of[o["id"]] = next_tid  # new track or an id switch
                next_tid += 1
            if rng.random() < 0.05:
                # Exactly IoU 0.5: same corner and width, double height.
                tx, ty, tw, th = x, y, o["w"], 2 * o["h"]
                tx, ty, tw, th = float(f2(tx)), float(f2(ty)), float(f2(tw)), 2 * float(f2(o["h"]))
            else:
                tx = x + rng.normal(0, 4)
                ty = y + rng.normal(0, 4)
                tw = o["w"] * rng.uniform(0.85, 1.15)
                th = o["h"] * rng.uniform(0.85, 1.15)
            tr.append(",".join([str(f), str(tid_of[o["id"]]), f2(tx), f2(ty), f2(tw), f2(th),
                                f2(rng.uniform(0.3, 1)), "-1", "-1", "-1"]))
        for _ in range(int(rng.integers(0, 3))):
            tr.append(",".join([str(f), str(next_tid), f2(rng.uniform(0, 600)),
                                f2(rng.uniform(0, 400)), f2(rng.uniform(20, 60)),
                                f2(rng.uniform(50, 150)), "0.5", "1", "-1", "-1"]))
            next_tid += 1
    return gt, tr


def mot17_cases():
    rng = np.random.default_rng(17)
    seqs = {}
    seqs["MOT17-A"] = (40,) + box_case(rng, 40, 6, [2, 7, 8, 12, 3, 6])
    seqs["MOT17-B"] = (30,) + box_case(rng, 30, 4, [7, 12, 6, 6, 13])
    for case, bench in (("mot17", "MOT17"), ("mot20", "MOT20")):
        renamed = {s.replace("MOT17", bench): v for s, v in seqs.items()}
        root = layout(case, bench, renamed)
        save_expected(root, run_trackeval(root, bench, False))


def rle_line(frame, oid, cls, m):
    r = mask_utils.encode(np.asfortranarray(m.astype(np.uint8)))
    return "%d %d %d %d %d %s" % (frame, oid, cls, m.shape[0], m.shape[1],
                                  r["counts"].decode("ascii"))


def mots_case():
    rng = np.random.default_rng(5)
    H, W, n = 48, 64, 12
    objs = []
    for k in range(6):
        cls = 2 if k < 4 else 1
        objs.append(dict(id=cls * 1000 + k + 1, cls=cls, start=int(rng.integers(1, 4)),
                         end=int(rng.integers(8, n + 1)), x=int(rng.integers(0, 50)),
                         y=int(rng.integers(0, 36)), vx=int(rng.integers(-1, 2)),
                         vy=int(rng.integers(-1, 2)), w=int(rng.integers(5, 12)),
                         h=int(rng.integers(6, 14))))
    gt, tr = [], []
    next_tid = 1
    tid_of = {}
    for f in range(1, n + 1):
        # Label images keep masks disjoint, as MOTS requires.
        glab = np.zeros((H, W), np.int32)
        tlab = np.zeros((H, W), np.int32)
        ignore = np.zeros((H, W), bool)
        ignore[0:10, 44:64] = True  # a fixed crowd region at the top right
        if f % 3 == 0:
            ignore[38:48, 0:12] = True  # and another every third frame
        gmeta, tmeta = {}, {}
        for o in objs:
            if not (o["start"] <= f <= o["end"]):
                continue
            x = min(max(o["x"] + o["vx"] * f, 0), W - o["w"])
            y = min(max(o["y"] + o["vy"] * f, 0), H - o["h"])
            region = np.zeros((H, W), bool)
            region[y:y + o["h"], x:x + o["w"]] = True
            region &= (glab == 0) & ~ignore
            if region.sum() == 0:
                continue
            glab[region] = o["id"]
            gmeta[o["id"]] = o["cls"]
            if rng.random() < 0.15:
                continue
            if o["id"] not in tid_of or rng.random() < 0.08:
                tid_of[o["id"]] = next_tid
                next_tid += 1
            dx, dy = int(rng.integers(-1, 2)), int(rng.integers(-1, 2))
            t = np.zeros((H, W), bool)
            y2, x2 = max(y + dy, 0), max(x + dx, 0)
            t[y2:y2 + o["h"], x2:x2 + o["w"]] = True
            t &= tlab == 0
            if t.sum() == 0:
                continue
            tid = tid_of[o["id"]]
            tlab[t] = tid
            tmeta[tid] = o["cls"]  # the tracker reports the class too
        # False positives: some inside the ignore region (removed), some outside (kept).
        for box in ([2, 46, 6, 8], [30, 20, 5, 5]) if f % 2 == 0 else ([1, 50, 5, 5],):
            y, x, h, w = box
            t = np.zeros((H, W), bool)
            t[y:y + h, x:x + w] = True
            t &= tlab == 0
            if t.sum():
                tlab[t] = next_tid
                tmeta[next_tid] = 2
                next_tid += 1
        for oid, cls in sorted(gmeta.items()):
            gt.append(rle_line(f, oid, cls, glab == oid))
        if ignore.any():
            gt.append(rle_line(f, 10000, 10, ignore & (glab == 0)))
        for tid, cls in sorted(tmeta.items()):
            tr.append(rle_line(f, tid, cls, tlab == tid))
    # TrackEval ignores a MOTS seqinfo's size, but shapetrack eval refuses masks of another
    # size than the sequence's (issue 65): the seqinfo says the masks' size.
    root = layout("mots", "MOTS", {"MOTS-01": (n, gt, tr)}, size=(W, H))
    save_expected(root, run_trackeval(root, "MOTS", True))


def edge_case():
    rng = np.random.default_rng(3)
    seqs = {}
    gt, tr = box_case(rng, 20, 3, [])
    seqs["empty-tracker"] = (20, gt, [])
    # Gt only in some frames; the tracker also reports in frames without gt.
    gt, tr = box_case(rng, 25, 3, [])
    gt = [l for l in gt if int(l.split(",")[0]) % 4 != 0]
    seqs["gt-gaps"] = (25, gt, tr)
    gt, tr = box_case(rng, 15, 2, [])
    seqs["no-gt"] = (15, [], tr)
    # Flicker: tracker ids appear for a frame or two, vanish and come back; ids reused.
    gt, tr = box_case(rng, 30, 4, [])
    flick = []
    for l in tr:
        p = l.split(",")
        f, tid = int(p[0]), int(p[1])
        if (f // 3 + tid) % 3 == 0:
            continue
        if f % 7 == 0:
            p[1] = str(tid % 3 + 100)  # reuse a small pool of ids, which swaps identities
            if any(q.split(",")[0] == p[0] and q.split(",")[1] == p[1] for q in flick):
                continue
        flick.append(",".join(p))
    seqs["flicker"] = (30, gt, flick)
    seqs["nothing"] = (5, [], [])
    root = layout("edge", "MOT15", seqs)
    save_expected(root, run_trackeval(root, "MOT15", False))


def nonmonotone_case():
    def row(f, i, x):
        return "%d,%d,%s,0,10,10,1,-1,-1,-1" % (f, i, x)
    # CLEAR: frame 1 matches g1-T (IoU .905) over V (.538); in frame 2 the continuation g1-T
    # (1000.905) beats g1-U + g2-T (1.44), one match. Without T in frame 1, g1 continues with V,
    # which is absent in frame 2, so both gts match: recall rises.
    clear_gt = [row(1, 1, "0"), row(2, 1, "0"), row(2, 2, "1")]
    clear_tr = [row(1, 1, "0.5"), row(1, 2, "-3"), row(2, 1, "0.5"), row(2, 3, "-3")]
    # HOTA: g1 and T coincide for 4 frames, so their alignment is high; in frame 5 the weak
    # g1-T (IoU .33) beats g1-U (IoU .67) because U's alignment is low. Without T in frame 5,
    # g1-U matches and DetRe rises.
    hota_gt = [row(f, 1, "0") for f in range(1, 6)]
    hota_tr = [row(f, 1, "0") for f in range(1, 5)] + [row(5, 1, "5"), row(5, 2, "2")]
    seqs = {"clear-full": (2, clear_gt, clear_tr),
            "clear-removed": (2, clear_gt, clear_tr[1:]),
            "hota-full": (5, hota_gt, hota_tr),
            "hota-removed": (5, hota_gt, hota_tr[:4] + hota_tr[5:])}
    root = layout("nonmonotone", "MOT15", seqs)
    save_expected(root, run_trackeval(root, "MOT15", False))


if __name__ == "__main__":
    nonmonotone_case()
    mot17_cases()
    mots_case()
    edge_case()
    print("fixtures written to", HERE, file=sys.stderr)
