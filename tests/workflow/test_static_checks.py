"""The static checks of ``make lint`` on the library, run by the test suite as well.

CI runs ``make test`` on a clean clone; without these tests a type error, an unused import or a
broken import contract would pass CI. The workflow's own checks (``snakemake --lint``,
``snakefmt``) are in tests/workflow/test_workflow.py.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent


def _run(*cmd: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(BIN / cmd[0]), *cmd[1:]], cwd=REPO, capture_output=True, text=True, timeout=600,
                          check=False)


def test_ruff_finds_nothing() -> None:
    proc = _run("ruff", "check", "src", "tests", "workflow/scripts", "benchmarks")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-1000:]


def test_import_contracts_are_kept() -> None:
    """The layers of pyproject.toml's import-linter contracts (the chains never import the simulator ...)."""
    proc = _run("lint-imports", "--no-cache")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-1000:]


@pytest.mark.slow
def test_mypy_finds_no_type_error() -> None:
    """mypy on the library as configured in pyproject.toml (about 30 CPU-s without a cache)."""
    proc = _run("mypy")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-1000:]
