"""Shared fixtures: the command-line binary the Python package is compared against."""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def cli():
    """Runs `scene-gen ARGS...` (target/release/scene-gen, or $SCENE_GEN_BIN) and returns its
    standard output; fails the test on a non-zero exit."""
    binary = Path(os.environ.get("SCENE_GEN_BIN", ROOT / "target" / "release" / "scene-gen"))
    if not binary.exists():
        pytest.fail(f"{binary} is missing: build it with `cargo build --release --bin scene-gen`")

    def run(*args):
        done = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True)
        assert done.returncode == 0, f"scene-gen {' '.join(map(str, args))}: {done.stderr}"
        return done.stdout

    return run


def tree_bytes(folder: Path) -> dict:
    """Every file under `folder` (relative name -> bytes)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}
