"""Pre-label a whole video library: one Ray task per manifest line.

    python -m shapetrack.batch --manifest M.txt --out DIR [--address RAY_ADDRESS] [--offline]
                               [--preset P] [--config C.json] [--workers N]
                               [--detector auto-motion|auto]

Each manifest line (blank lines and ``#`` comments skipped) is a folder, a local path or an
fsspec URL (``file://``, ``s3://``, ``gs://``, … with the matching fsspec package installed):

- a MOTChallenge sequence: ``det/det.txt``, ``seqinfo.ini``, optional ``img1/`` (then used for
  appearance). Tracked as ``shapetrack track --det SEQ/det/det.txt [--frames SEQ/img1]
  [--offline] [--preset P] [--config C] --out DIR/<SEQ>.txt`` would, by the same library call,
  so the output is the CLI's bit for bit;
- or a folder of frames (.jpg/.png): the automatic detector runs first (the CLI's ``detect
  --detector auto-motion``, weights-free, by default; ``--detector auto`` adds the learned
  segmentation where its model is installed: far better masks, ~100× the detection time),
  then the masks are tracked.

Writes ``DIR/<sequence>.txt`` (MOT for boxes, MOTS for masks), each atomically (a temporary
file renamed into place), and ``DIR/summary.json`` (every 5 s while running, and at the end): per line its
status (ok | failed), error message, frames, tracks and seconds. A rerun skips the lines whose
output exists and is complete (written whole by an earlier run with the same settings). A bad
line fails alone; a task whose worker dies is retried (``--retries``). Without ``--address``,
Ray starts locally with ``--workers`` CPUs (default: all).

Memory: each task holds one sequence. Online, the core streams (one frame's detections and
image at a time; ``shapetrack track`` keeps 5.6 MB peak over 40,000 frames); offline, ~0.8 KB
per mask until the pass. Ray is told ``--task-memory-mb`` (default 512) per task, so it never
runs more tasks on a node than that node's memory holds.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import sys
import tempfile
import time
import uuid
from typing import Any, Optional

import shapetrack

SUMMARY = "summary.json"
IMAGE_EXT = (".jpg", ".jpeg", ".png")


# ---------------------------------------------------------------- files, local or fsspec URLs


def _fs(url: str):
    """The fsspec filesystem and path of a URL; a plain path is the local filesystem."""
    import fsspec

    return fsspec.core.url_to_fs(url)


def _is_local(url: str) -> bool:
    return "://" not in url or url.startswith("file://")


def _local_path(url: str) -> str:
    return url[len("file://") :] if url.startswith("file://") else url


def _join(base: str, name: str) -> str:
    return base.rstrip("/") + "/" + name


def _name(line: str) -> str:
    return line.rstrip("/").rsplit("/", 1)[-1]


def _stage_in(src: str, tmp: str) -> str:
    """A local folder holding what the run reads of ``src``: ``src`` itself when local,
    otherwise a copy in ``tmp`` of ``det/``, ``seqinfo.ini``, ``img1/`` and the frames."""
    if _is_local(src):
        return _local_path(src)
    fs, root = _fs(src)
    dst = os.path.join(tmp, "in")
    os.makedirs(dst, exist_ok=True)
    for entry in fs.ls(root, detail=True):
        name = entry["name"].rstrip("/").rsplit("/", 1)[-1]
        if entry["type"] == "directory" and name in ("det", "img1"):
            fs.get(entry["name"], os.path.join(dst, name), recursive=True)
        elif entry["type"] == "file" and (name == "seqinfo.ini" or name.lower().endswith(IMAGE_EXT)):
            fs.get(entry["name"], os.path.join(dst, name))
    return dst


def _publish(local: str, out_url: str) -> None:
    """Puts a finished local file at ``out_url`` so that it appears whole: local outputs are
    renamed into place by the core itself; remote ones are uploaded under a temporary name
    and moved (object stores make a whole object visible at once)."""
    fs, path = _fs(out_url)
    part = f"{path}.part-{uuid.uuid4().hex[:8]}"
    fs.put_file(local, part)
    fs.mv(part, path)


def _exists(url: str) -> Optional[int]:
    """The size of the file at ``url``, or ``None`` when there is none."""
    try:
        fs, path = _fs(url)
        return int(fs.size(path)) if fs.isfile(path) else None
    except (FileNotFoundError, OSError):
        return None


def _write_json(url: str, value: Any) -> None:
    """Writes JSON whole (temporary file, then renamed or uploaded)."""
    text = json.dumps(value, indent=2) + "\n"
    if _is_local(url):
        path = _local_path(url)
        tmp = f"{path}.tmp-{os.getpid()}"
        with open(tmp, "w") as f:
            f.write(text)
        os.replace(tmp, path)
        return
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        f.write(text)
    try:
        _publish(f.name, url)
    finally:
        os.unlink(f.name)


def _read_json(url: str) -> Optional[Any]:
    try:
        fs, path = _fs(url)
        with fs.open(path, "r") as f:
            return json.load(f)
    except (FileNotFoundError, OSError, ValueError):
        return None


# ---------------------------------------------------------------- one line


def run_line(line: str, out_dir: str, settings: dict) -> dict:
    """Tracks one manifest line and publishes its output. Never raises for a bad line: the
    error goes into the result (status ``failed``), so one bad line stops nothing else."""
    t0 = time.perf_counter()
    name = _name(line)
    res: dict = {"line": line, "name": name, "status": "failed", "error": None}
    res.update(frames=0, tracks=0, seconds=0.0, output=_join(out_dir, f"{name}.txt"))
    crash = os.environ.get("SHAPETRACK_BATCH_CRASH_ONCE")
    if crash and crash.startswith(name + ":"):
        # Test hook: the first attempt kills its worker, as a lost node would.
        marker = crash.split(":", 1)[1]
        if not os.path.exists(marker):
            open(marker, "w").close()
            os._exit(1)
    tmp = tempfile.mkdtemp(prefix="shapetrack-batch-")
    try:
        src = _stage_in(line, tmp)
        det = os.path.join(src, "det", "det.txt")
        img1 = os.path.join(src, "img1")
        out_local = (
            _local_path(res["output"]) if _is_local(out_dir) else os.path.join(tmp, f"{name}.txt")
        )
        kw = dict(offline=settings["offline"], preset=settings["preset"], config=settings["config"])
        res["stage_seconds"] = stages = {"stage_in": round(time.perf_counter() - t0, 3)}
        if os.path.isfile(det):
            frames = img1 if os.path.isdir(img1) else None
            t1 = time.perf_counter()
            s = shapetrack.track_files(det, out_local, frames=frames, **kw)
            stages["track"] = round(time.perf_counter() - t1, 3)
        elif os.path.isdir(src) and any(f.lower().endswith(IMAGE_EXT) for f in os.listdir(src)):
            masks = os.path.join(tmp, "det_mots.txt")
            t1 = time.perf_counter()
            warning = shapetrack._native.detect_files(src, masks, settings.get("detector", "auto-motion"))[3]
            if warning:
                res["warning"] = warning  # the model is not installed on this worker
            stages["detect"] = round(time.perf_counter() - t1, 3)
            t1 = time.perf_counter()
            s = shapetrack.track_files(masks, out_local, frames=src, **kw)
            stages["track"] = round(time.perf_counter() - t1, 3)
        else:
            raise ValueError(f"{line}: neither a MOTChallenge sequence (det/det.txt) nor a folder of .jpg/.png frames")
        if not _is_local(out_dir):
            _publish(out_local, res["output"])
        res.update(status="ok", frames=int(s["frames"]), tracks=int(s["tracks"]))
        # Inside `track`: the tracker's own time; the rest is reading and writing files.
        stages["tracker_core"] = round(float(s["core_seconds"]), 3)
        res["bytes"] = _exists(res["output"])
    except Exception as e:  # noqa: BLE001 - every failure is the line's own
        res["error"] = f"{type(e).__name__}: {e}"
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    res["seconds"] = round(time.perf_counter() - t0, 3)
    return res


# ---------------------------------------------------------------- the batch


def read_manifest(url: str) -> list[str]:
    """The manifest's lines: blank lines and ``#`` comments skipped."""
    fs, path = _fs(url)
    with fs.open(path, "r") as f:
        return [ln.strip() for ln in f if ln.strip() and not ln.strip().startswith("#")]


def _settings(args: argparse.Namespace) -> dict:
    config_text = None
    if args.config:
        fs, path = _fs(args.config)
        with fs.open(path, "r") as f:
            config_text = f.read()
        # Checked once, before any task: a typo is one clear error, not one per line.
        try:
            shapetrack._native.check_config(config_text)
        except ValueError as e:
            raise SystemExit(f"--config {args.config}: {e}") from None
    digest = hashlib.sha256((config_text or "").encode()).hexdigest()[:16]
    return {
        "offline": bool(args.offline),
        "preset": args.preset,
        "config": args.config,
        "config_sha256": digest,
        "detector": args.detector,
    }


class _Progress:
    """tqdm when installed, else one line per finished sequence."""

    def __init__(self, total: int, done: int) -> None:
        self.total, self.n = total, done
        try:
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=done, unit="seq", file=sys.stderr)
        except ImportError:
            self.bar = None

    def update(self, r: dict) -> None:
        self.n += 1
        if self.bar is not None:
            self.bar.set_postfix_str(f"{r['name']} {r['status']}")
            self.bar.update(1)
        else:
            print(f"[{self.n}/{self.total}] {r['name']}: {r['status']}", file=sys.stderr)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def main(argv: Optional[list[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="python -m shapetrack.batch", description=__doc__.split("\n\n")[0])
    p.add_argument("--manifest", required=True, help="one sequence folder (path or URL) per line")
    p.add_argument("--out", required=True, help="output folder (path or URL)")
    p.add_argument("--address", default=None, help="Ray cluster address (default: a local Ray)")
    p.add_argument("--offline", action="store_true", help="the offline pass after the online one")
    p.add_argument("--preset", choices=["default", "masks"], default=None)
    p.add_argument("--config", default=None, help="tracker settings JSON (path or URL)")
    p.add_argument(
        "--detector",
        choices=["auto-motion", "auto"],
        default="auto-motion",
        help="detector for frame folders (auto: with the learned segmentation, much slower)",
    )
    p.add_argument("--workers", type=int, default=None, help="local Ray's CPUs (default: all)")
    p.add_argument("--retries", type=int, default=3, help="retries of a task whose worker died")
    p.add_argument("--task-memory-mb", type=int, default=512, help="memory Ray reserves per task")
    args = p.parse_args(argv)
    if args.workers is not None and args.workers < 1:
        p.error("--workers must be at least 1")

    lines = read_manifest(args.manifest)
    names = [_name(ln) for ln in lines]
    settings = _settings(args)
    out = args.out.rstrip("/")
    fs, out_path = _fs(out)
    fs.makedirs(out_path, exist_ok=True)
    summary_url = _join(out, SUMMARY)

    # Resume: a line is done when an earlier run with these settings wrote it whole (the
    # size it recorded is the size found) or, without such a record, its output exists (the
    # core only ever renames a finished file into place).
    before = _read_json(summary_url) or {}
    same = before.get("settings") == settings
    prior = {r["line"]: r for r in before.get("lines", [])} if same else {}
    results: dict[str, dict] = {}
    todo: list[str] = []
    seen: set[str] = set()
    # One listing of DIR, not one request per line (10^5 lines on an object store).
    sizes = {
        e["name"].rstrip("/").rsplit("/", 1)[-1]: e.get("size")
        for e in fs.ls(out_path, detail=True)
        if e.get("type") == "file"
    }
    for line, name in zip(lines, names):
        if name in seen:
            results[line] = {"line": line, "name": name, "status": "failed", "frames": 0, "tracks": 0, "seconds": 0.0,
                             "error": f"another line is also named {name!r}: its output would be overwritten"}
            continue
        seen.add(name)
        size = sizes.get(f"{name}.txt")
        old = prior.get(line)
        if size is not None and (old is None and not before or old and old.get("status") == "ok" and old.get("bytes") == size):
            results[line] = dict(old or {"line": line, "name": name, "status": "ok", "error": None, "bytes": size,
                                          "frames": None, "tracks": None, "seconds": 0.0}, skipped=True)
        else:
            todo.append(line)

    ray_start = 0.0

    def write_summary(elapsed: float) -> None:
        rows = [results[ln] for ln in lines if ln in results]
        ran = [r for r in rows if not r.get("skipped")]
        _write_json(summary_url, {
            "settings": settings,
            "lines": rows,
            "ok": sum(r["status"] == "ok" for r in rows),
            "failed": sum(r["status"] == "failed" for r in rows),
            "skipped": sum(bool(r.get("skipped")) for r in rows),
            "computed": len(ran),
            "wall_seconds": round(elapsed, 3),
            # Ray's start is a fixed cost per batch, not per sequence: counted apart.
            "ray_start_seconds": round(ray_start, 3),
            "sequences_per_minute": round(60 * len(ran) / (elapsed - ray_start), 2)
            if elapsed > ray_start and ran else None,
        })

    t0 = time.perf_counter()
    progress = _Progress(len(lines), len(lines) - len(todo))
    if todo:
        import ray

        if args.address:
            ray.init(address=args.address, log_to_driver=False)
        else:
            ray.init(num_cpus=args.workers, include_dashboard=False, log_to_driver=False)
        ray_start = time.perf_counter() - t0
        # By reference, not by value: under `python -m` this module is `__main__`, which Ray
        # would pickle whole; the package's copy is importable on every worker.
        from shapetrack.batch import run_line as task_fn

        task = ray.remote(task_fn).options(
            num_cpus=1,
            max_retries=args.retries,
            memory=args.task_memory_mb * 1024 * 1024,
        )
        pending = {task.remote(line, out, settings): line for line in todo}
        refs = list(pending)
        written = time.perf_counter()
        while refs:
            # Whatever finished within a second: one pass over the refs per second, not per
            # result (10^5 lines would make waiting for one at a time quadratic).
            done, refs = ray.wait(refs, num_returns=len(refs), timeout=1.0)
            for ref in done:
                line = pending.pop(ref)
                try:
                    r = ray.get(ref)
                except Exception as e:  # noqa: BLE001 - the worker was lost beyond its retries
                    r = {"line": line, "name": _name(line), "status": "failed", "frames": 0, "tracks": 0,
                         "seconds": 0.0, "error": f"task lost after {args.retries} retries: {type(e).__name__}: {e}"}
                results[line] = r
                progress.update(r)
            # summary.json at most every 5 s while running (rewritten whole each time).
            if done and time.perf_counter() - written > 5:
                write_summary(time.perf_counter() - t0)
                written = time.perf_counter()
        ray.shutdown()
    write_summary(time.perf_counter() - t0)
    progress.close()
    failed = [r for r in results.values() if r["status"] != "ok"]
    print(f"{len(lines) - len(failed)} ok, {len(failed)} failed, {len(lines) - len(todo)} skipped; {summary_url}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
