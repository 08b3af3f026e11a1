"""Shared fixtures: the repository's CLI (the reference every output is compared with) and the
real data in ../shared/data (read in place, never copied into the repository)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data"
MOT15 = DATA / "mot15-train"


def mot15_sequences() -> list[Path]:
    return sorted(p for p in MOT15.iterdir() if (p / "det" / "det.txt").is_file())


@pytest.fixture(scope="session")
def cli() -> Path:
    """The `shapetrack` binary: $SHAPETRACK_CLI, else target/release, else target/debug
    (`node scripts/test.mjs --only=python` builds the release one first)."""
    env = os.environ.get("SHAPETRACK_CLI")
    candidates = [Path(env)] if env else []
    candidates += [ROOT / "target" / "release" / "shapetrack", ROOT / "target" / "debug" / "shapetrack"]
    for c in candidates:
        if c.is_file():
            return c
    pytest.fail("no shapetrack CLI: run `cargo build --release --bin shapetrack` (or set SHAPETRACK_CLI)")


@pytest.fixture(scope="session")
def cli_outputs(cli: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """The CLI's online output on every MOT15 sequence: `shapetrack track --det SEQ/det/det.txt
    --out OUT`, by sequence name."""
    out = tmp_path_factory.mktemp("cli")
    res = {}
    for seq in mot15_sequences():
        dst = out / f"{seq.name}.txt"
        subprocess.run(
            [str(cli), "track", "--det", str(seq / "det" / "det.txt"), "--out", str(dst)],
            check=True,
            capture_output=True,
        )
        res[seq.name] = dst.read_bytes()
    return res
