#!/usr/bin/env python3
"""Separability study (issue 64, depth order / amodal completion): does a per-sequence
statistic computed from same-frame overlapping detection pairs tell a visible-part box
detector (synthetic pedestrian crowd) from amodal boxes with noise (MOT15, BDD, SportsMOT)?

Usage (the grid's cells first, then the study; numpy and scipy, e.g. the python/ venv):

    shapetrack grid prepare --datasets synth --cells 'synth-pedestrians/*,synth-occluders/*' --out G
    shapetrack grid prepare --datasets mot15,bdd,sportsmot --out G
    python scripts/cut_box_study.py G --out results.json [--noid-only] [--frames N]
        [--score-min S] [--fhi F] [--cells pat,...]

The statistic the tracker took (`track::cut_views`, setting `complete_cut_boxes`) is the
identity-free `A_hi_p25` of `seq_noid` / `stats_noid`; the figures are in
tests/data/quality/README.md, "Completing cut boxes".

Per sequence, per identity (either from ground truth, only to attach ids, or from a simple
IoU linker that needs no ground truth), the reference size is the median det height / width
over the frames where the det overlaps no other kept det. For every same-frame pair of
intersecting dets with references, the nearer one A has the larger *expected* bottom
(y1 + reference height: what a track's prediction gives, robust to a cut-off bottom); B is
the other. B's expected full box: top kept, reference height; horizontally its box widened
to the reference width towards A's side. Then
  f   = |A ∩ B_full| / |B_full|      expected covered fraction of B
  ov  = |A ∩ B_det|  / |B_det|       actual covered fraction of B's det box
  rh  = h_B / ref_h(B), rw, ra = area / ref area; the same for A (control)
Occluded pairs: f >= 0.3.
"""
import sys, os, glob, json, math, argparse, fnmatch
import numpy as np
from scipy.optimize import linear_sum_assignment


def load_txt(path):
    rows = []
    with open(path) as fh:
        for line in fh:
            p = line.strip().split(',')
            if len(p) < 7:
                continue
            rows.append([float(v) for v in p[:9]] + [0.0] * (9 - min(9, len(p))))
    a = np.array(rows, dtype=float) if rows else np.zeros((0, 9))
    return a


def iou_mat(a, b):
    # a: n x 4 (x1,y1,x2,y2), b: m x 4
    ix1 = np.maximum(a[:, None, 0], b[None, :, 0])
    iy1 = np.maximum(a[:, None, 1], b[None, :, 1])
    ix2 = np.minimum(a[:, None, 2], b[None, :, 2])
    iy2 = np.minimum(a[:, None, 3], b[None, :, 3])
    inter = np.clip(ix2 - ix1, 0, None) * np.clip(iy2 - iy1, 0, None)
    aa = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    ab = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    union = aa[:, None] + ab[None, :] - inter
    return inter / np.maximum(union, 1e-9), inter, aa, ab


def inter_area(p, q):
    w = min(p[2], q[2]) - max(p[0], q[0])
    h = min(p[3], q[3]) - max(p[1], q[1])
    return max(w, 0.0) * max(h, 0.0)


def det_threshold(scores):
    if len(scores) == 0:
        return 0.0
    return min(0.5, float(np.percentile(scores, 40)))


def ids_from_gt(frames_det, frames_gt):
    """Attach a gt id to each det (analysis only): det mostly inside the gt box
    (ioa_det >= 0.7) and IoU >= 0.1, Hungarian on IoU."""
    ids = {}
    for fr, D in frames_det.items():
        G = frames_gt.get(fr)
        out = np.full(len(D), -1, dtype=int)
        if G is not None and len(G) and len(D):
            iou, inter, ad, ag = iou_mat(D[:, :4], G[:, 1:5])
            ioa = inter / np.maximum(ad[:, None], 1e-9)
            ok = (ioa >= 0.7) & (iou >= 0.1)
            cost = np.where(ok, -iou, 1.0)
            r, c = linear_sum_assignment(cost)
            for i, j in zip(r, c):
                if ok[i, j]:
                    out[i] = int(G[j, 0])
        ids[fr] = out
    return ids


def ids_from_linker(frames_det, max_gap=5, thr=0.25):
    """Simple online IoU linker (no gt): each live track (seen within max_gap frames)
    predicts its box by constant velocity of its last two views; a det continues the
    track it overlaps most (IoU >= thr, Hungarian); otherwise it starts a new track."""
    ids = {}
    tracks = {}  # id -> (last_frame, box, velocity per frame)
    nxt = 0
    for fr in sorted(frames_det):
        D = frames_det[fr]
        live = [t for t, (lf, _, _) in tracks.items() if fr - lf <= max_gap]
        out = np.full(len(D), -1, dtype=int)
        if live and len(D):
            T = np.array([tracks[t][1] + tracks[t][2] * (fr - tracks[t][0]) for t in live])
            iou, _, _, _ = iou_mat(D[:, :4], T)
            cost = np.where(iou >= thr, -iou, 1.0)
            r, c = linear_sum_assignment(cost)
            for i, j in zip(r, c):
                if iou[i, j] >= thr:
                    out[i] = live[j]
        for i in range(len(D)):
            if out[i] < 0:
                out[i] = nxt
                nxt += 1
                tracks[out[i]] = (fr, D[i, :4].copy(), np.zeros(4))
            else:
                lf, lb, v = tracks[out[i]]
                nv = (D[i, :4] - lb) / (fr - lf)
                tracks[out[i]] = (fr, D[i, :4].copy(), 0.5 * v + 0.5 * nv)
        ids[fr] = out
    return ids


def seq_dets(frames_det, ids, min_views=8, pct=80, ref=None):
    """Per det with an identity of >= min_views dets: its size against the identity's
    reference (the pct-th percentile of its dets' heights / widths: near the whole view for
    a visible-part detector, a bit above the mean for noisy whole boxes), and how much of
    its expected whole box (top kept, reference height; widened to the reference width
    towards the occluder) the nearer dets' boxes cover. Depth: the expected bottom
    y1 + ref_h, larger = nearer (what a track's prediction gives)."""
    hs, ws = {}, {}
    for fr, D in frames_det.items():
        for k in range(len(D)):
            i = ids[fr][k]
            if i >= 0:
                hs.setdefault(i, []).append(D[k, 3] - D[k, 1])
                ws.setdefault(i, []).append(D[k, 2] - D[k, 0])
    if ref is None:
        ref = {i: (float(np.percentile(hs[i], pct)), float(np.percentile(ws[i], pct)))
               for i in hs if len(hs[i]) >= min_views}
    out = []  # rh, rw, ra, f, ov_over_f, cut(bottom or side at the occluder's edge)
    for fr, D in frames_det.items():
        idx = [k for k in range(len(D)) if ids[fr][k] in ref]
        if not idx:
            continue
        R = {k: ref[ids[fr][k]] for k in idx}
        eb = {k: D[k, 1] + R[k][0] for k in idx}
        for b in idx:
            B = D[b, :4]; hB, wB = B[3] - B[1], B[2] - B[0]
            rh, rw = R[b]
            fh = max(rh, hB); fw = max(rw, wB)
            best = (0.0, 1.0, 0)
            for a in idx:
                if a == b or ids[fr][a] == ids[fr][b] or eb[a] <= eb[b]:
                    continue
                A = D[a, :4]
                fx1, fx2 = B[0], B[2]
                if wB < fw:
                    if (A[0] + A[2]) / 2 < (B[0] + B[2]) / 2:
                        fx1 = B[2] - fw
                    else:
                        fx2 = B[0] + fw
                full = (fx1, B[1], fx2, B[1] + fh)
                f = inter_area(A, full) / max(fw * fh, 1e-9)
                if f > best[0]:
                    ov = inter_area(A, B) / max(hB * wB, 1e-9)
                    tol_h, tol_w = 0.1 * rh, 0.15 * rw
                    cut = int((abs(B[3] - A[1]) < tol_h and hB < 0.9 * rh) or
                              (wB < 0.9 * rw and (abs(B[2] - A[0]) < tol_w or abs(B[0] - A[2]) < tol_w)))
                    best = (f, ov / max(f, 1e-9), cut)
            out.append((hB / rh, wB / rw, hB * wB / (rh * rw), best[0], best[1], best[2],
                        ids[fr][b], hB, wB, fr))
    return np.array(out) if out else np.zeros((0, 10))


def seq_dets2(frames_det, ids, min_free=3):
    """Second pass: reference = median size over the identity's free views (no nearer det
    covers >= 5 % of its expected box in the first pass), needing min_free of them."""
    X = seq_dets(frames_det, ids)
    ref = {}
    if len(X):
        fr_ = X[X[:, 3] < 0.05]
        for i in np.unique(fr_[:, 6]):
            Y = fr_[fr_[:, 6] == i]
            if len(Y) >= min_free:
                ref[int(i)] = (float(np.median(Y[:, 7])), float(np.median(Y[:, 8])))
    return seq_dets(frames_det, ids, ref=ref)


def seq_noid(frames_det):
    """No identities at all: a det's expected whole box keeps its top and width and takes
    the height its width gives at the sequence's median aspect (h / w) of dets that
    overlap no other det; nearer = larger expected bottom. Returns per det:
    (aspect / free median aspect, f = covered fraction of the expected box by nearer dets)."""
    asp = []
    for fr, D in frames_det.items():
        if len(D) == 0:
            continue
        _, inter, _, _ = iou_mat(D[:, :4], D[:, :4])
        np.fill_diagonal(inter, 0)
        free = inter.sum(1) <= 0
        asp.extend(((D[:, 3] - D[:, 1]) / np.maximum(D[:, 2] - D[:, 0], 1e-9))[free].tolist())
    if len(asp) < 20:
        return np.zeros((0, 2))
    a0 = float(np.median(asp))
    out = []
    for fr, D in frames_det.items():
        n = len(D)
        if n == 0:
            continue
        w = D[:, 2] - D[:, 0]
        h = D[:, 3] - D[:, 1]
        eh = np.maximum(h, w * a0)
        full = np.stack([D[:, 0], D[:, 1], D[:, 2], D[:, 1] + eh], 1)
        eb = full[:, 3]
        _, inter, _, af = iou_mat(full, D[:, :4])  # inter[b, a] = |full_b ∩ det_a|
        for b in range(n):
            m = eb > eb[b]
            f = float((inter[b][m]).max() / max(af[b], 1e-9)) if m.any() else 0.0
            out.append((h[b] / max(w[b], 1e-9) / a0, f))
    return np.array(out)


FHI = 0.6


def stats_noid(X):
    out = {'dets': int(len(X))}
    if len(X) == 0:
        return out
    free, hi, occ = X[X[:, 1] < 0.05], X[X[:, 1] >= FHI], X[X[:, 1] >= 0.3]
    out['n_free'], out['n_hi'] = len(free), len(hi)
    if len(free) >= 10 and len(hi) >= 10:
        out['A_hi'] = float(np.median(hi[:, 0]) / np.median(free[:, 0]))
        out['A_occ'] = float(np.median(occ[:, 0]) / np.median(free[:, 0]))
        out['A_hi_p25'] = float(np.percentile(hi[:, 0], 25) / np.percentile(free[:, 0], 25))
    return out


def stats(X):
    out = {'dets': int(len(X))}
    if len(X) == 0:
        return out
    free = X[X[:, 3] < 0.05]
    mid = X[(X[:, 3] >= 0.3) & (X[:, 3] < 0.6)]
    hi = X[X[:, 3] >= 0.6]
    out['n_free'], out['n_mid'], out['n_hi'] = len(free), len(mid), len(hi)
    if len(free) < 10 or len(mid) + len(hi) < 10:
        return out
    m = lambda Y, c: float(np.median(Y[:, c]))
    out['rh_free'] = m(free, 0)
    for nm, Y in (('mid', mid), ('hi', hi)):
        if len(Y) >= 10:
            out['Sh_' + nm] = m(Y, 0) / m(free, 0)      # height shrink under cover
            out['Sa_' + nm] = m(Y, 2) / m(free, 2)      # area shrink under cover
            out['q_' + nm] = m(Y, 4)                    # actual / expected overlap with occluder
            out['cut_' + nm] = float(np.mean(Y[:, 5]))  # box edge at the occluder's edge
    occ = X[X[:, 3] >= 0.3]
    out['Sh_occ'] = m(occ, 0) / m(free, 0)
    out['Sa_occ'] = m(occ, 2) / m(free, 2)
    out['q_occ'] = m(occ, 4)
    out['cut_occ'] = float(np.mean(occ[:, 5]))
    # local: a det's height / width / area against its identity's latest free view
    # (f < 0.05) at most 10 frames before; hidden (f >= 0.5) against free ones
    loc = {'hi': [], 'free': []}
    order = np.lexsort((X[:, 9], X[:, 6]))
    last = {}
    for r in X[order]:
        i = r[6]
        if i in last and r[9] - last[i][0] <= 10:
            lh, lw = last[i][1], last[i][2]
            row = (r[7] / lh, r[8] / lw, r[7] * r[8] / (lh * lw))
            if r[3] >= 0.5:
                loc['hi'].append(row)
            elif r[3] < 0.05:
                loc['free'].append(row)
        if r[3] < 0.05:
            last[i] = (r[9], r[7], r[8])
    out['n_loc'] = len(loc['hi'])
    if len(loc['hi']) >= 10 and len(loc['free']) >= 10:
        H, F = np.array(loc['hi']), np.array(loc['free'])
        out['Lh'] = float(np.median(H[:, 0]) / np.median(F[:, 0]))
        out['Lw'] = float(np.median(H[:, 1]) / np.median(F[:, 1]))
        out['La'] = float(np.median(H[:, 2]) / np.median(F[:, 2]))
        out['La_p25'] = float(np.percentile(H[:, 2], 25) / np.percentile(F[:, 2], 25))
    # slope of the height ratio on the expected covered fraction, all dets
    out['slope_h'] = float(np.polyfit(X[:, 3], np.clip(X[:, 0], 0, 3), 1)[0])
    return out


def cell_sequences(cdir):
    for det in sorted(glob.glob(os.path.join(cdir, 'det', '*.txt'))):
        name = os.path.basename(det)[:-4]
        gts = glob.glob(os.path.join(cdir, 'gt', '*', name, 'gt', 'gt.txt'))
        yield name, det, (gts[0] if gts else None)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('G')
    ap.add_argument('--cells', default='*')
    ap.add_argument('--out', default='results.json')
    ap.add_argument('--frames', type=int, default=0, help='only the first N frames (0: all)')
    ap.add_argument('--score-min', type=float, default=None, help='fixed score threshold instead of min(0.5, 40th percentile)')
    ap.add_argument('--fhi', type=float, default=0.6, help='covered fraction for the id-free statistic')
    ap.add_argument('--noid-only', action='store_true', help='only the id-free statistic')
    args = ap.parse_args()
    pats = args.cells.split(',')
    global FHI
    FHI = args.fhi
    res = {}
    for cdir in sorted(glob.glob(os.path.join(args.G, '*'))):
        cell = os.path.basename(cdir).replace('__', '/')
        if not any(fnmatch.fnmatch(cell, p) for p in pats):
            continue
        res[cell] = {}
        for name, detp, gtp in cell_sequences(cdir):
            d = load_txt(detp)
            thr = det_threshold(d[:, 6]) if len(d) else 0
            if args.score_min is not None:
                thr = args.score_min
            d = d[d[:, 6] >= thr]
            if args.frames:
                d = d[d[:, 0] <= args.frames]
            fd = {}
            for r in d:
                fd.setdefault(int(r[0]), []).append([r[2], r[3], r[2] + r[4], r[3] + r[5]])
            fd = {k: np.array(v) for k, v in fd.items()}
            entry = {'dets': int(len(d)), 'thr': thr}
            if gtp and not args.noid_only:
                g = load_txt(gtp)
                # MOT15-style: keep considered gt (conf flag != 0), any class
                g = g[g[:, 6] != 0]
                fg = {}
                for r in g:
                    fg.setdefault(int(r[0]), []).append([r[1], r[2], r[3], r[2] + r[4], r[3] + r[5]])
                fg = {k: np.array(v) for k, v in fg.items()}
                entry['gt'] = stats(seq_dets2(fd, ids_from_gt(fd, fg)))
            entry['noid'] = stats_noid(seq_noid(fd))
            if not args.noid_only:
                entry['link'] = stats(seq_dets2(fd, ids_from_linker(fd)))
            res[cell][name] = entry
            print(cell, name, json.dumps(entry), flush=True)
    with open(args.out, 'w') as fh:
        json.dump(res, fh, indent=1)


if __name__ == '__main__':
    main()
