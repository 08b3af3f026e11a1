"""shapetrack: the multi-object shape tracker's Rust core, for Python.

Online tracking one frame at a time (:class:`Tracker`), the offline pass over a whole video
(:class:`OfflineTracker`), the CLI's detectors (:func:`detect`, :func:`detect_files`: motion
cues, box refinement, and the learned segmentation where its model is installed), following
one target from a first mask (:func:`follow`), whole sequences from files as the CLI's
``track`` does (:func:`track_files`), and the CLI's ``eval`` (:func:`evaluate`). Batch runs over a video
library on Ray: ``python -m shapetrack.batch`` (:mod:`shapetrack.batch`).

Settings are the same JSON objects as everywhere in shapetrack (the CLI's ``--config`` files,
the JS ``Tracker``): name only what changes, over a preset (``{"preset": "masks",
"max_lost": 60}``); a wrong or unknown field is a ``ValueError`` naming it.

Every call that does work releases the GIL. Bad input raises ``TypeError`` (wrong kind of
value) or ``ValueError`` (wrong shape or value), the message starting with the argument's name.

>>> import numpy as np, shapetrack
>>> t = shapetrack.Tracker()
>>> for x in (10.0, 14.0, 18.0, 22.0):
...     tracks = t.update(np.array([[x, 20.0, 30.0, 60.0]]), np.array([0.9]))
>>> sorted(set(tracks.tracker_id.tolist()))
[1]
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _native

__all__ = [
    "Tracker",
    "OfflineTracker",
    "Tracks",
    "Detections",
    "detect",
    "detect_files",
    "follow",
    "track_files",
    "evaluate",
    "__version__",
]

__version__: str = _native.__version__

PathLike = Union[str, "os.PathLike[str]"]


@dataclass
class Tracks:
    """Tracked shapes as numpy arrays, one row per shape.

    ``tracker_id`` (int64), ``frame`` (int64, 1-based, the tracker's count of frames),
    ``xywh`` (float64, n×4: left, top, width, height), ``score`` (float64), ``class_id``
    (int32, -1 unknown), ``detection_index`` (int64: the row of that frame's input it came
    from, -1 when filled in), ``interpolated`` (bool), ``mask`` (bool n×h×w, or ``None`` in
    box mode).
    """

    tracker_id: np.ndarray
    frame: np.ndarray
    xywh: np.ndarray
    score: np.ndarray
    class_id: np.ndarray
    detection_index: np.ndarray
    interpolated: np.ndarray
    mask: Optional[np.ndarray]

    def __len__(self) -> int:
        return int(self.tracker_id.shape[0])

    @property
    def xyxy(self) -> np.ndarray:
        """Boxes as corners (x1, y1, x2, y2)."""
        b = self.xywh
        return np.concatenate([b[:, :2], b[:, :2] + b[:, 2:]], axis=1)


@dataclass
class Detections:
    """One frame's detections: ``xywh`` (float64 n×4), ``score`` (float64), ``class_id``
    (int32), ``mask`` (bool n×h×w)."""

    xywh: np.ndarray
    score: np.ndarray
    class_id: np.ndarray
    mask: np.ndarray

    def __len__(self) -> int:
        return int(self.xywh.shape[0])


def _config_json(config: Optional[Mapping[str, Any]], name: str = "config") -> Optional[str]:
    if config is None:
        return None
    if not isinstance(config, Mapping):
        raise TypeError(f"{name}: expected a dict of settings or None, got {type(config).__name__}")
    try:
        return json.dumps(dict(config), allow_nan=False)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{name}: not JSON settings: {e}") from None


def _array(name: str, value: Any) -> np.ndarray:
    if value is None:
        raise TypeError(f"{name}: expected an array, got None")
    try:
        a = np.asarray(value)
    except Exception as e:  # ragged lists and the like
        raise TypeError(f"{name}: not an array: {e}") from None
    if a.dtype == object or a.dtype.kind not in "biuf":
        raise TypeError(f"{name}: expected numbers, got dtype {a.dtype}")
    return a


def _frame_input(
    boxes: Any,
    scores: Any,
    classes: Any = None,
    masks: Any = None,
    frame: Any = None,
) -> tuple:
    """Checks one frame's arrays and turns them into the extension's bytes, naming the
    argument at fault."""
    b = _array("boxes", boxes)
    if b.size == 0 and b.ndim <= 2:
        b = b.reshape(0, 4)
    if b.ndim != 2 or b.shape[1] != 4:
        raise ValueError(f"boxes: expected shape (N, 4) as x, y, w, h, got {b.shape}")
    n = b.shape[0]
    s = _array("scores", scores)
    if s.shape != (n,):
        raise ValueError(f"scores: expected shape ({n},) to match boxes, got {s.shape}")
    c = None
    if classes is not None:
        ca = _array("classes", classes)
        if ca.dtype.kind not in "biu":
            raise TypeError(f"classes: expected integers, got dtype {ca.dtype}")
        if ca.shape != (n,):
            raise ValueError(f"classes: expected shape ({n},) to match boxes, got {ca.shape}")
        if ca.size and (ca.min() < -(2**31) or ca.max() >= 2**31):
            raise ValueError("classes: values must fit in 32 bits")
        c = np.ascontiguousarray(ca, dtype=np.int32).tobytes()
    height = width = 0
    f = None
    if frame is not None:
        fa = _array("frame", frame)
        if fa.dtype != np.uint8:
            raise TypeError(f"frame: expected dtype uint8 (RGB), got {fa.dtype}")
        if fa.ndim != 3 or fa.shape[2] != 3:
            raise ValueError(f"frame: expected shape (H, W, 3), got {fa.shape}")
        height, width = fa.shape[:2]
        f = np.ascontiguousarray(fa).tobytes()
    m = None
    if masks is not None:
        ma = _array("masks", masks)
        if ma.dtype != np.bool_:
            raise TypeError(f"masks: expected dtype bool, got {ma.dtype}")
        if ma.ndim != 3 or ma.shape[0] != n:
            raise ValueError(f"masks: expected shape ({n}, H, W) to match boxes, got {ma.shape}")
        if frame is not None and ma.shape[1:] != (height, width):
            raise ValueError(f"masks: {ma.shape[1:]} pixels, but the frame is {(height, width)}")
        height, width = ma.shape[1:]
        m = np.ascontiguousarray(ma, dtype=np.uint8).tobytes()
    return (
        n,
        np.ascontiguousarray(b, dtype=np.float64).tobytes(),
        np.ascontiguousarray(s, dtype=np.float64).tobytes(),
        c,
        m,
        f,
        int(height),
        int(width),
    )


def _tracks(d: Mapping[str, Any]) -> Tracks:
    ids = np.frombuffer(d["tracker_id"], dtype=np.uint64).astype(np.int64)
    n = ids.shape[0]
    mask = None
    if d["mask"] is not None:
        mask = np.frombuffer(d["mask"], dtype=np.uint8).reshape(n, d["height"], d["width"]) != 0
    return Tracks(
        tracker_id=ids,
        frame=np.frombuffer(d["frame"], dtype=np.uint32).astype(np.int64),
        xywh=np.frombuffer(d["xywh"], dtype=np.float64).reshape(n, 4).copy(),
        score=np.frombuffer(d["score"], dtype=np.float64).copy(),
        class_id=np.frombuffer(d["class_id"], dtype=np.int32).copy(),
        detection_index=np.frombuffer(d["detection_index"], dtype=np.int64).copy(),
        interpolated=np.frombuffer(d["interpolated"], dtype=np.uint8) != 0,
        mask=mask,
    )


class Tracker:
    """The online tracker: one :meth:`update` per frame.

    ``config`` is a settings dict (``{"preset": "masks", "max_lost": 60}``); ``None`` is the
    default preset (tuned on MOTChallenge boxes).
    """

    def __init__(self, config: Optional[Mapping[str, Any]] = None) -> None:
        self._native = _native.NativeTracker(_config_json(config))

    @property
    def frame(self) -> int:
        """Frames seen so far."""
        return int(self._native.frame)

    def update(
        self,
        boxes: Any,
        scores: Any,
        classes: Any = None,
        masks: Any = None,
        frame: Any = None,
    ) -> Tracks:
        """One frame's detections in, the shapes the tracker reports out.

        ``boxes`` N×4 (x, y, w, h), ``scores`` N, ``classes`` N integers (optional), ``masks``
        N×H×W bool (optional; then each detection is its mask and its box the mask's own,
        as when MOTS input is read), ``frame`` H×W×3 uint8 RGB (optional; appearance terms
        use it). The result holds this frame's shapes and, when a track is confirmed, the
        earlier frames it was tentative in (see ``Tracks.frame``).
        """
        return _tracks(self._native.update(*_frame_input(boxes, scores, classes, masks, frame)))

    def update_with_detections(self, detections: Any) -> Any:
        """``supervision.Detections`` in, the same detections out with ``tracker_id`` set (-1
        for those not on a confirmed track this frame), as roboflow's ``trackers`` do. Uses
        ``xyxy``, ``confidence`` (1 when absent), ``class_id`` and ``mask`` when present."""
        try:
            xyxy = np.asarray(detections.xyxy, dtype=np.float64)
        except AttributeError:
            raise TypeError(
                f"detections: expected supervision.Detections, got {type(detections).__name__}"
            ) from None
        n = xyxy.shape[0]
        xyxy = xyxy.reshape(n, 4)
        boxes = np.concatenate([xyxy[:, :2], xyxy[:, 2:] - xyxy[:, :2]], axis=1)
        conf = getattr(detections, "confidence", None)
        scores = np.ones(n) if conf is None else conf
        tracks = self.update(
            boxes,
            scores,
            getattr(detections, "class_id", None),
            getattr(detections, "mask", None),
        )
        ids = np.full(n, -1, dtype=np.int64)
        now = (tracks.frame == self.frame) & (tracks.detection_index >= 0)
        ids[tracks.detection_index[now]] = tracks.tracker_id[now]
        import copy

        out = copy.copy(detections)
        out.tracker_id = ids
        return out


class OfflineTracker:
    """The offline mode: frames pushed one at a time (:meth:`push`), then :meth:`finish` runs
    the Kalman trajectory re-linker and gap filling over the whole video.

    ``config`` is an offline settings dict (``{"online": {"preset": "masks"}, "relink": {…},
    "fill": {…}}``, every part optional); ``fps`` the video's rate (the re-linker's time
    step); ``progress(phase, fraction)`` hears how far :meth:`finish` is.
    """

    def __init__(
        self,
        config: Optional[Mapping[str, Any]] = None,
        fps: float = 30.0,
        progress: Optional[Callable[[str, float], None]] = None,
    ) -> None:
        if progress is not None and not callable(progress):
            raise TypeError("progress: expected a callable(phase, fraction) or None")
        try:
            fps = float(fps)
        except (TypeError, ValueError):
            raise TypeError(f"fps: expected a number, got {type(fps).__name__}") from None
        self._native = _native.NativeOfflineTracker(_config_json(config), fps)
        self._progress = progress
        self.joins = 0
        """Joins the re-linker made (set by :meth:`finish`)."""
        self.filled = 0
        """Shapes the gap filling made (set by :meth:`finish`)."""

    @property
    def frames(self) -> int:
        """Frames pushed so far."""
        return int(self._native.frames)

    def push(
        self,
        boxes: Any,
        scores: Any,
        classes: Any = None,
        masks: Any = None,
        frame: Any = None,
    ) -> None:
        """One frame, with the arguments of :meth:`Tracker.update`."""
        self._native.push(*_frame_input(boxes, scores, classes, masks, frame))

    def finish(self, progress: Optional[Callable[[str, float], None]] = None) -> Tracks:
        """The offline pass; every shape of the video by (frame, id). Once only."""
        cb = progress if progress is not None else self._progress
        if cb is not None and not callable(cb):
            raise TypeError("progress: expected a callable(phase, fraction) or None")
        d = self._native.finish(cb)
        self.joins, self.filled = int(d["joins"]), int(d["filled"])
        return _tracks(d)


def _frames_of(frames: Any) -> Iterable[np.ndarray]:
    """A folder's frames (decoded by the core, natural order) or an iterable of arrays."""
    if isinstance(frames, (str, os.PathLike)):
        for p in _native.image_files(os.fspath(frames)):
            data, h, w = _native.read_frame(p)
            yield np.frombuffer(data, dtype=np.uint8).reshape(h, w, 3)
        return
    try:
        it = iter(frames)
    except TypeError:
        raise TypeError("frames: expected a folder path or an iterable of H×W×3 uint8 arrays") from None
    for k, f in enumerate(it):
        a = _array(f"frames[{k}]", f)
        if a.dtype != np.uint8 or a.ndim != 3 or a.shape[2] != 3:
            raise ValueError(f"frames[{k}]: expected an H×W×3 uint8 array, got {a.dtype} {a.shape}")
        yield a


def _warn(message: Optional[str]) -> None:
    # The CLI prints the same words on stderr and goes on with the weights-free path.
    if message:
        warnings.warn(message, RuntimeWarning, stacklevel=3)


def _model_arg(model: Optional[PathLike]) -> Optional[str]:
    if model is None:
        return None
    if not isinstance(model, (str, os.PathLike)):
        raise TypeError("model: expected a path, 'none' or None")
    return os.fspath(model)


def _segment_arg(segment: Optional[Mapping[str, Any]]) -> Optional[str]:
    if segment is None:
        return None
    if not isinstance(segment, Mapping):
        raise TypeError("segment: expected a dict of the learned segmentation's settings")
    return json.dumps(dict(segment))


def _boxes_arg(boxes: Any) -> Optional[list]:
    if boxes is None:
        return None
    out = []
    for k, b in enumerate(boxes):
        a = np.asarray(b, dtype=np.float64)
        if a.size == 0:
            out.append([])
            continue
        if a.ndim != 2 or a.shape[1] != 4:
            raise ValueError(f"boxes[{k}]: expected shape (N, 4) (x, y, w, h), got {a.shape}")
        out.append([tuple(r) for r in a.tolist()])
    return out


def detect(
    frames: Any,
    detector: Union[str, Callable[[np.ndarray], Any]] = "auto",
    boxes: Optional[Sequence[Any]] = None,
    model: Optional[PathLike] = None,
    segment: Optional[Mapping[str, Any]] = None,
) -> list:
    """Detections of every frame, in order: a list of :class:`Detections`.

    ``frames``: a folder of .jpg/.png (natural order, as the CLI reads it) or an iterable of
    H×W×3 uint8 arrays. ``detector``: the CLI's ``--detector`` values, the same detectors:

    - ``"auto"``: background subtraction or the moving-camera detector (chosen from how much
      the camera moves over the first frames), each blob and each salient region of the
      whole frame then segmented by the learned model (U²-Net-p), so objects that stand still
      are found too; ``"refine"``: each of ``boxes`` segmented by the learned model;
    - ``"auto-motion"``, ``"refine-colour"``: the same without the model (weights-free,
      ~100× faster natively); ``"background"``, ``"moving"``: one motion cue;
    - or a callable ``frame -> (boxes xywh, scores[, masks])`` for your own model.

    ``boxes``: per frame, an N×4 array of x, y, w, h (``refine``; with ``auto`` too, which
    then refines them). ``model``: the model file (u2netp.onnx), ``"none"`` for the
    weights-free path, or ``None`` for the installed one (``$SHAPETRACK_U2NETP``, a checkout's
    node_modules); when it is not installed, ``auto`` and ``refine`` warn
    (``RuntimeWarning``) and go on without it, as the CLI does. ``segment``: the learned
    segmentation's settings over its defaults (the CLI's ``--segment``).
    """
    out = []
    if callable(detector):
        for f in _frames_of(frames):
            r = detector(f)
            bx, scores = np.asarray(r[0], dtype=np.float64), np.asarray(r[1], dtype=np.float64)
            n = bx.reshape(-1, 4).shape[0]
            masks = np.asarray(r[2], dtype=bool) if len(r) > 2 and r[2] is not None else np.zeros((n,) + f.shape[:2], bool)
            out.append(Detections(bx.reshape(n, 4), scores.reshape(n), np.full(n, -1, np.int32), masks))
        return out
    if not isinstance(detector, str):
        raise TypeError("detector: expected a name or a callable")
    native = _native.NativeDetector(
        detector, _boxes_arg(boxes), _model_arg(model), _segment_arg(segment)
    )
    _warn(native.warning)
    for f in _frames_of(frames):
        h, w = f.shape[:2]
        d = native.detect(np.ascontiguousarray(f).tobytes(), h, w)
        xywh = np.frombuffer(d["xywh"], dtype=np.float64).reshape(-1, 4).copy()
        n = xywh.shape[0]
        out.append(
            Detections(
                xywh=xywh,
                score=np.frombuffer(d["score"], dtype=np.float64).copy(),
                class_id=np.frombuffer(d["class_id"], dtype=np.int32).copy(),
                mask=np.frombuffer(d["mask"], dtype=np.uint8).reshape(n, h, w) != 0,
            )
        )
    return out


def detect_files(
    frames: PathLike,
    out: PathLike,
    detector: str = "auto",
    boxes: Optional[PathLike] = None,
    model: Optional[PathLike] = None,
    segment: Optional[Mapping[str, Any]] = None,
) -> dict:
    """``shapetrack detect --frames FRAMES [--detector D] [--boxes B.txt] [--model M|none]
    [--segment JSON] --out OUT``: the same detector over the folder, ``out`` the same MOTS
    bytes (id -1), written atomically. ``boxes``: a MOTChallenge file. Returns ``frames``,
    ``masks`` and ``detector`` (its name, ``+ learned segmentation`` when the model ran)."""
    if not isinstance(detector, str):
        raise TypeError("detector: expected one of the CLI's --detector names")
    n, masks, name, warning = _native.detect_files(
        os.fspath(frames),
        os.fspath(out),
        detector,
        None if boxes is None else os.fspath(boxes),
        _model_arg(model),
        _segment_arg(segment),
    )
    _warn(warning)
    return {"frames": n, "masks": masks, "detector": name}


@dataclass
class Followed:
    """One target through a video: ``mask`` (bool n×h×w), ``confidence`` (float64 n), ``lost``
    (bool n: the mask is a prediction there)."""

    mask: np.ndarray
    confidence: np.ndarray
    lost: np.ndarray


def follow(
    frames: Any,
    mask: Any,
    init_frame: int = 0,
    config: Optional[Mapping[str, Any]] = None,
    model: Optional[PathLike] = None,
) -> Followed:
    """Follows one target given by ``mask`` (H×W bool) at frame ``init_frame`` (0-based),
    forward to the end and backward to the start, without a detector: ``shapetrack follow
    --detector none [--model M|none]``, the same masks. ``frames`` as in :func:`detect`;
    ``config`` a ``FollowConfig``; ``model`` as in :func:`detect` (the learned segmentation
    re-anchors the shape when it drifts; ``"none"`` for the weights-free follower)."""
    fs = [np.ascontiguousarray(f) for f in _frames_of(frames)]
    if not fs:
        raise ValueError("frames: no frames")
    h, w = fs[0].shape[:2]
    for k, f in enumerate(fs):
        if f.shape[:2] != (h, w):
            raise ValueError(f"frames[{k}]: {f.shape[:2]} pixels, the first frame is {(h, w)}")
    m = _array("mask", mask)
    if m.dtype != np.bool_:
        raise TypeError(f"mask: expected dtype bool, got {m.dtype}")
    if m.shape != (h, w):
        raise ValueError(f"mask: expected shape {(h, w)} as the frames, got {m.shape}")
    if not isinstance(init_frame, (int, np.integer)) or isinstance(init_frame, bool):
        raise TypeError("init_frame: expected an int")
    if not 0 <= init_frame < len(fs):
        raise ValueError(f"init_frame: {init_frame} is outside 0..{len(fs) - 1}")
    d = _native.follow_frames(
        b"".join(f.tobytes() for f in fs),
        len(fs),
        h,
        w,
        m.astype(np.uint8).tobytes(),
        int(init_frame),
        _config_json(config),
        _model_arg(model),
    )
    _warn(d["warning"])
    n = len(fs)
    return Followed(
        mask=np.frombuffer(d["mask"], dtype=np.uint8).reshape(n, h, w) != 0,
        confidence=np.frombuffer(d["confidence"], dtype=np.float64).copy(),
        lost=np.frombuffer(d["lost"], dtype=np.uint8) != 0,
    )


def track_files(
    det: PathLike,
    out: PathLike,
    frames: Optional[PathLike] = None,
    seqinfo: Optional[PathLike] = None,
    offline: bool = False,
    preset: Optional[str] = None,
    config: Optional[PathLike] = None,
    fps: Optional[float] = None,
) -> dict:
    """``shapetrack track --det DET [--frames F] [--seqinfo S] [--offline] [--preset P]
    [--config C] --out OUT``: the same library call, so ``out`` equals the CLI's bit for bit
    (mask input is written as MOTS whatever the extension). Written atomically. Returns the
    run's counts (``frames``, ``detections``, ``tracks``, ``shapes``, ``core_seconds``, …)."""
    fs = lambda p: None if p is None else os.fspath(p)  # noqa: E731
    return dict(
        _native.track_files(
            fs(det), fs(out), fs(frames), fs(seqinfo), bool(offline), preset, fs(config), fps
        )
    )


def evaluate(
    gt: PathLike,
    results: PathLike,
    benchmark: str = "MOT15",
    split: str = "train",
    seqs: Optional[Sequence[str]] = None,
    masks: bool = False,
    threshold: float = 0.5,
) -> dict:
    """CLEAR, Identity and HOTA as ``shapetrack eval --gt GT --tracker RESULTS --benchmark B
    --json F`` gives them (equal to TrackEval): ``{"sequences": {name: row}, "combined":
    row}``, each row ``{"HOTA": …, "DetA": …, "MOTA": …, "IDF1": …, "IDSW": …, …}``.

    ``results`` holds one ``<seq>.txt`` per sequence (the layout ``shapetrack.batch`` writes).
    """
    text = _native.evaluate(
        os.fspath(gt),
        os.fspath(results),
        benchmark,
        split,
        None if seqs is None else list(seqs),
        bool(masks),
        float(threshold),
    )
    return json.loads(text)
