"""`python -m shapetrack.batch` on a local Ray: every MOT15 sequence plus one corrupt det file,
then a rerun; and the fsspec path (inputs and outputs at `memory://` URLs) in process."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import MOT15, mot15_sequences

pytest.importorskip("ray")
fsspec = pytest.importorskip("fsspec")


def _corrupt_sequence(root: Path) -> Path:
    seq = root / "Corrupt-1"
    (seq / "det").mkdir(parents=True)
    (seq / "det" / "det.txt").write_text("1,-1,10,10,20,20,0.9,-1,-1,-1\n2,-1,ten,10,20,20,0.9,-1,-1,-1\n")
    (seq / "seqinfo.ini").write_text("[Sequence]\nname=Corrupt-1\nframeRate=25\nseqLength=2\nimWidth=640\nimHeight=480\n")
    return seq


def _batch(args: list[str], env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "shapetrack.batch", *args],
        capture_output=True,
        text=True,
        env={**os.environ, **(env or {})},
        timeout=900,
    )


def test_ray_batch_over_mot15_with_a_corrupt_line_then_a_rerun(cli_outputs, tmp_path):
    # Catches: a bad line stopping the others or going unreported; outputs that differ from
    # the CLI's; a rerun that recomputes finished lines; a lost worker not retried; file://
    # URLs in the manifest and for --out not working.
    bad = _corrupt_sequence(tmp_path / "lib")
    seqs = mot15_sequences()
    lines = [f"file://{s}" if k % 2 else str(s) for k, s in enumerate(seqs)] + [str(bad)]
    manifest = tmp_path / "manifest.txt"
    manifest.write_text("# MOT15 and one corrupt file\n" + "\n".join(lines) + "\n\n")
    out = tmp_path / "out"
    marker = tmp_path / "crashed-once"
    # The first attempt at TUD-Campus kills its worker (a lost node); Ray must retry it.
    r = _batch(
        ["--manifest", str(manifest), "--out", f"file://{out}", "--workers", "2"],
        env={"SHAPETRACK_BATCH_CRASH_ONCE": f"TUD-Campus:{marker}"},
    )
    assert r.returncode == 1, r.stdout + r.stderr  # one line failed
    assert marker.exists(), "the crash hook ran"
    summary = json.loads((out / "summary.json").read_text())
    rows = {row["name"]: row for row in summary["lines"]}
    assert len(rows) == 12 and summary["ok"] == 11 and summary["failed"] == 1
    for seq in seqs:
        row = rows[seq.name]
        assert row["status"] == "ok" and row["error"] is None, row
        assert row["frames"] > 0 and row["tracks"] > 0 and row["seconds"] > 0
        assert (out / f"{seq.name}.txt").read_bytes() == cli_outputs[seq.name], seq.name
    failed = rows["Corrupt-1"]
    assert failed["status"] == "failed" and "det.txt:2" in failed["error"], failed
    assert not (out / "Corrupt-1.txt").exists()
    assert not [p for p in out.iterdir() if ".tmp" in p.name or ".part" in p.name]

    mtimes = {p.name: p.stat().st_mtime_ns for p in out.glob("*.txt")}
    r2 = _batch(["--manifest", str(manifest), "--out", str(out), "--workers", "2"])
    assert r2.returncode == 1, r2.stdout + r2.stderr
    again = json.loads((out / "summary.json").read_text())
    assert again["skipped"] == 11 and again["computed"] == 1, again  # only the bad line again
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.txt")} == mtimes


def test_fsspec_urls_in_and_out(cli_outputs):
    # Catches the object-store path: inputs staged in from a URL, the output uploaded whole.
    from shapetrack import batch

    fs = fsspec.filesystem("memory")
    seq = MOT15 / "KITTI-17"
    fs.pipe("/lib/KITTI-17/det/det.txt", (seq / "det" / "det.txt").read_bytes())
    fs.pipe("/lib/KITTI-17/seqinfo.ini", (seq / "seqinfo.ini").read_bytes())
    fs.makedirs("/labels", exist_ok=True)
    settings = {"offline": False, "preset": None, "config": None, "config_sha256": ""}
    r = batch.run_line("memory://lib/KITTI-17", "memory://labels", settings)
    assert r["status"] == "ok", r
    assert fs.cat("/labels/KITTI-17.txt") == cli_outputs["KITTI-17"]
    assert [p for p in fs.ls("/labels", detail=False) if ".part" in p] == []
    r = batch.run_line("memory://lib/missing", "memory://labels", settings)
    assert r["status"] == "failed" and "missing" in r["error"]
