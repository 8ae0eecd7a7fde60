"""The static checks of ``make lint`` on the library, run by the test suite as well.

CI runs ``make test`` on a clean clone; without these tests a type error, an unused import or a
broken import contract would pass CI. The workflow's own checks (``snakemake --lint``,
``snakefmt``) are in tests/workflow/test_workflow.py.
"""

from __future__ import annotations

import os
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


#: benchmarks/ files that are not command-line scripts (shared helpers, the pytest plugin of bench_test_suite.py)
_NOT_SCRIPTS = {"conftest.py", "bench_common.py", "pytest_timeline.py"}


def _benchmark_scripts() -> list[str]:
    return sorted(p.name for p in (REPO / "benchmarks").glob("*.py")
                  if p.name not in _NOT_SCRIPTS and not p.name.startswith("test_bench_"))


@pytest.mark.slow
@pytest.mark.parametrize("script", _benchmark_scripts())
def test_benchmark_script_gives_its_help(script: str) -> None:
    """Every benchmark and validation script imports what it uses and answers ``--help``.

    The scripts are run by hand or by ``make validate``, not by the suite: without this an
    import moved in the library would break one unnoticed until its next run.
    """
    proc = subprocess.run([sys.executable, str(REPO / "benchmarks" / script), "--help"], cwd=REPO, capture_output=True,
                          text=True, timeout=120, check=False,
                          env={**os.environ, "PYTHONPATH": str(REPO / "src")})
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "usage" in proc.stdout.lower(), proc.stdout[:500]
