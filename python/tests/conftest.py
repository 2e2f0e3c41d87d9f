"""Shared helpers of the pytest suite: the repository root and the built `millcomp` binary.

Every function of the package is checked against the CLI on the same inputs: the test runs the binary
(`MILLCOMP_BIN`, else the workspace's target/debug/millcomp that `cargo test --workspace` builds) and
compares what it prints with `--json` to what the package returns.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def millcomp_bin() -> Path:
    env = os.environ.get("MILLCOMP_BIN")
    if env:
        return (ROOT / env).resolve()
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "debug" / "millcomp"


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    # paths in the tests are relative to the repository, as in the docs
    monkeypatch.chdir(ROOT)


class Cli:
    """Runs the built binary."""

    def __init__(self, path: Path):
        if not path.exists():
            pytest.fail(f"{path} is missing: build it first (cargo build, or set MILLCOMP_BIN)")
        self.path = path

    def run(self, *args: str, check: bool = True) -> subprocess.CompletedProcess:
        p = subprocess.run([str(self.path), *args], cwd=ROOT, capture_output=True, text=True)
        if check and p.returncode != 0:
            raise AssertionError(f"millcomp {' '.join(args)} failed ({p.returncode}):\n{p.stderr}")
        return p

    def json(self, *args: str):
        return json.loads(self.run("--json", *args).stdout)

    def error(self, *args: str) -> str:
        """The message of a failing call, without its leading `error: `."""
        p = self.run(*args, check=False)
        assert p.returncode != 0, f"millcomp {' '.join(args)} did not fail"
        text = p.stderr
        assert text.startswith("error: "), text
        return text[len("error: ") :].rstrip("\n")


@pytest.fixture(scope="session")
def cli() -> Cli:
    return Cli(millcomp_bin())
