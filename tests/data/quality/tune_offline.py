#!/usr/bin/env python3
"""Rank offline configs on a split of MOT15-train (how the offline defaults were chosen).

Usage: tune_offline.py SPLIT CONFIGS.jsonl      SPLIT = train | test | all (README.md)
Each line of CONFIGS.jsonl is an OfflineConfig JSON (`{}` = the defaults; the line
`"online"` alone scores the online tracker instead). Runs `shapetrack track [--offline
--offline-config]` per config and sequence (box mode, det/det.txt, fps from seqinfo.ini) and
scores with `shapetrack eval` (our metrics, equal to TrackEval's). Prints one line per config,
best combined HOTA first.
Env: BIN (default target/release/shapetrack), DATA (default ../shared/data/mot15-train),
     WORK (scratch, default /tmp/shapetrack-offline-tune). Never used at test time.
"""
import json, os, shutil, subprocess, sys

SPLITS = {
    "train": ["ADL-Rundle-6", "ETH-Bahnhof", "ETH-Pedcross2", "KITTI-13", "PETS09-S2L1", "TUD-Campus"],
    "test": ["ADL-Rundle-8", "ETH-Sunnyday", "KITTI-17", "TUD-Stadtmitte", "Venice-2"],
}
SPLITS["all"] = sorted(SPLITS["train"] + SPLITS["test"])

here = os.path.dirname(os.path.abspath(__file__))
repo = os.path.normpath(os.path.join(here, "../../.."))
BIN = os.environ.get("BIN", os.path.join(repo, "target/release/shapetrack"))
DATA = os.path.abspath(os.environ.get("DATA", os.path.join(repo, "../shared/data/mot15-train")))
WORK = os.environ.get("WORK", "/tmp/shapetrack-offline-tune")


def score(split, cfg, name):
    seqs = SPLITS[split]
    out = os.path.join(WORK, split, name)
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    extra = []
    if cfg != "online":
        cp = os.path.join(WORK, split, name + ".json")
        json.dump(cfg, open(cp, "w"))
        extra = ["--offline", "--offline-config", cp]
    for s in seqs:
        subprocess.run([BIN, "track", "--det", f"{DATA}/{s}/det/det.txt", "--out", f"{out}/{s}.txt"] + extra,
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    js = os.path.join(WORK, split, name + ".scores.json")
    subprocess.run([BIN, "eval", "--gt", DATA, "--tracker", out, "--benchmark", "MOT15", "--json", js, "--seq"] + seqs,
                   check=True, stdout=subprocess.DEVNULL)
    return json.load(open(js))


def main():
    split, cfgfile = sys.argv[1:3]
    rows = []
    for i, line in enumerate(l for l in open(cfgfile) if l.strip()):
        cfg = json.loads(line)
        r = score(split, cfg, f"c{i:04d}")
        c = r["combined"]
        rows.append((c["HOTA"], c["IDF1"], c["IDSW"], c["MOTA"], line.strip()))
        print(f"c{i:04d} HOTA {c['HOTA']:.3f} IDF1 {c['IDF1']:.3f} IDSW {c['IDSW']} MOTA {c['MOTA']:.3f} {line.strip()}",
              file=sys.stderr, flush=True)
        if os.environ.get("PERSEQ"):
            for name, s in r["sequences"].items():
                print(f"   {name:16s} HOTA {s['HOTA']:.3f} IDF1 {s['IDF1']:.3f} IDSW {s['IDSW']} MOTA {s['MOTA']:.3f}",
                      file=sys.stderr)
    rows.sort(key=lambda r: -r[0])
    for h, i1, sw, mo, l in rows:
        print(f"HOTA {h:.3f} IDF1 {i1:.3f} IDSW {sw} MOTA {mo:.3f} {l}")


if __name__ == "__main__":
    main()
