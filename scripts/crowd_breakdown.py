#!/usr/bin/env python3
"""Where identities break in a crowd (issue 64, item 2): every ID switch and every fragment of a
tracker's output, with what the ground truth looked like around it.

    python3 scripts/crowd_breakdown.py --cell DIR [--tracker ours-online] [--json OUT.json]

DIR is a prepared grid cell (`shapetrack grid prepare` + `grid run`, or scripts/grid.py):
gt/MOT15-train/<seq>/gt/gt.txt (visibility in column 9), det/<seq>.txt and
trackers/MOT15-train/<tracker>/data/<seq>.txt. Matching is CLEAR MOT's: per frame, last
frame's pairs are kept while their IoU stays ≥ 0.5, the rest assigned by maximum IoU (scipy's
Hungarian when installed, else greedy). Gt boxes of visibility 0 are skipped, as the grid's
evaluation does not score them either.

For an **ID switch** (a gt object matched to another output id than at its last match) it
records the gap (frames unmatched in between), the visibility at the last match and its
minimum in the gap, the neighbours (other visible gt whose centre lies within one box width of
the object's), whether the new id was born within 3 frames (a **rebirth**: the old track was
not re-found) or already followed another object (a **steal**). For a **fragment** (matched,
then unmatched while the gt is visible) it records the gap and whether a detection overlapped
the object (IoU ≥ 0.5) in the gap (**tracker miss**) or none did (**detector miss**).
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import sys

import numpy as np


def read_mot(path: str, gt: bool = False) -> dict:
    """frame -> list of (id, x, y, w, h, vis)."""
    out = collections.defaultdict(list)
    with open(path) as f:
        for ln in f:
            p = ln.strip().split(",")
            if len(p) < 6:
                continue
            vis = float(p[8]) if gt and len(p) > 8 else 1.0
            if gt and (len(p) > 6 and float(p[6]) == 0):
                continue
            out[int(float(p[0]))].append((int(float(p[1])), *map(float, p[2:6]), vis))
    return out


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    if len(a) == 0 or len(b) == 0:
        return np.zeros((len(a), len(b)))
    ax2, ay2 = a[:, 0] + a[:, 2], a[:, 1] + a[:, 3]
    bx2, by2 = b[:, 0] + b[:, 2], b[:, 1] + b[:, 3]
    iw = np.clip(np.minimum(ax2[:, None], bx2[None]) - np.maximum(a[:, None, 0], b[None, :, 0]), 0, None)
    ih = np.clip(np.minimum(ay2[:, None], by2[None]) - np.maximum(a[:, None, 1], b[None, :, 1]), 0, None)
    inter = iw * ih
    union = (a[:, 2] * a[:, 3])[:, None] + (b[:, 2] * b[:, 3])[None] - inter
    return inter / np.maximum(union, 1e-9)


def assign(score: np.ndarray) -> list:
    """Maximum-weight pairs with IoU ≥ 0.5."""
    if score.size == 0:
        return []
    try:
        from scipy.optimize import linear_sum_assignment

        r, c = linear_sum_assignment(-score)
        return [(i, j) for i, j in zip(r, c) if score[i, j] >= 0.5]
    except ImportError:
        pairs, used_r, used_c = [], set(), set()
        for k in np.argsort(-score, axis=None):
            i, j = divmod(int(k), score.shape[1])
            if score[i, j] < 0.5:
                break
            if i not in used_r and j not in used_c:
                pairs.append((i, j))
                used_r.add(i)
                used_c.add(j)
        return pairs


def analyse(gt: dict, res: dict, det: dict, frames: int) -> tuple[list, list]:
    last_pred = {}  # gt id -> (pred id, frame of last match)
    prev_pairs = {}  # gt id -> pred id matched in the previous frame
    first_seen = {}  # pred id -> first frame
    pred_gt = {}  # pred id -> gt id at its last match
    gt_at = {}  # (frame, gt id) -> (box, vis)
    switches, fragments = [], []
    open_frag = {}  # gt id -> fragment dict while unmatched
    for t in range(1, frames + 1):
        g = [r for r in gt.get(t, []) if r[5] > 0]
        p = res.get(t, [])
        for r in p:
            first_seen.setdefault(r[0], t)
        for r in g:
            gt_at[(t, r[0])] = (np.array(r[1:5]), r[5])
        gb = np.array([r[1:5] for r in g]).reshape(-1, 4)
        pb = np.array([r[1:5] for r in p]).reshape(-1, 4)
        s = iou_matrix(gb, pb)
        gi = {r[0]: i for i, r in enumerate(g)}
        pj = {r[0]: j for j, r in enumerate(p)}
        pairs = []
        for gid, pid in prev_pairs.items():
            if gid in gi and pid in pj and s[gi[gid], pj[pid]] >= 0.5:
                pairs.append((gi[gid], pj[pid]))
        kept_r = {i for i, _ in pairs}
        kept_c = {j for _, j in pairs}
        rest = s.copy()
        for i in kept_r:
            rest[i, :] = 0
        for j in kept_c:
            rest[:, j] = 0
        pairs += assign(rest)
        matched = {}
        for i, j in pairs:
            matched[g[i][0]] = p[j][0]
        db = np.array([r[1:5] for r in det.get(t, [])]).reshape(-1, 4)
        dcov = iou_matrix(gb, db).max(axis=1) if len(db) else np.zeros(len(g))
        for i, r in enumerate(g):
            gid = r[0]
            if gid in matched:
                pid = matched[gid]
                if gid in open_frag:
                    fr = open_frag.pop(gid)
                    fr["gap"] = t - fr["frame"]
                    fragments.append(fr)
                if gid in last_pred and last_pred[gid][0] != pid:
                    lp, lt = last_pred[gid]
                    box, vis = gt_at[(lt, gid)]
                    gap_vis = [gt_at[(k, gid)][1] for k in range(lt + 1, t) if (k, gid) in gt_at]
                    c = box[:2] + box[2:] / 2
                    nb = 0
                    for k2, (ob, ov) in ((k[1], v) for k, v in gt_at.items() if k[0] == lt and k[1] != gid):
                        if ov > 0 and np.linalg.norm(ob[:2] + ob[2:] / 2 - c) < box[2]:
                            nb += 1
                    switches.append(
                        {
                            "frame": t,
                            "gt": gid,
                            "gap": t - lt - 1,
                            "vis_before": round(float(vis), 3),
                            "vis_min_gap": round(float(min(gap_vis)), 3) if gap_vis else None,
                            "neighbours": nb,
                            "kind": "rebirth" if t - first_seen[pid] <= 3 else "steal",
                            "old_alive": any(r2[0] == lp for r2 in p),
                            # Whom the new id followed before: another object (a swap in
                            # the crowd) or nobody (a track that coasted or was born here).
                            "from_other": pred_gt.get(pid) not in (None, gid),
                            "height": round(float(box[3]), 1),
                        }
                    )
                last_pred[gid] = (pid, t)
                pred_gt[pid] = gid
            elif gid in last_pred and last_pred[gid][1] == t - 1 and gid not in open_frag:
                open_frag[gid] = {
                    "frame": t,
                    "gt": gid,
                    "vis": round(float(r[5]), 3),
                    "detected": False,
                    "gap": None,
                }
            if gid in open_frag and dcov[i] >= 0.5:
                open_frag[gid]["detected"] = True
        prev_pairs = matched
    for fr in open_frag.values():
        fr["gap"] = frames + 1 - fr["frame"]
        fragments.append(fr)
    return switches, fragments


def bucket(v, edges, labels):
    for e, lab in zip(edges, labels):
        if v <= e:
            return lab
    return labels[-1]


def table(rows: list, key, labels: list, title: str) -> str:
    c = collections.Counter(key(r) for r in rows)
    n = max(len(rows), 1)
    return f"{title}: " + ", ".join(f"{lab} {c[lab]} ({100 * c[lab] / n:.0f}%)" for lab in labels)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cell", required=True)
    ap.add_argument("--tracker", default="ours-online")
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    gtroot = os.path.join(a.cell, "gt", "MOT15-train")
    all_sw, all_fr = [], []
    for seq in sorted(os.listdir(gtroot)):
        gpath = os.path.join(gtroot, seq, "gt", "gt.txt")
        if not os.path.isfile(gpath):
            continue
        gt = read_mot(gpath, gt=True)
        res = read_mot(os.path.join(a.cell, "trackers", "MOT15-train", a.tracker, "data", f"{seq}.txt"))
        det = read_mot(os.path.join(a.cell, "det", f"{seq}.txt"))
        frames = max(max(gt), max(res, default=0))
        sw, fr = analyse(gt, res, det, frames)
        for r in sw + fr:
            r["seq"] = seq
        all_sw += sw
        all_fr += fr
    gl = ["0", "1-2", "3-5", "6-10", "11-25", ">25"]
    ge = [0, 2, 5, 10, 25, 10**9]
    vl = ["<0.2", "0.2-0.4", "0.4-0.6", "0.6-0.8", ">=0.8"]
    ve = [0.2, 0.4, 0.6, 0.8, 1.01]
    print(f"{a.cell} {a.tracker}: {len(all_sw)} ID switches, {len(all_fr)} fragments")
    print(table(all_sw, lambda r: bucket(r["gap"], ge, gl), gl, "switches by gap"))
    print(table(all_sw, lambda r: bucket(r["vis_before"] - 1e-9, ve, vl), vl, "switches by visibility before"))
    print(table(all_sw, lambda r: str(min(r["neighbours"], 3)).replace("3", "3+"), ["0", "1", "2", "3+"], "switches by neighbours"))
    print(table(all_sw, lambda r: r["kind"], ["rebirth", "steal"], "switches by kind"))
    print(table(all_sw, lambda r: "old alive" if r["old_alive"] else "old gone", ["old alive", "old gone"], "the old id at the switch"))
    print(table(all_sw, lambda r: "from another object" if r["from_other"] else "from nobody", ["from another object", "from nobody"], "the new id before"))
    print(table(all_fr, lambda r: bucket(r["gap"], ge, gl), gl, "fragments by gap"))
    print(table(all_fr, lambda r: "detector miss" if not r["detected"] else "tracker miss", ["detector miss", "tracker miss"], "fragments by cause"))
    print(table(all_fr, lambda r: bucket(r["vis"] - 1e-9, ve, vl), vl, "fragments by visibility at the break"))
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"switches": all_sw, "fragments": all_fr}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
