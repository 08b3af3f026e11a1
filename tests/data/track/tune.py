#!/usr/bin/env python
"""Rank tracker configs with TrackEval on a split of MOT15-train (how the defaults were chosen).

Usage: tune.py SPLIT CONFIGS.jsonl        SPLIT = train | test | all (README.md)
Env:   BIN (shapetrack binary, default target/release/shapetrack), DATA (mot15-train folder,
       default ../shared/data/mot15-train), WORK (scratch folder, default /tmp/shapetrack-tune),
       PERSEQ=1 to print per-sequence numbers too.
Runs `shapetrack track --config` per config and sequence, then scores every config in one
TrackEval call (HOTA, CLEAR, Identity at IoU 0.5, as run_trackeval_mot.py). Needs the peers
venv (/work/peers/venv/bin/python). Never used at test time.
"""
import contextlib, io, json, os, shutil, subprocess, sys
import numpy as np
for _a, _t in (("float", float), ("int", int), ("bool", bool)):
    if not hasattr(np, _a):
        setattr(np, _a, _t)
import trackeval

SPLITS = {
    "train": ["ADL-Rundle-6", "ETH-Bahnhof", "ETH-Pedcross2", "KITTI-13", "PETS09-S2L1", "TUD-Campus"],
    "test": ["ADL-Rundle-8", "ETH-Sunnyday", "KITTI-17", "TUD-Stadtmitte", "Venice-2"],
}
SPLITS["all"] = sorted(SPLITS["train"] + SPLITS["test"])

here = os.path.dirname(os.path.abspath(__file__))
repo = os.path.normpath(os.path.join(here, "../../.."))
split, cfgfile = sys.argv[1:3]
BIN = os.environ.get("BIN", os.path.join(repo, "target/release/shapetrack"))
DATA = os.path.abspath(os.environ.get("DATA", os.path.join(repo, "../shared/data/mot15-train")))
WORK = os.environ.get("WORK", "/tmp/shapetrack-tune")
seqs = SPLITS[split]

gt = os.path.join(WORK, f"gt_{split}")
os.makedirs(os.path.join(gt, "seqmaps"), exist_ok=True)
link = os.path.join(gt, "MOT15-train")
if not os.path.islink(link):
    os.symlink(DATA, link)
with open(os.path.join(gt, "seqmaps", "MOT15-train.txt"), "w") as f:
    f.write("name\n" + "".join(s + "\n" for s in seqs))

root = os.path.join(WORK, f"runs_{split}")
shutil.rmtree(root, ignore_errors=True)
cfgs = [json.loads(l) for l in open(cfgfile) if l.strip()]
names = []
for i, c in enumerate(cfgs):
    name = f"c{i:04d}"
    names.append(name)
    d = os.path.join(root, "MOT15-train", name, "data")
    os.makedirs(d)
    cp = os.path.join(root, "MOT15-train", name, "config.json")
    json.dump(c, open(cp, "w"))
    for s in seqs:
        subprocess.run([BIN, "track", "--det", f"{DATA}/{s}/det/det.txt", "--out", f"{d}/{s}.txt",
                        "--config", cp], check=True, stdout=subprocess.DEVNULL)

ec = trackeval.Evaluator.get_default_eval_config()
ec.update({"USE_PARALLEL": False, "PLOT_CURVES": False, "PRINT_CONFIG": False,
           "OUTPUT_DETAILED": False, "OUTPUT_SUMMARY": False, "PRINT_RESULTS": False,
           "TIME_PROGRESS": False, "DISPLAY_LESS_PROGRESS": True})
dc = trackeval.datasets.MotChallenge2DBox.get_default_dataset_config()
dc.update({"GT_FOLDER": gt, "TRACKERS_FOLDER": root, "BENCHMARK": "MOT15",
           "SPLIT_TO_EVAL": "train", "TRACKERS_TO_EVAL": names, "PRINT_CONFIG": False})
mc = {"METRICS": ["HOTA", "CLEAR", "Identity"], "THRESHOLD": 0.5}
with contextlib.redirect_stdout(io.StringIO()):
    res, _ = trackeval.Evaluator(ec).evaluate(
        [trackeval.datasets.MotChallenge2DBox(dc)],
        [trackeval.metrics.HOTA(mc), trackeval.metrics.CLEAR(mc), trackeval.metrics.Identity(mc)])


def line(p):
    return "HOTA %.3f AssA %.3f DetA %.3f IDF1 %.3f IDSW %d MOTA %.3f" % (
        100 * np.mean(p["HOTA"]["HOTA"]), 100 * np.mean(p["HOTA"]["AssA"]),
        100 * np.mean(p["HOTA"]["DetA"]), 100 * p["Identity"]["IDF1"], p["CLEAR"]["IDSW"],
        100 * p["CLEAR"]["MOTA"])


rows = []
for name, c in zip(names, cfgs):
    r = res["MotChallenge2DBox"][name]
    if os.environ.get("PERSEQ"):
        print(json.dumps(c))
        for seq, v in r.items():
            print("   %-16s %s" % (seq, line(v["pedestrian"])))
    p = r["COMBINED_SEQ"]["pedestrian"]
    rows.append((np.mean(p["HOTA"]["HOTA"]), line(p), c))
for _, l, c in sorted(rows, key=lambda r: -r[0]):
    print(l, json.dumps(c))
