"""Reference numbers from the official VOT toolkit (vot-toolkit 0.9.0 on PyPI) on VOT "bag".

Run once, offline, output committed (the Rust tests never run Python):

    python3 -m venv /tmp/votvenv
    /tmp/votvenv/bin/pip install vot-toolkit==0.9.0 attributee==0.1.9
    /tmp/votvenv/bin/python tests/data/vot/make_toolkit_fixture.py

(attributee 0.1.10 does not import on Python 3.11, hence the pin.)

It builds a throw-away workspace around ../shared/data/vot-bag (images symlinked), writes an
`anchor.value` file (anchors every 50 frames, each run towards the longer side: what
`shapetrack::eval::vot::anchors_every(196, 50)` gives), writes the result files of three
synthetic trackers for the VOT2020 multistart experiment and for a VOT2019-style supervised
(reset) experiment, runs `vot analysis`, and stores here:

- `bag_anchor.value`: the anchors;
- `results/<tracker>/baseline/bag_XXXXXXXX.txt`: multistart trajectories (toolkit naming);
- `results/<tracker>/reset/bag_001.txt`: reset-protocol trajectories;
- `toolkit_reference.json`: the toolkit's A, R, EAO (multistart) and A, failures,
  robustness, EAO (supervised) per tracker.

Trackers: `perfect` returns the ground truth; `shifted` returns it moved 200 px right in
frames 60..75 (0-based, inclusive); `constant` returns the axis-aligned box of the
initialisation polygon in every frame (a rectangle against polygon ground truth).
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

from vot.region import Special, calculate_overlap
from vot.region.io import parse_region

HERE = os.path.dirname(os.path.abspath(__file__))
BAG = os.path.normpath(os.path.join(HERE, "..", "..", "..", "..", "shared", "data", "vot-bag"))
if not os.path.isdir(BAG):
    BAG = "/work/shared/data/vot-bag"
SIZE = (480, 360)
SHIFT = (60, 75)

gt_lines = [l.strip() for l in open(os.path.join(BAG, "groundtruth.txt")) if l.strip()]
gt = [parse_region(l) for l in gt_lines]
n = len(gt)


def anchors(num, spacing=50):
    out = []
    for f in range(0, num, spacing):
        out.append((f, num - f >= f + 1))
    return out


def fmt(v):
    return repr(float(v))


def shifted_line(line, dx):
    vals = [float(v) for v in line.split(",")]
    return ",".join(fmt(v + (dx if i % 2 == 0 else 0)) for i, v in enumerate(vals))


def box_of(line):
    vals = [float(v) for v in line.split(",")]
    xs, ys = vals[0::2], vals[1::2]
    return f"{fmt(min(xs))},{fmt(min(ys))},{fmt(max(xs) - min(xs))},{fmt(max(ys) - min(ys))}"


def tracker_output(name, start, frame):
    """The line a tracker initialised in `start` reports for `frame`."""
    if name == "perfect":
        return gt_lines[frame]
    if name == "shifted":
        return shifted_line(gt_lines[frame], 200.0) if SHIFT[0] <= frame <= SHIFT[1] else gt_lines[frame]
    if name == "constant":
        return box_of(gt_lines[start])
    raise ValueError(name)


TRACKERS = ["perfect", "shifted", "constant"]

work = tempfile.mkdtemp(prefix="vot-fixture-")
try:
    seqdir = os.path.join(work, "sequences", "bag")
    os.makedirs(seqdir)
    with open(os.path.join(work, "sequences", "list.txt"), "w") as fp:
        fp.write("bag\n")
    for f in sorted(os.listdir(BAG)):
        if f.endswith(".jpg"):
            os.symlink(os.path.join(BAG, f), os.path.join(seqdir, f))
    shutil.copy(os.path.join(BAG, "groundtruth.txt"), seqdir)
    anchor_lines = ["0"] * n
    for f, fwd in anchors(n):
        anchor_lines[f] = "1" if fwd else "-1"
    anchor_text = "\n".join(anchor_lines) + "\n"
    with open(os.path.join(seqdir, "anchor.value"), "w") as fp:
        fp.write(anchor_text)
    with open(os.path.join(HERE, "bag_anchor.value"), "w") as fp:
        fp.write(anchor_text)

    with open(os.path.join(work, "stack.yaml"), "w") as fp:
        fp.write("""title: shapetrack fixture
experiments:
  baseline:
    type: multistart
    analyses:
      - type: multistart_eao_score
        name: eaoscore
        low: 115
        high: 755
      - type: multistart_average_ar
        name: ar
  reset:
    type: supervised
    repetitions: 1
    skip_initialize: 5
    analyses:
      - type: supervised_average_ar
        name: ar
        sensitivity: 30
      - type: supervised_eao_score
        name: eaoscore
        low: 46
        high: 291
""")
    with open(os.path.join(work, "config.yaml"), "w") as fp:
        fp.write("registry:\n- ./trackers.ini\nstack: ./stack.yaml\n")
    with open(os.path.join(work, "trackers.ini"), "w") as fp:
        for t in TRACKERS:
            fp.write(f"[{t}]\nlabel = {t}\nprotocol = traxpython\ncommand = none\n\n")

    out_results = os.path.join(HERE, "results")
    shutil.rmtree(out_results, ignore_errors=True)
    for t in TRACKERS:
        # Multistart: one trajectory per anchor in run order, "1" at the anchor.
        d = os.path.join(work, "results", t, "baseline", "bag")
        os.makedirs(d)
        os.makedirs(os.path.join(out_results, t, "baseline"))
        for f, fwd in anchors(n):
            frames = list(range(f, n)) if fwd else list(reversed(range(0, f + 1)))
            lines = ["1"] + [tracker_output(t, f, k) for k in frames[1:]]
            name = "bag_%08d.txt" % f
            for target in (os.path.join(d, name), os.path.join(out_results, t, "baseline", name)):
                with open(target, "w") as fp:
                    fp.write("\n".join(lines) + "\n")
        # Supervised (reset): the toolkit's SupervisedExperiment.execute loop.
        traj = ["0"] * n
        frame = 0
        while frame < n:
            traj[frame] = "1"
            start = frame
            frame += 1
            while frame < n:
                line = tracker_output(t, start, frame)
                if calculate_overlap(parse_region(line), gt[frame], SIZE) <= 0:
                    traj[frame] = "2"
                    frame += 5
                    break
                traj[frame] = line
                frame += 1
        d = os.path.join(work, "results", t, "reset", "bag")
        os.makedirs(d)
        os.makedirs(os.path.join(out_results, t, "reset"))
        for target in (os.path.join(d, "bag_001.txt"), os.path.join(out_results, t, "reset", "bag_001.txt")):
            with open(target, "w") as fp:
                fp.write("\n".join(traj) + "\n")

    vot = os.path.join(os.path.dirname(sys.executable), "vot")
    subprocess.run([vot, "analysis", "--workspace", work, "--format", "json", "--name", "ref"] + TRACKERS,
                   check=True)
    adir = os.path.join(work, "analysis")
    found = [os.path.join(r, f) for r, _, fs in os.walk(adir) for f in fs if f.endswith(".json")]
    report = json.load(open(found[0]))
    # Analyses come back in stack order: baseline = [eaoscore, ar], reset = [ar, eaoscore];
    # one entry per tracker in the order given on the command line.
    base = report["results"]["baseline"]["results"]
    reset = report["results"]["reset"]["results"]
    ref = {"toolkit": report["toolkit"], "sequence": report["sequences"]["bag"], "trackers": {}}
    for i, t in enumerate(TRACKERS):
        a, r = base[1][i][0], base[1][i][1]
        ra = reset[0][i]
        ref["trackers"][t] = {
            "anchor": {"accuracy": a, "robustness": r, "eao": base[0][i][0],
                       "accuracy_weight": base[1][i][3], "robustness_weight": base[1][i][4]},
            "reset": {"accuracy": ra[0], "failures": ra[1], "robustness": ra[2][0],
                      "eao": reset[1][i][0]},
        }
    with open(os.path.join(HERE, "toolkit_reference.json"), "w") as fp:
        json.dump(ref, fp, indent=1, sort_keys=True)
        fp.write("\n")
    print(json.dumps(ref, indent=1))
finally:
    shutil.rmtree(work, ignore_errors=True)
