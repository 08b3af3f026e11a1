#!/usr/bin/env python3
"""Peer comparison on MOT15-train: the PyPI trackers and shapetrack (online and offline) on the
same detections (det/det.txt), in one run, scored by TrackEval and by `shapetrack eval`.

Usage: scripts/compare_peers.py [--venv DIR] [--out DIR] [--bin PATH] [--peers LIST]

  --venv   Python venv with TrackEval and the peers, or a cache folder holding one as
           DIR/venv (default: $SHAPETRACK_PEERS_VENV, else ~/.cache/shapetrack/peers). Created
           with ../shared/tools/peers/setup_venv.sh when missing (that needs the Python package
           index once; nothing is downloaded otherwise).
  --out    Work folder (default: target/compare_peers): results in TrackEval's layout,
           OUT/MOT15-train/<tracker>/data/<seq>.txt, plus each tool's raw output.
  --bin    shapetrack binary (default: `cargo build --release`, then target/release/shapetrack).
  --peers  Comma-separated peers (default: rf_sort,rf_bytetrack,norfair,motpy).

Prints one table: per tracker HOTA, IDF1, IDSW and MOTA from our metrics beside TrackEval's,
and fps = frames / time inside the tracker (the peers: their update calls, timed by
run_baseline.py; shapetrack: the core, without file reading or writing; one thread).
Only the standard library is needed to run this script itself.
"""
import argparse, json, os, re, shutil, subprocess, sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, ".."))
SHARED = os.path.normpath(os.path.join(REPO, "..", "shared"))
DATA = os.path.join(SHARED, "data", "mot15-train")
TOOLS = os.path.join(SHARED, "tools", "peers")
NAMES = {"rf_sort": "SORT (roboflow trackers)", "rf_bytetrack": "ByteTrack (roboflow trackers)",
         "norfair": "norfair (IoU)", "motpy": "motpy", "shapetrack_online": "shapetrack online",
         "shapetrack_offline": "shapetrack offline"}


def sh(cmd, **kw):
    """Runs a command, failing loudly with its output."""
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        sys.exit(f"command failed ({r.returncode}): {' '.join(cmd)}\n{r.stdout}\n{r.stderr}")
    return r.stdout


def seqinfo(seq):
    text = open(os.path.join(DATA, seq, "seqinfo.ini")).read()
    get = lambda k: re.search(rf"^{k}\s*=\s*(\S+)", text, re.M).group(1)
    return int(get("seqLength")), float(get("frameRate"))


def ensure_venv(path):
    """The venv's python: PATH itself or PATH/venv; made by setup_venv.sh when neither exists
    (in place: PATH when it is named `venv`, else PATH/venv)."""
    for cand in (path, os.path.join(path, "venv")):
        py = os.path.join(cand, "bin", "python")
        if os.path.exists(py):
            return py
    path = os.path.abspath(path)
    cache = os.path.dirname(path) if os.path.basename(path) == "venv" else path
    os.makedirs(cache, exist_ok=True)
    print(f"creating the peers venv in {cache}/venv (pip install from PyPI, once)...", file=sys.stderr)
    sh(["bash", os.path.join(TOOLS, "setup_venv.sh"), cache])
    return os.path.join(cache, "venv", "bin", "python")


def run_peer(py, peer, seqs, out):
    data = os.path.join(out, "MOT15-train", peer, "data")
    os.makedirs(data, exist_ok=True)
    frames = time = 0.0
    for s in seqs:
        n, fps = seqinfo(s)
        line = sh([py, os.path.join(TOOLS, "run_baseline.py"), peer,
                   os.path.join(DATA, s, "det", "det.txt"), os.path.join(data, s + ".txt"), str(fps)])
        m = re.search(r"frames=(\d+).*tracker_time=([\d.]+)s", line)
        frames += int(m.group(1))
        time += float(m.group(2))
    return frames / time if time > 0 else float("inf")


def run_shapetrack(binary, name, extra, seqs, out):
    data = os.path.join(out, "MOT15-train", name, "data")
    os.makedirs(data, exist_ok=True)
    frames = time = 0.0
    for s in seqs:
        line = sh([binary, "track", "--det", os.path.join(DATA, s, "det", "det.txt"),
                   "--out", os.path.join(data, s + ".txt")] + extra)
        m = re.search(r"frames=(\d+).*core_fps=(\d+)", line)
        n, core_fps = int(m.group(1)), float(m.group(2))
        frames += n
        time += n / core_fps if core_fps > 0 else 0.0
    return frames / time if time > 0 else float("inf")


def trackeval_scores(py, out, tracker):
    text = sh([py, os.path.join(TOOLS, "run_trackeval_mot.py"), os.path.join(out, "gt"), out,
               "MOT15", tracker])
    with open(os.path.join(out, "MOT15-train", tracker, "trackeval_full.txt"), "w") as f:
        f.write(text)
    for line in text.splitlines():
        p = line.split()
        if len(p) >= 11 and p[0] == "SUMMARY" and p[1] == "COMBINED_SEQ":
            return {"HOTA": float(p[2]), "MOTA": float(p[5]), "IDF1": float(p[7]), "IDSW": int(p[8])}
    sys.exit(f"no COMBINED_SEQ row in TrackEval's output for {tracker}")


def our_scores(binary, out, tracker, seqs):
    js = os.path.join(out, "MOT15-train", tracker, "shapetrack_eval.json")
    sh([binary, "eval", "--gt", DATA, "--tracker", os.path.join(out, "MOT15-train", tracker, "data"),
        "--benchmark", "MOT15", "--json", js, "--seq"] + seqs)
    c = json.load(open(js))["combined"]
    return {"HOTA": c["HOTA"], "MOTA": c["MOTA"], "IDF1": c["IDF1"], "IDSW": int(c["IDSW"])}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--venv", default=os.environ.get(
        "SHAPETRACK_PEERS_VENV", os.path.expanduser("~/.cache/shapetrack/peers")))
    ap.add_argument("--out", default=os.path.join(REPO, "target", "compare_peers"))
    ap.add_argument("--bin", default=None)
    ap.add_argument("--peers", default="rf_sort,rf_bytetrack,norfair,motpy")
    a = ap.parse_args()

    seqs = sorted(d for d in os.listdir(DATA) if os.path.isdir(os.path.join(DATA, d)))
    py = ensure_venv(a.venv)
    binary = a.bin
    if binary is None:
        sh(["cargo", "build", "--release", "--quiet"], cwd=REPO)
        binary = os.path.join(REPO, "target", "release", "shapetrack")
    out = os.path.abspath(a.out)
    shutil.rmtree(os.path.join(out, "MOT15-train"), ignore_errors=True)
    # TrackEval's layout: GT_ROOT/MOT15-train/<seq> and a seqmap.
    gt = os.path.join(out, "gt")
    os.makedirs(os.path.join(gt, "seqmaps"), exist_ok=True)
    link = os.path.join(gt, "MOT15-train")
    if os.path.islink(link):
        os.unlink(link)
    os.symlink(DATA, link)
    with open(os.path.join(gt, "seqmaps", "MOT15-train.txt"), "w") as f:
        f.write("name\n" + "".join(s + "\n" for s in seqs))

    fps = {}
    for p in [p for p in a.peers.split(",") if p]:
        print(f"running {p}...", file=sys.stderr)
        fps[p] = run_peer(py, p, seqs, out)
    print("running shapetrack...", file=sys.stderr)
    fps["shapetrack_online"] = run_shapetrack(binary, "shapetrack_online", [], seqs, out)
    fps["shapetrack_offline"] = run_shapetrack(binary, "shapetrack_offline", ["--offline"], seqs, out)

    rows = []
    for t in fps:
        print(f"scoring {t}...", file=sys.stderr)
        rows.append((t, our_scores(binary, out, t, seqs), trackeval_scores(py, out, t), fps[t]))

    print(f"\nMOT15-train, {len(seqs)} sequences combined, det/det.txt; ours = `shapetrack eval`, "
          "TE = TrackEval")
    head = f"{'tracker':32} {'HOTA ours':>9} {'HOTA TE':>8} {'IDF1 ours':>9} {'IDF1 TE':>8} " \
           f"{'IDSW ours':>9} {'IDSW TE':>8} {'MOTA ours':>9} {'MOTA TE':>8} {'fps':>9}"
    print(head)
    print("-" * len(head))
    for t, o, te, f in rows:
        print(f"{NAMES.get(t, t):32} {o['HOTA']:9.3f} {te['HOTA']:8.3f} {o['IDF1']:9.3f} "
              f"{te['IDF1']:8.3f} {o['IDSW']:9d} {te['IDSW']:8d} {o['MOTA']:9.3f} {te['MOTA']:8.3f} "
              f"{f:9.0f}")
    mismatch = [t for t, o, te, _ in rows if o["IDSW"] != te["IDSW"] or any(
        abs(o[k] - te[k]) > 0.0005 for k in ("HOTA", "IDF1", "MOTA"))]
    if mismatch:
        print(f"\nnote: our metrics differ from TrackEval's for {', '.join(mismatch)}")


if __name__ == "__main__":
    main()
