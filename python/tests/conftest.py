"""Shared fixtures: the repository root and the real `lmhost` binary."""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _binary() -> Path:
    env = os.environ.get("LMHOST_BIN")
    if env:
        return Path(env)
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "debug" / "lmhost"


@pytest.fixture(scope="session")
def lmhost_bin() -> Path:
    b = _binary()
    if not b.exists():
        pytest.fail(f"{b} is missing: build it with `cargo build -p lmhost-cli` (or set LMHOST_BIN)")
    os.environ["LMHOST_BIN"] = str(b)
    return b


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


def cli(binary, *args, check=True):
    r = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True, cwd=ROOT)
    if check and r.returncode != 0:
        raise AssertionError(f"lmhost {' '.join(map(str, args))} failed: {r.stderr}")
    return r
