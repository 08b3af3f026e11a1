#!/usr/bin/env python3
"""The robustness grid, in one command: datasets x detector models x {ours online, ours offline,
ours with masks where the cell has masks, each peer}, all on the same detections, scored by our
eval and by TrackEval; writes tests/data/quality/grid.md and grid.json.

Usage: scripts/grid.py [--cells GLOB,..] [--datasets D,..] [--peers LIST] [--out DIR]
                       [--venv DIR] [--bin PATH] [--no-trackeval] [--jobs N] [--from-json FILE]

  --cells     only cells whose dataset/model name matches (`*` wildcard, comma-separated)
  --datasets  mot15,sportsmot,bdd,bdd-masks,synth (default: all)
  --peers     rf_sort,rf_bytetrack,norfair,ocsort,motpy (default: all)
  --out       work folder (default: target/grid)
  --venv      Python venv with TrackEval and the peers, or a cache folder holding one as DIR/venv
              (default: $SHAPETRACK_PEERS_VENV, else ~/.cache/shapetrack/peers); created with
              ../shared/tools/peers/setup_venv.sh when missing, and OC-SORT's own venv beside it
              (ocsort-venv: numpy<2, its pinned scipy and filterpy): that needs PyPI once
  --bin       shapetrack binary (default: cargo build --release, then target/release/shapetrack)
  --jobs      peer runs in parallel (default 1; this machine has 2 cores)
  --rerun-peers  run the peers again even where a cell's detections did not change (by default
              their results are reused: a digest of the detections is kept beside them)
  --write     where to write grid.md/grid.json (default tests/data/quality; `-` for nowhere)
  --from-json write grid.md (and grid.json) again from a grid.json this script wrote, without
              running anything: the tables' form changed, the figures did not
  --merge     with --cells or --datasets: put the selected cells' rows into the grid.json already
              at --write (replacing those cells, keeping every other), and note the partial run
              in grid.md, instead of writing a grid of the selected cells alone

Stages: `shapetrack grid prepare` writes each cell in TrackEval's layout with its detections;
`shapetrack grid run` runs ours; the peers run through ../shared/tools/peers/run_baseline.py
(OC-SORT through scripts/peers/ocsort_runner.py), with their plain defaults, timed inside their
update calls; `shapetrack grid score` and TrackEval (run_trackeval_mot.py, BENCHMARK MOT15, one
ground-truth root per cell) score every tracker folder. Only the standard library is needed to
run this script itself.
"""
import argparse, concurrent.futures, datetime, hashlib, json, os, re, subprocess, sys, time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, ".."))
SHARED = os.environ.get("SHAPETRACK_SHARED", os.path.normpath(os.path.join(REPO, "..", "shared")))
TOOLS = os.path.join(SHARED, "tools", "peers")
PEERS = ["rf_sort", "rf_bytetrack", "norfair", "ocsort", "motpy"]
NAMES = {"rf_sort": "SORT", "rf_bytetrack": "ByteTrack", "norfair": "norfair", "ocsort": "OC-SORT",
         "motpy": "motpy", "ours-online": "ours online", "ours-offline": "ours offline",
         "ours-masks-online": "ours masks online", "ours-masks-offline": "ours masks offline"}


def sh(cmd, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        sys.exit(f"command failed ({r.returncode}): {' '.join(cmd)}\n{r.stdout}\n{r.stderr}")
    return r.stdout


def ensure_venv(path):
    for cand in (path, os.path.join(path, "venv")):
        py = os.path.join(cand, "bin", "python")
        if os.path.exists(py):
            break
    else:
        path = os.path.abspath(path)
        cache = os.path.dirname(path) if os.path.basename(path) == "venv" else path
        os.makedirs(cache, exist_ok=True)
        print(f"creating the peers venv in {cache}/venv (PyPI, once)...", file=sys.stderr)
        sh(["bash", os.path.join(TOOLS, "setup_venv.sh"), cache])
        py = os.path.join(cache, "venv", "bin", "python")
    return py


def ensure_ocsort_venv(path):
    """OC-SORT (PyPI `ocsort` 0.0.2) in a venv of its own: its code needs numpy 1.x (numpy 2
    refuses its `float()` of size-1 arrays) and pins scipy 1.9.3 and filterpy 1.4.5, which would
    clash with TrackEval's venv. Its `lap==0.4.0` pin no longer builds; lap 0.5 has the same
    `lapjv` API."""
    py = os.path.join(path, "bin", "python")
    if not os.path.exists(py):
        print(f"creating the OC-SORT venv in {path} (PyPI, once)...", file=sys.stderr)
        sh([sys.executable, "-m", "venv", path])
    if subprocess.run([py, "-c", "import ocsort, filterpy, lap, scipy"], capture_output=True).returncode:
        sh([py, "-m", "pip", "install", "-q", "numpy<2", "scipy==1.9.3", "filterpy==1.4.5", "lap>=0.5"])
        sh([py, "-m", "pip", "install", "-q", "--no-deps", "ocsort==0.0.2"])
    return py


def cells_in(out):
    return sorted(d for d in os.listdir(out) if "__" in d and os.path.isdir(os.path.join(out, d)))


def seqs_of(cell_dir):
    with open(os.path.join(cell_dir, "gt", "seqmaps", "MOT15-train.txt")) as f:
        return [l.strip() for l in f.readlines()[1:] if l.strip()]


def fps_of(cell_dir, seq):
    text = open(os.path.join(cell_dir, "gt", "MOT15-train", seq, "seqinfo.ini")).read()
    return float(re.search(r"^frameRate\s*=\s*(\S+)", text, re.M).group(1))


def dets_digest(cell_dir):
    """A digest of a cell's detection files: a peer's results are reused while it holds."""
    h = hashlib.sha256()
    for s in seqs_of(cell_dir):
        h.update(s.encode())
        with open(os.path.join(cell_dir, "det", s + ".txt"), "rb") as f:
            h.update(f.read())
    return h.hexdigest()


def run_peer(py, peer, cell_dir, ocsort_py=None, reuse=True):
    data = os.path.join(cell_dir, "trackers", "MOT15-train", peer, "data")
    stamp = os.path.join(cell_dir, "trackers", "MOT15-train", peer, "dets.sha256")
    digest = dets_digest(cell_dir)
    timing = os.path.join(cell_dir, "trackers", "MOT15-train", peer, "fps.txt")
    if reuse and os.path.exists(stamp) and open(stamp).read() == digest and os.path.exists(timing):
        return float(open(timing).read())
    os.makedirs(data, exist_ok=True)
    frames = secs = 0.0
    for s in seqs_of(cell_dir):
        det = os.path.join(cell_dir, "det", s + ".txt")
        out = os.path.join(data, s + ".txt")
        if os.path.getsize(det) == 0:
            open(out, "w").close()
            continue
        if peer == "ocsort":
            cmd = [ocsort_py, os.path.join(HERE, "peers", "ocsort_runner.py"), det, out]
        else:
            cmd = [py, os.path.join(TOOLS, "run_baseline.py"), peer, det, out, str(fps_of(cell_dir, s))]
        line = sh(cmd)
        m = re.search(r"frames=(\d+).*tracker_time=([\d.]+)s", line)
        frames += int(m.group(1))
        secs += float(m.group(2))
    fps = frames / secs if secs > 0 else float("inf")
    open(timing, "w").write(repr(fps))
    open(stamp, "w").write(digest)
    return fps


def trackeval(py, cell_dir, tracker):
    text = sh([py, os.path.join(TOOLS, "run_trackeval_mot.py"), os.path.join(cell_dir, "gt"),
               os.path.join(cell_dir, "trackers"), "MOT15", tracker])
    for line in text.splitlines():
        p = line.split()
        if len(p) >= 11 and p[0] == "SUMMARY" and p[1] == "COMBINED_SEQ":
            return {"HOTA": float(p[2]), "DetA": float(p[3]), "AssA": float(p[4]),
                    "MOTA": float(p[5]), "IDF1": float(p[7]), "IDSW": int(p[8])}
    sys.exit(f"no COMBINED_SEQ row in TrackEval's output for {cell_dir} {tracker}")


def fmt_cell(r, best):
    if r is None:
        return "–"
    s = f"{r['HOTA']:.1f} / {r['IDF1']:.1f}"
    return f"**{s}**" if best else s


def render(result):
    """grid.md's text from a grid.json's content, and the summary counts it states."""
    ours_scores, peers = result["ours"], result.get("peers") or [
        p for p in PEERS if any(p in v for v in result["ours"].values())]
    te = {tuple(k.rsplit("/", 1)): v for k, v in result.get("trackeval", {}).items()}
    rows, worst = [], {}
    ours_cols = ["ours-online", "ours-offline", "ours-masks-online", "ours-masks-offline"]
    summary = {"online_ge_best_hota": 0, "online_ge_sort_hota": 0, "offline_ge_best_hota_idf1": 0,
               "masks_online_ge_best_hota": 0, "masks_offline_ge_best_hota_idf1": 0,
               "masks_online_gt_boxes": 0, "masks_offline_gt_boxes": 0, "mask_cells": 0, "cells": 0}
    by_dataset = {}
    for name in sorted(ours_scores, key=lambda n: n.replace("/", "__")):
        s = ours_scores[name]
        for (cc, tr), v in te.items():
            if cc == name and tr in s:
                for k in ("HOTA", "IDF1", "MOTA"):
                    worst[k] = max(worst.get(k, 0.0), abs(v[k] - s[tr][k]))
                worst["IDSW"] = max(worst.get("IDSW", 0), abs(v["IDSW"] - s[tr]["IDSW"]))
        pe = {p: s.get(p) for p in peers if s.get(p)}
        best_peer = max(pe, key=lambda p: pe[p]["HOTA"]) if pe else None
        bh = pe[best_peer]["HOTA"] if best_peer else 0.0
        bi = max((v["IDF1"] for v in pe.values()), default=0.0)
        on, off = s.get("ours-online"), s.get("ours-offline")
        summary["cells"] += 1
        if on and on["HOTA"] >= bh:
            summary["online_ge_best_hota"] += 1
        if on and on["HOTA"] >= (pe.get("rf_sort") or {"HOTA": 0})["HOTA"]:
            summary["online_ge_sort_hota"] += 1
        if off and off["HOTA"] >= bh and off["IDF1"] >= bi:
            summary["offline_ge_best_hota_idf1"] += 1
        mon = s.get("ours-masks-online")
        if mon:
            summary["mask_cells"] += 1
            if mon["HOTA"] >= bh:
                summary["masks_online_ge_best_hota"] += 1
            if on and mon["HOTA"] > on["HOTA"]:
                summary["masks_online_gt_boxes"] += 1
        moff = s.get("ours-masks-offline")
        if moff:
            if moff["HOTA"] >= bh and moff["IDF1"] >= bi:
                summary["masks_offline_ge_best_hota_idf1"] += 1
            if off and moff["HOTA"] > off["HOTA"]:
                summary["masks_offline_gt_boxes"] += 1
        ds = name.split("/")[0]
        agg = by_dataset.setdefault(ds, {})
        for tr, v in s.items():
            agg.setdefault(tr, []).append(v["HOTA"])
        rows.append((name, s, best_peer, bh))

    # Issue 9's mask-mode goal is stated per synthetic family (a scenario, over its clean and
    # ragged masks): the family's mean HOTA with masks and frames against its mean in our box
    # mode and each peer's.
    mean = lambda v: sum(v) / len(v)
    fam = {ds: {t: mean(v) for t, v in agg.items()} for ds, agg in by_dataset.items()
           if ds.startswith("synth-") and "ours-masks-online" in agg}
    for mode, box in (("online", "ours-online"), ("offline", "ours-offline")):
        mk = f"ours-masks-{mode}"
        summary[f"families_masks_{mode}_gt_boxes"] = sum(1 for m in fam.values() if m[mk] > m[box])
        summary[f"families_masks_{mode}_gt_peers"] = sum(
            1 for m in fam.values() if all(m[mk] > m[p] for p in peers if p in m))
    summary["families"] = len(fam)
    below = [f"{ds} {mode} ({m[f'ours-masks-{mode}']:.2f} vs {m[box]:.2f})" for ds, m in sorted(fam.items())
             for mode, box in (("online", "ours-online"), ("offline", "ours-offline"))
             if m[f"ours-masks-{mode}"] <= m[box]]

    trackers = [t for t in ours_cols + peers if any(t in r[1] for r in rows)]
    lines = []
    lines.append("| cell | " + " | ".join(NAMES.get(t, t) for t in trackers) + " | best peer | online − best | online − SORT |")
    lines.append("|---" * (len(trackers) + 4) + "|")
    for name, s, bp, bh in rows:
        best_h = max((v["HOTA"] for v in s.values()), default=None)
        cells_txt = [fmt_cell(s.get(t), s.get(t) is not None and s[t]["HOTA"] == best_h) for t in trackers]
        on = s.get("ours-online")
        d_best = f"{on['HOTA'] - bh:+.1f}" if on and bp else "–"
        d_sort = f"{on['HOTA'] - s['rf_sort']['HOTA']:+.1f}" if on and s.get("rf_sort") else "–"
        lines.append(f"| {name} | " + " | ".join(cells_txt) + f" | {NAMES.get(bp, bp)} | {d_best} | {d_sort} |")
    n = max(summary["cells"], 1)
    # In the order the stages run (grid.json keeps them sorted by name).
    order = ["prepare", "ours", "peers", "score", "trackeval"]
    stages = dict(sorted(result.get("stages_seconds", {}).items(),
                         key=lambda kv: order.index(kv[0]) if kv[0] in order else len(order)))
    nf = summary["families"]
    md = [f"# Robustness grid\n",
          f"HOTA / IDF1 (our eval; TrackEval agrees: largest difference {json.dumps(worst) if worst else 'not run'}) per cell "
          f"(dataset/detector model) and tracker, all on the same detections. Bold: best in the row. "
          f"Made {result['made']} at commit {result['commit']}{' (with uncommitted changes)' if result.get('dirty') else ''} "
          f"by `{result['command']}` "
          f"({sum(stages.values()) / 60:.0f} min: " + ", ".join(f"{k} {v:.0f} s" for k, v in stages.items()) + ")"
          + "".join(f"; cells {', '.join(u['cells'])} (re)made {u['made']} at commit {u['commit']}"
                    f"{' (with uncommitted changes)' if u.get('dirty') else ''} by `{u['command']}` "
                    f"({sum(u['stages_seconds'].values()) / 60:.0f} min)" for u in result.get("updates", []))
          + ".\n",
          f"- ours online ≥ best peer on HOTA: {summary['online_ge_best_hota']} / {n} cells; ≥ SORT: {summary['online_ge_sort_hota']} / {n}",
          f"- ours offline ≥ best peer on HOTA and IDF1: {summary['offline_ge_best_hota_idf1']} / {n}",
          f"- ours with masks online ≥ best peer on HOTA: {summary['masks_online_ge_best_hota']} / {summary['mask_cells']} mask cells; "
          f"offline ≥ best peer on HOTA and IDF1: {summary['masks_offline_ge_best_hota_idf1']} / {summary['mask_cells']}",
          f"- masks with frames above our own box mode on HOTA: online {summary['masks_online_gt_boxes']} / {summary['mask_cells']}, "
          f"offline {summary['masks_offline_gt_boxes']} / {summary['mask_cells']} mask cells",
          f"- synthetic families (mean HOTA over a family's clean and ragged cells), masks with frames above our own box "
          f"mode: online {summary['families_masks_online_gt_boxes']} / {nf}, offline "
          f"{summary['families_masks_offline_gt_boxes']} / {nf}; above every peer: online "
          f"{summary['families_masks_online_gt_peers']} / {nf}, offline {summary['families_masks_offline_gt_peers']} / {nf}"
          + (f" (not above box mode: {'; '.join(below)})" if below else "") + "\n",
          "Mean HOTA per dataset:\n",
          "| dataset | " + " | ".join(NAMES.get(t, t) for t in trackers) + " |",
          "|---" * (len(trackers) + 1) + "|"]
    for ds, agg in sorted(by_dataset.items()):
        md.append(f"| {ds} | " + " | ".join(
            f"{sum(agg[t]) / len(agg[t]):.1f}" if t in agg else "–" for t in trackers) + " |")
    md += ["", *lines, ""]
    return "\n".join(md), summary, worst


def write_tables(result, where):
    """Prints grid.md's text and, unless `where` is `-`, writes grid.md and grid.json there."""
    text, summary, worst = render(result)
    result = {**result, "summary": summary, "trackeval_max_difference": worst}
    print(text)
    if where != "-":
        os.makedirs(where, exist_ok=True)
        open(os.path.join(where, "grid.md"), "w").write(text)
        json.dump(result, open(os.path.join(where, "grid.json"), "w"), indent=1, sort_keys=True)


def merge(old, new, cells):
    """`old` (a whole grid's grid.json) with the rows of `cells` taken from `new` (a run of
    those cells alone), and the run noted under `updates`: grid.md keeps saying how every figure
    was made."""
    out = {k: v for k, v in old.items() if k not in ("summary", "trackeval_max_difference")}
    of = lambda key: key.rsplit("/", 1)[0]
    out["ours"] = {**{k: v for k, v in old["ours"].items() if k not in cells}, **new["ours"]}
    out["trackeval"] = {**{k: v for k, v in old.get("trackeval", {}).items() if of(k) not in cells},
                        **new.get("trackeval", {})}
    out["fps"] = {**{k: v for k, v in old.get("fps", {}).items() if of(k) not in cells},
                  **new.get("fps", {})}
    out["updates"] = [u for u in old.get("updates", []) if not set(u["cells"]) <= set(cells)] + [
        {k: new[k] for k in ("made", "commit", "dirty", "command", "stages_seconds")} | {"cells": cells}]
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", default="")
    ap.add_argument("--datasets", default="")
    ap.add_argument("--peers", default=",".join(PEERS))
    ap.add_argument("--out", default=os.path.join(REPO, "target", "grid"))
    ap.add_argument("--venv", default=os.environ.get(
        "SHAPETRACK_PEERS_VENV", os.path.expanduser("~/.cache/shapetrack/peers")))
    ap.add_argument("--bin", default=None)
    ap.add_argument("--no-trackeval", action="store_true")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--rerun-peers", action="store_true",
                    help="run the peers even where their results for the same detections exist")
    ap.add_argument("--write", default=os.path.join(REPO, "tests", "data", "quality"))
    ap.add_argument("--merge", action="store_true",
                    help="merge the selected cells into the grid.json at --write (module docs)")
    ap.add_argument("--from-json", default=None,
                    help="write grid.md again from this grid.json (no run): a change of the tables' form")
    a = ap.parse_args()
    if a.from_json:
        write_tables(json.load(open(a.from_json)), a.write)
        return
    t_start = time.time()
    stages = {}

    py = ensure_venv(a.venv)
    ocsort_py = None
    if "ocsort" in a.peers.split(","):
        ocsort_py = ensure_ocsort_venv(os.path.join(os.path.dirname(os.path.abspath(a.venv.rstrip("/"))),
                                                    "ocsort-venv"))
    binary = a.bin
    if binary is None:
        sh(["cargo", "build", "--release", "--quiet"], cwd=REPO)
        binary = os.path.join(REPO, "target", "release", "shapetrack")
    out = os.path.abspath(a.out)
    os.makedirs(out, exist_ok=True)
    sel = []
    if a.cells:
        sel += ["--cells", a.cells]
    if a.datasets:
        sel += ["--datasets", a.datasets]

    t = time.time()
    print("preparing cells...", file=sys.stderr)
    sh([binary, "grid", "prepare", "--out", out] + sel)
    stages["prepare"] = time.time() - t
    t = time.time()
    print("running ours...", file=sys.stderr)
    ours_log = sh([binary, "grid", "run", "--dir", out, "--name", "ours"] + sel)
    stages["ours"] = time.time() - t
    ours_fps = {}
    for line in ours_log.splitlines():
        m = re.match(r"(\S+) (\S+): (\d+) frames in ([\d.]+) s", line)
        if m:
            # A cell timed at 0 s (too fast for the clock) gets no figure rather than a huge one.
            if float(m.group(4)) > 0:
                ours_fps[(m.group(1), m.group(2))] = int(m.group(3)) / float(m.group(4))

    cells = [c for c in cells_in(out) if not sel or any(
        re.fullmatch(p.replace("*", ".*"), c.replace("__", "/")) for p in (a.cells or "*").split(","))]
    if a.datasets:
        wanted = a.datasets.split(",")
        cells = [c for c in cells if any(c.split("__")[0] == d or (d == "synth" and c.startswith("synth-"))
                                         for d in wanted)]
    peers = [p for p in a.peers.split(",") if p]
    t = time.time()
    peer_fps = {}
    jobs = [(p, c) for c in cells for p in peers]
    print(f"running {len(peers)} peers on {len(cells)} cells...", file=sys.stderr)
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, a.jobs)) as ex:
        futs = {ex.submit(run_peer, py, p, os.path.join(out, c), ocsort_py, not a.rerun_peers): (p, c)
                for p, c in jobs}
        for f in concurrent.futures.as_completed(futs):
            peer_fps[futs[f]] = f.result()
    stages["peers"] = time.time() - t

    t = time.time()
    print("scoring (ours)...", file=sys.stderr)
    score_json = os.path.join(out, "scores.json")
    sh([binary, "grid", "score", "--dir", out, "--json", score_json] + sel)
    ours_scores = json.load(open(score_json))
    stages["score"] = time.time() - t
    te = {}
    if not a.no_trackeval:
        t = time.time()
        print("scoring (TrackEval)...", file=sys.stderr)
        tj = [(c, tr) for c in cells for tr in sorted(os.listdir(os.path.join(out, c, "trackers", "MOT15-train")))]
        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, a.jobs)) as ex:
            futs = {ex.submit(trackeval, py, os.path.join(out, c), tr): (c, tr) for c, tr in tj}
            for f in concurrent.futures.as_completed(futs):
                te[futs[f]] = f.result()
        stages["trackeval"] = time.time() - t

    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=REPO).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True, cwd=REPO).stdout.strip()
    cmd = "python3 scripts/grid.py" + (f" --cells {a.cells}" if a.cells else "") + (f" --datasets {a.datasets}" if a.datasets else "") + (" --merge" if a.merge else "")
    fps = {f"{c}/{p}": v for (p, c), v in peer_fps.items()}
    fps.update({f"{c}/{t}": v for (c, t), v in ours_fps.items()})
    result = {"made": now, "commit": commit, "dirty": bool(dirty), "command": cmd, "stages_seconds": stages,
              "peers": peers, "ours": {c.replace("__", "/"): ours_scores.get(c.replace("__", "/"), {}) for c in cells},
              "trackeval": {f"{c.replace('__', '/')}/{t}": v for (c, t), v in te.items()}, "fps": fps}
    if a.merge:
        result = merge(json.load(open(os.path.join(a.write, "grid.json"))), result,
                       [c.replace("__", "/") for c in cells])
    write_tables(result, a.write)
    print(f"done in {(time.time() - t_start) / 60:.1f} min", file=sys.stderr)


if __name__ == "__main__":
    main()
