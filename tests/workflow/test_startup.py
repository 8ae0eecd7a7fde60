"""Job start-up: what a workflow job imports, and the hand-written pieces that keep it small.

* :func:`dronewind.simulate.common.one_pole_filter` gives the numbers of
  :func:`scipy.signal.lfilter`, bit for bit, without importing :mod:`scipy.signal`;
* the step modules of the quadrotor and payload jobs do not import scipy.signal, scipy.stats,
  matplotlib, dask.array or pint before they need them.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.signal

from dronewind.simulate import common

SRC = Path(__file__).resolve().parents[2] / "src"


def _modules_after(code: str) -> set[str]:
    """Modules imported by a fresh interpreter that runs ``code``."""
    script = code + "\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    env = dict(os.environ, PYTHONPATH=str(SRC))
    out = subprocess.run([sys.executable, "-c", script], env=env, check=True, capture_output=True, text=True)
    return set(json.loads(out.stdout.strip().splitlines()[-1]))


# ------------------------------------------------------------------ one-pole filter


@pytest.mark.parametrize(("b0", "a", "z0"), [(0.3, 0.7, 0.0), (1.0, 0.999, -2.5), (0.04, 0.96, 1.2)])
def test_one_pole_filter_equals_lfilter_bit_for_bit(b0, a, z0, monkeypatch):
    x = np.random.default_rng(3).normal(size=5000) * 4.0 + 1.0
    expected = scipy.signal.lfilter([b0], [1.0, -a], x, zi=[z0])[0]
    monkeypatch.delitem(sys.modules, "scipy.signal")  # as in a process that has not imported it
    got = common.one_pole_filter(b0, a, x, z0)
    assert got.shape == x.shape and np.array_equal(got, expected)


def test_first_order_lag_and_ou_equal_lfilter_bit_for_bit(monkeypatch):
    rng = np.random.default_rng(7)
    x = np.cumsum(rng.normal(size=3000))
    a = np.exp(-1.0 / (10.0 * 2.0))
    lag_ref = scipy.signal.lfilter([1 - a], [1, -a], x, zi=[a * x[0]])[0]
    draws = np.random.default_rng(11)  # the draws ornstein_uhlenbeck makes, in its order
    e = draws.standard_normal(3000) * 0.5 * np.sqrt(1 - a * a)
    e[0] = draws.standard_normal() * 0.5
    ou_ref = scipy.signal.lfilter([1.0], [1, -a], e, zi=[0.0])[0]
    monkeypatch.delitem(sys.modules, "scipy.signal")
    assert np.array_equal(common.first_order_lag(x, 2.0, 10.0), lag_ref)
    assert np.array_equal(common.ornstein_uhlenbeck(np.random.default_rng(11), 3000, 0.5, 2.0, 10.0), ou_ref)


# ------------------------------------------------------------------ step modules


@pytest.mark.parametrize("module", ["dronewind.steps.quadrotor", "dronewind.steps.common", "dronewind.steps.payload",
                                    "dronewind.simulate.quadrotor", "dronewind.manifest", "dronewind.payload.chain"])
def test_step_modules_import_no_heavy_library(module):
    mods = _modules_after(f"import {module}")
    heavy = {"scipy.signal", "scipy.stats", "matplotlib", "dask.array", "pint", "jsonschema"} & mods
    assert not heavy, f"{module} imports {sorted(heavy)}"


def test_report_step_imports_no_matplotlib():
    mods = _modules_after("import dronewind.steps.report")
    assert "matplotlib" not in mods


# ------------------------------------------------------------------ the Snakefile


def test_snakefile_imports_no_scientific_library():
    # Snakemake runs the Snakefile each time it starts (on a cluster once per job, dry runs
    # included); what it imports from dronewind must be names, not the chain: scipy.signal,
    # scipy.stats and matplotlib took about 2 s of each start before, xarray (through the
    # readers whose column names the format checks need) about 0.2 s more.
    repo = Path(__file__).resolve().parents[2]
    rules = [repo / "Snakefile", *sorted((repo / "workflow" / "rules").glob("*.smk"))]
    lines, block = [], ""
    for path in rules:
        for line in path.read_text().splitlines():
            if block or line.lstrip().startswith("from dronewind") or line.lstrip().startswith("import dronewind"):
                block += line.strip() + " "
                if "(" not in block or ")" in block:
                    lines.append(block.strip())
                    block = ""
    assert any("load_published" in line for line in lines) and len(lines) >= 12  # the parser found them
    mods = _modules_after("\n".join(lines))
    heavy = {"scipy", "matplotlib", "netCDF4", "dask", "pint", "xarray"} & mods
    assert not heavy, f"the Snakefile's imports load {sorted(heavy)}"
