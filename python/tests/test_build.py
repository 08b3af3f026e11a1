"""The extension shares `cargo test`'s build: every dependency of the core gets the same
features in both (python/Cargo.toml lists three crates only for that). If an update made them
drift, the `python package` step would still pass, only compiling tract and linfa a second
time (over ten minutes on the CI machine); this test says which crate drifted instead."""

from __future__ import annotations

import subprocess

from conftest import ROOT


def _tree(package: str, edges: str) -> dict[str, set[str]]:
    """`cargo tree` of `package`: each dependency (name and version) with its feature lists."""
    out = subprocess.run(
        ["cargo", "tree", "--offline", "-p", package, "-e", edges, "-f", "{p}|{f}", "--prefix", "none"],
        cwd=ROOT, check=True, capture_output=True, text=True,
    ).stdout
    res: dict[str, set[str]] = {}
    for line in out.splitlines():
        line = line.removesuffix(" (*)").strip()
        if not line:
            continue
        pkg, _, feats = line.partition("|")
        # `name vX.Y.Z (path or proc-macro)`: the name and version identify the unit.
        res.setdefault(" ".join(pkg.split()[:2]), set()).add(feats.strip())
    return res


def test_the_extension_and_the_test_build_give_the_core_s_dependencies_equal_features():
    core = _tree("shapetrack", "normal,build")
    tests = _tree("shapetrack", "normal,build,dev")
    ext = _tree("shapetrack-python", "normal,build")
    drift = {
        k: (tests[k], ext[k])
        for k in core
        if k in ext and k in tests and tests[k] != ext[k] and not k.startswith("shapetrack ")
    }
    assert not drift, (
        "features differ between `cargo test`'s build and the extension's; give python/Cargo.toml "
        f"the crate with the test build's features: {drift}"
    )
    # The comparison covers the heavy part of the build.
    assert any(k.startswith("tract-core ") for k in core) and any(k.startswith("linfa ") for k in core)
