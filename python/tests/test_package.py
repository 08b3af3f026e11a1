"""The package against the CLI, bit for bit, and its API's contracts (types, errors naming the
argument, the supervision adapter, the offline progress callback)."""

from __future__ import annotations

import json
import subprocess
import threading
from pathlib import Path

import numpy as np
import pytest

import shapetrack
from conftest import DATA, MOT15, mot15_sequences


def test_track_files_equals_the_cli_on_every_mot15_sequence(cli_outputs, tmp_path):
    # Catches any drift between `shapetrack track` and the package's run of a sequence
    # (settings, frame loop, output writing): both must be the one library call.
    assert len(cli_outputs) == 11
    for seq in mot15_sequences():
        out = tmp_path / f"{seq.name}.txt"
        s = shapetrack.track_files(seq / "det" / "det.txt", out)
        assert out.read_bytes() == cli_outputs[seq.name], seq.name
        assert s["frames"] > 0 and s["tracks"] > 0 and not s["masks"]


def test_offline_and_a_preset_equal_the_cli(cli, tmp_path):
    # The offline pass and the flags the batch passes through (--offline, --preset, --config).
    seq = MOT15 / "TUD-Campus"
    cfg = tmp_path / "c.json"
    cfg.write_text(json.dumps({"max_lost": 40}))
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    subprocess.run(
        [str(cli), "track", "--det", str(seq / "det/det.txt"), "--offline", "--preset", "masks",
         "--config", str(cfg), "--out", str(a)],
        check=True, capture_output=True,
    )
    s = shapetrack.track_files(seq / "det/det.txt", b, offline=True, preset="masks", config=cfg)
    assert a.read_bytes() == b.read_bytes()
    assert "joins" in s


def test_evaluate_gives_the_cli_eval_figures(cli, cli_outputs, tmp_path):
    # Catches an eval setting (preprocessing, threshold, similarity) that differs from `eval`.
    res = tmp_path / "res"
    res.mkdir()
    for name, text in cli_outputs.items():
        (res / f"{name}.txt").write_bytes(text)
    j = tmp_path / "scores.json"
    subprocess.run(
        [str(cli), "eval", "--gt", str(MOT15), "--tracker", str(res), "--benchmark", "MOT15", "--json", str(j)],
        check=True, capture_output=True,
    )
    ours = shapetrack.evaluate(MOT15, res, benchmark="MOT15")
    assert ours == json.loads(j.read_text())
    assert 30 < ours["combined"]["HOTA"] < 60


def walker(n=6):
    """One box walking right, then a second appearing."""
    for k in range(n):
        boxes = [[10.0 + 4 * k, 20.0, 30.0, 60.0]]
        if k >= 2:
            boxes.append([200.0, 40.0 + 2 * k, 25.0, 50.0])
        yield np.array(boxes), np.full(len(boxes), 0.95)


def test_tracker_keeps_one_identity_per_walker():
    t = shapetrack.Tracker({"preset": "default"})
    seen = []
    for boxes, scores in walker(12):
        tr = t.update(boxes, scores, classes=np.arange(len(boxes)))
        assert tr.xywh.shape == (len(tr), 4) and tr.mask is None
        seen.append(tr)
    last = seen[-1]
    assert sorted(last.tracker_id.tolist()) == [1, 2]
    assert set(last.class_id.tolist()) == {0, 1}
    assert t.frame == 12


def test_masks_and_frame_give_masks_back():
    h, w = 120, 160
    t = shapetrack.Tracker({"preset": "masks"})
    frame = np.zeros((h, w, 3), np.uint8)
    for k in range(10):
        m = np.zeros((1, h, w), bool)
        m[0, 30:70, 20 + 3 * k : 50 + 3 * k] = True
        frame[:] = 40
        frame[m[0]] = (200, 30, 30)
        tr = t.update(np.array([[20.0 + 3 * k, 30, 30, 40]]), np.array([0.99]), masks=m, frame=frame)
    assert tr.mask is not None and tr.mask.shape == (len(tr), h, w)
    assert tr.mask[tr.frame == 10].sum() > 0


@pytest.mark.parametrize(
    "kwargs, exc, field",
    [
        (dict(boxes=np.zeros((2, 3)), scores=np.ones(2)), ValueError, "boxes"),
        (dict(boxes=np.zeros((2, 4)), scores=np.ones(3)), ValueError, "scores"),
        (dict(boxes=np.zeros((2, 4)), scores=["a", "b"]), TypeError, "scores"),
        (dict(boxes=None, scores=np.ones(2)), TypeError, "boxes"),
        (dict(boxes=np.zeros((1, 4)), scores=np.ones(1), classes=np.array([0.5])), TypeError, "classes"),
        (dict(boxes=np.zeros((1, 4)), scores=np.ones(1), masks=np.zeros((1, 4, 4), np.uint8)), TypeError, "masks"),
        (dict(boxes=np.zeros((1, 4)), scores=np.ones(1), masks=np.zeros((2, 4, 4), bool)), ValueError, "masks"),
        (dict(boxes=np.zeros((1, 4)), scores=np.ones(1), frame=np.zeros((4, 4, 3), np.float32)), TypeError, "frame"),
        (dict(boxes=np.zeros((1, 4)), scores=np.ones(1), frame=np.zeros((4, 4)), ), TypeError, "frame"),
        (dict(boxes=np.array([[np.nan, 0, 1, 1]]), scores=np.ones(1)), ValueError, r"boxes\[0\].*bbox\.x"),
        (dict(boxes=np.array([[0, 0, -1, 1]]), scores=np.ones(1)), ValueError, r"boxes\[0\].*bbox\.w"),
        (dict(boxes=np.zeros((1, 4)), scores=np.array([np.inf])), ValueError, r"scores\[0\]"),
    ],
)
def test_bad_input_names_the_field(kwargs, exc, field):
    t = shapetrack.Tracker()
    with pytest.raises(exc, match=field):
        t.update(**kwargs)
    # A refused frame changes nothing: the tracker goes on.
    t.update(np.zeros((0, 4)), np.zeros(0))
    assert t.frame == 1


def test_bad_config_names_the_field():
    with pytest.raises(ValueError, match="max_lots"):
        shapetrack.Tracker({"max_lots": 3})
    with pytest.raises(ValueError, match="preset"):
        shapetrack.Tracker({"preset": "fast"})
    with pytest.raises(TypeError, match="config"):
        shapetrack.Tracker("masks")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="fps"):
        shapetrack.OfflineTracker(fps=0)


def test_update_releases_the_gil():
    # Two threads, two trackers: while one is inside the core the other's Python runs. A
    # counter in a third thread advances during a long update only if the GIL is free.
    t = shapetrack.Tracker()
    rng = np.random.default_rng(1)
    boxes = np.column_stack([rng.uniform(0, 2000, 1500), rng.uniform(0, 2000, 1500),
                             np.full(1500, 30.0), np.full(1500, 60.0)])
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)

    th = threading.Thread(target=count)
    th.start()
    try:
        before = len(ticks)
        for _ in range(3):
            t.update(boxes, np.full(1500, 0.95))
        during = len(ticks) - before
    finally:
        stop.set()
        th.join()
    assert during > 0


def test_offline_tracker_reports_progress():
    phases = []
    ot = shapetrack.OfflineTracker({"online": {"preset": "default"}}, fps=25, progress=lambda p, f: phases.append((p, f)))
    for boxes, scores in walker(12):
        ot.push(boxes, scores)
    assert ot.frames == 12
    tr = ot.finish()
    assert phases and phases[-1][0] == "done"
    assert np.all(np.diff(tr.frame) >= 0), "by (frame, id)"
    with pytest.raises(ValueError, match="finished"):
        ot.finish()


def test_supervision_adapter_sets_tracker_ids():
    sv = pytest.importorskip("supervision")
    t = shapetrack.Tracker()
    ids = []
    for boxes, scores in walker(12):
        xyxy = np.concatenate([boxes[:, :2], boxes[:, :2] + boxes[:, 2:]], axis=1)
        det = sv.Detections(xyxy=xyxy, confidence=scores, class_id=np.zeros(len(boxes), int))
        out = t.update_with_detections(det)
        assert isinstance(out, sv.Detections) and len(out) == len(det)
        assert det.tracker_id is None, "the input is not changed"
        np.testing.assert_array_equal(out.xyxy, det.xyxy)
        ids.append(out.tracker_id.tolist())
    # Tentative first (-1), then one stable id per walker, as roboflow's trackers report.
    assert ids[0] == [-1]
    assert ids[-1][0] == ids[-2][0] != -1 and ids[-1][1] == ids[-2][1] != -1
    assert ids[-1][0] != ids[-1][1]
    with pytest.raises(TypeError, match="detections"):
        t.update_with_detections([[0, 0, 1, 1]])


DAVIS = DATA / "davis-car-shadow" / "DAVIS"


def _frames(tmp_path: Path, n: int) -> Path:
    src = DAVIS / "JPEGImages" / "480p" / "car-shadow"
    dst = tmp_path / "frames"
    dst.mkdir()
    for p in sorted(src.iterdir())[:n]:
        (dst / p.name).symlink_to(p)
    return dst


def test_detect_equals_the_cli_weights_free_detector(cli, tmp_path):
    frames = _frames(tmp_path, 8)
    a, b = tmp_path / "cli.txt", tmp_path / "py.txt"
    subprocess.run(
        [str(cli), "detect", "--frames", str(frames), "--detector", "auto-motion", "--out", str(a)],
        check=True, capture_output=True,
    )
    r = shapetrack.detect_files(frames, b, detector="auto-motion")
    assert a.read_bytes() == b.read_bytes()
    assert r["frames"] == 8 and "learned" not in r["detector"]
    dets = shapetrack.detect(frames, detector="auto-motion")
    assert len(dets) == 8 and all(d.mask.shape[1:] == (480, 854) for d in dets)
    with pytest.raises(ValueError, match="detector"):
        shapetrack.detect(frames, detector="yolo")
    with pytest.raises(ValueError, match="boxes"):
        shapetrack.detect(frames, detector="refine")
    with pytest.raises(ValueError, match="segment"):
        shapetrack.detect(frames, detector="auto-motion", segment={"treshold": 0.4})
    with pytest.raises(ValueError, match="model"):
        shapetrack.detect(frames, detector="auto", model=tmp_path / "missing.onnx")


def _gt_mask(k: int) -> np.ndarray:
    ann = sorted((DAVIS / "Annotations" / "480p" / "car-shadow").iterdir())[k]
    rgb, h, w = shapetrack._native.read_frame(str(ann))
    return np.frombuffer(rgb, np.uint8).reshape(h, w, 3).any(axis=2)


def _box_of(m: np.ndarray) -> list:
    ys, xs = np.nonzero(m)
    return [float(xs.min()), float(ys.min()), float(xs.max() - xs.min() + 1), float(ys.max() - ys.min() + 1)]


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def test_learned_refine_equals_the_cli(cli, tmp_path):
    # The learned segmentation (U²-Net-p through tract, installed by `npm ci`) turns given
    # boxes into masks: the package builds the CLI's very detector, so the bytes are equal.
    frames = _frames(tmp_path, 3)
    boxes = [_box_of(_gt_mask(k)) for k in range(3)]
    txt = tmp_path / "boxes.txt"
    txt.write_text("".join(f"{k + 1},-1,{x},{y},{w},{h},1,-1,-1,-1\n" for k, (x, y, w, h) in enumerate(boxes)))
    a, b = tmp_path / "cli.txt", tmp_path / "py.txt"
    subprocess.run(
        [str(cli), "detect", "--frames", str(frames), "--detector", "refine", "--boxes", str(txt), "--out", str(a)],
        check=True, capture_output=True,
    )
    r = shapetrack.detect_files(frames, b, detector="refine", boxes=txt)
    assert r["detector"] == "refine + learned segmentation", r
    assert a.read_bytes() == b.read_bytes()
    # In memory, boxes as arrays: the same masks, and they are the car's.
    dets = shapetrack.detect(frames, detector="refine", boxes=[np.array([bx]) for bx in boxes])
    for k, d in enumerate(dets):
        assert d.mask.shape[0] == 1 and _iou(d.mask[0], _gt_mask(k)) > 0.9
    # The weights-free refinement is another detector, with other masks.
    c = tmp_path / "colour.txt"
    shapetrack.detect_files(frames, c, detector="refine", boxes=txt, model="none")
    assert c.read_bytes() != a.read_bytes()


def _rle_decode(s: str, h: int, w: int) -> np.ndarray:
    """A pycocotools-compressed RLE string (MOTS) as an h×w bool mask."""
    counts, p = [], 0
    while p < len(s):
        x, k, more = 0, 0, True
        while more:
            c = ord(s[p]) - 48
            x |= (c & 0x1F) << (5 * k)
            more = bool(c & 0x20)
            p, k = p + 1, k + 1
            if not more and c & 0x10:
                x |= -1 << (5 * k)
        if len(counts) > 2:
            x += counts[-2]
        counts.append(x)
    flat = np.zeros(h * w, bool)
    pos = 0
    for i, c in enumerate(counts):
        flat[pos:pos + c] = i % 2 == 1
        pos += c
    return flat.reshape(w, h).T


@pytest.mark.parametrize("model", [None, "none"])
def test_follow_equals_the_cli(cli, tmp_path, model):
    # From the second frame's mask, forward and backward: `shapetrack follow --detector none`
    # with its learned model (the default) and without (`--model none`).
    frames = _frames(tmp_path, 4)
    ann = sorted((DAVIS / "Annotations" / "480p" / "car-shadow").iterdir())[1]
    out = tmp_path / "cli.txt"
    cmd = [str(cli), "follow", "--frames", str(frames), "--init", str(ann), "--init-frame", "2",
           "--detector", "none", "--out", str(out)]
    subprocess.run(cmd + (["--model", model] if model else []), check=True, capture_output=True)
    f = shapetrack.follow(frames, _gt_mask(1), init_frame=1, model=model)
    cli_masks = np.zeros_like(f.mask)
    for line in out.read_text().splitlines():
        fr, _id, _cls, h, w, rle = line.split(" ", 5)
        cli_masks[int(fr) - 1] = _rle_decode(rle, int(h), int(w))
    assert cli_masks.any(axis=(1, 2)).all()
    assert np.array_equal(cli_masks, f.mask)


def test_follow_keeps_the_target(tmp_path):
    frames = _frames(tmp_path, 5)
    ann = sorted((DAVIS / "Annotations" / "480p" / "car-shadow").iterdir())[0]
    rgb, h, w = shapetrack._native.read_frame(str(ann))
    mask = np.frombuffer(rgb, np.uint8).reshape(h, w, 3).any(axis=2)
    f = shapetrack.follow(frames, mask, init_frame=0)
    assert f.mask.shape == (5, h, w) and f.confidence[0] == 1.0
    inter = (f.mask[4] & mask).sum() / max((f.mask[4] | mask).sum(), 1)
    assert inter > 0.3
