"""Ray tasks (the shipped `python -m shapetrack.batch`) against Ray Data over the same manifest.

    nice -n 10 PY scripts/bench_ray_engines.py --manifest M --workers 1 2 --runs K --out-root DIR
        [--data-api map|map_batches|both]

PY is a Python with the built package and ``ray[data]`` (pandas, pyarrow). Each run alternates
the engines (tasks, data, tasks, data, ...) so that load drift from other work on the machine
hits both alike; every engine runs in a fresh process (interpreter start, imports, ``ray.init``,
the batch, ``ray.shutdown``) into an empty output folder, so nothing is skipped by resume:

- tasks: ``PY -m shapetrack.batch --manifest M --out DIR/tasks_w<w>_r<i> --workers w``; its
  ``ray_start_seconds`` and ``sequences_per_minute`` come from its summary.json;
- data: this script as a child: ``ray.init(num_cpus=w)``, ``ray.data.from_items`` (one line a
  block), ``.map`` (or ``.map_batches(batch_size=1)``) with ``num_cpus=1`` calling
  ``shapetrack.batch.run_line`` with ``shapetrack.batch._settings``' settings (the defaults:
  online, no preset, no config), then ``take_all`` and ``ray.shutdown``; timed as batch.py
  times itself (from just before ``import ray`` to after ``ray.shutdown``; Ray's start =
  ``import ray`` + ``ray.init``, counted apart; importing ``ray.data`` counts as Data's work).

Every data run's ``DIR/<seq>.txt`` is compared byte for byte with the tasks run of the same
round. Prints one row per run (with "lines s", the sum of the lines' own run_line seconds) and
a summary (median, min–max) per engine and worker count.
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import shutil
import statistics
import subprocess
import sys
import time


def _loadavg() -> str:
    return "/".join(f"{x:.2f}" for x in os.getloadavg())


# ---------------------------------------------------------------- the Ray Data engine (child)


def data_child(manifest: str, out: str, workers: int, api: str, result_json: str) -> None:
    from shapetrack import batch

    lines = batch.read_manifest(manifest)
    settings = batch._settings(argparse.Namespace(config=None, offline=False, preset=None))
    os.makedirs(out, exist_ok=True)

    # As batch.py: Ray's start = `import ray` + `ray.init`; importing ray.data (~1.2 s more,
    # pandas and pyarrow) is Data's own cost, so it counts in the time without Ray's start.
    t0 = time.perf_counter()
    import ray

    ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
    ray_start = time.perf_counter() - t0
    import ray.data

    ctx = ray.data.DataContext.get_current()
    ctx.enable_progress_bars = False

    def one(row: dict) -> dict:
        from shapetrack.batch import run_line

        # The result as JSON text: its nested, partly-null fields differ between lines, which
        # Arrow blocks would otherwise have to unify into one schema.
        return {"result": json.dumps(run_line(row["line"], out, settings))}

    def one_batch(b: dict) -> dict:
        from shapetrack.batch import run_line

        return {"result": [json.dumps(run_line(str(ln), out, settings)) for ln in b["line"]]}

    ds = ray.data.from_items([{"line": ln} for ln in lines], override_num_blocks=len(lines))
    if api == "map":
        ds = ds.map(one, num_cpus=1)
    else:
        ds = ds.map_batches(one_batch, batch_size=1, num_cpus=1)
    rows = ds.take_all()
    ray.shutdown()
    elapsed = time.perf_counter() - t0
    results = [json.loads(r["result"]) for r in rows]
    with open(result_json, "w") as f:
        json.dump({
            "wall_seconds": round(elapsed, 3),
            "ray_start_seconds": round(ray_start, 3),
            "sequences_per_minute": round(60 * len(results) / (elapsed - ray_start), 2),
            "ok": sum(r["status"] == "ok" for r in results),
            "line_seconds": round(sum(r["seconds"] for r in results), 3),
            "failed": [r for r in results if r["status"] != "ok"],
        }, f, indent=2)


# ---------------------------------------------------------------- the parent


def run_tasks(manifest: str, out: str, workers: int) -> dict:
    t = time.perf_counter()
    p = subprocess.run(
        [sys.executable, "-m", "shapetrack.batch", "--manifest", manifest, "--out", out, "--workers", str(workers)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    outer = time.perf_counter() - t
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)
    if p.returncode != 0 or s["failed"]:
        print(p.stdout, p.stderr, file=sys.stderr)
    return {"outer": outer, "inner": s["wall_seconds"], "ray_start": s["ray_start_seconds"],
            "spm": s["sequences_per_minute"], "ok": s["ok"], "failed": s["failed"],
            "work": sum(r["seconds"] for r in s["lines"])}


def run_data(manifest: str, out: str, workers: int, api: str) -> dict:
    res = out + ".result.json"
    t = time.perf_counter()
    p = subprocess.run(
        [sys.executable, os.path.abspath(__file__), "--child", "--manifest", manifest, "--out-root", out,
         "--workers", str(workers), "--data-api", api, "--result", res],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    outer = time.perf_counter() - t
    if p.returncode != 0:
        print(p.stdout[-4000:], p.stderr[-4000:], file=sys.stderr)
        raise SystemExit(f"data engine failed (exit {p.returncode})")
    with open(res) as f:
        s = json.load(f)
    if s["failed"]:
        print(json.dumps(s["failed"], indent=1), file=sys.stderr)
    return {"outer": outer, "inner": s["wall_seconds"], "ray_start": s["ray_start_seconds"],
            "spm": s["sequences_per_minute"], "ok": s["ok"], "failed": len(s["failed"]),
            "work": s["line_seconds"]}


def compare(names: list[str], a: str, b: str) -> list[str]:
    """The names whose outputs differ (or are missing) between folders a and b."""
    bad = []
    for n in names:
        fa, fb = os.path.join(a, f"{n}.txt"), os.path.join(b, f"{n}.txt")
        if not (os.path.isfile(fa) and os.path.isfile(fb) and filecmp.cmp(fa, fb, shallow=False)):
            bad.append(n)
    return bad


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--manifest", required=True)
    ap.add_argument("--workers", type=int, nargs="+", required=True)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out-root", required=True)
    ap.add_argument("--data-api", choices=["map", "map_batches", "both"], default="both")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--result", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        data_child(a.manifest, a.out_root, a.workers[0], a.data_api, a.result)
        return 0

    from shapetrack import batch

    names = [batch._name(ln) for ln in batch.read_manifest(a.manifest)]
    apis = ["map", "map_batches"] if a.data_api == "both" else [a.data_api]
    engines = ["tasks"] + [f"data-{x}" for x in apis]
    os.makedirs(a.out_root, exist_ok=True)
    rows, mismatches = [], []
    print(f"{a.manifest}: {len(names)} lines; workers {a.workers}; {a.runs} runs; engines {engines}")
    print(f"{'run':>3} {'engine':<16} {'w':>2} {'wall s':>7} {'-Ray start':>10} {'Ray start':>9} "
          f"{'seq/min':>8} {'ok':>3} {'lines s':>7}  load before", flush=True)
    for i in range(a.runs):
        for w in a.workers:
            for eng in engines:
                out = os.path.join(a.out_root, f"{eng}_w{w}_r{i}")
                shutil.rmtree(out, ignore_errors=True)
                load = _loadavg()
                if eng == "tasks":
                    r = run_tasks(a.manifest, out, w)
                else:
                    r = run_data(a.manifest, out, w, eng.split("-", 1)[1])
                    bad = compare(names, os.path.join(a.out_root, f"tasks_w{w}_r{i}"), out)
                    if bad:
                        mismatches.append((eng, w, i, bad))
                        print(f"    OUTPUTS DIFFER from tasks_w{w}_r{i}: {bad}", flush=True)
                r.update(engine=eng, workers=w, run=i, load=load)
                rows.append(r)
                print(f"{i:>3} {eng:<16} {w:>2} {r['outer']:>7.2f} {r['outer'] - r['ray_start']:>10.2f} "
                      f"{r['ray_start']:>9.2f} {r['spm']:>8.1f} {r['ok']:>3} {r['work']:>7.2f}  {load}", flush=True)

    print(f"\nsummary: median (min–max) over {a.runs} runs; wall = the process, from start to exit; "
          f"load average at the end {_loadavg()}")
    print(f"| engine | workers | wall (s) | wall without Ray start (s) | sequences / minute |")
    print("|---|---|---|---|---|")
    for w in a.workers:
        for eng in engines:
            rs = [r for r in rows if r["engine"] == eng and r["workers"] == w]

            def fmt(vals, nd):
                return f"{statistics.median(vals):.{nd}f} ({min(vals):.{nd}f}–{max(vals):.{nd}f})"

            print(f"| {eng} | {w} | {fmt([r['outer'] for r in rs], 2)} | "
                  f"{fmt([r['outer'] - r['ray_start'] for r in rs], 2)} | {fmt([r['spm'] for r in rs], 1)} |")
    with open(os.path.join(a.out_root, "bench_rows.json"), "w") as f:
        json.dump(rows, f, indent=1)
    print("outputs: " + ("all data outputs equal the tasks outputs byte for byte" if not mismatches
                         else f"DIFFER: {mismatches}"))
    return 1 if mismatches else 0


if __name__ == "__main__":
    raise SystemExit(main())
