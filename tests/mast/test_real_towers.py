"""The shipped tower campaigns on the real records (dronewind.datasets), through the workflow.

* ``config/campaigns/real_ameriflux_gold.yaml``: the 96 AmeriFlux open-path gold half-hours
  (Gill WindMaster Pro, 10 Hz) in the default 30-min blocks;
* ``config/campaigns/real_fluxpart.yaml``: the fluxpart CSAT3 record (20 Hz, 2 x 15 min) in
  15-min blocks (``config/blocks_15min.yaml``).

Each is skipped, with the reason, when its record is absent. The block statistics are checked
against an independent implementation (``benchmarks/metpy_agreement.py``: numpy gap filling
and double rotation, MetPy statistics) on the same despiked blocks, read from the L1 files the
workflow wrote. Measured (benchmarks/results/metpy_agreement.json): median relative
differences of U, sigma_w, u* and w'T' 2e-7 to 2e-6, at most 4.1e-6: the CSV holds 6
significant digits (rounding up to 5e-6 relative), so both implementations agree to the
table's precision; the issue's limits (0.5 % and 2 %) are asserted, and the precision
limit 1e-5 too.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dronewind.compare.blocks import BLOCK_STATS_COLUMNS
from dronewind.core.cf import check_compliance
from dronewind.core.products import open_product
from tests.conftest import needs_record, record_path

pytestmark = pytest.mark.slow  # workflow runs or repeated diagnoses: not in the fast tier

ROOT = Path(__file__).resolve().parents[2]
GOLD = record_path("ameriflux_gold_openpath")
FLUXPART = record_path("fluxpart_csat3_toa5")
BIN = Path(sys.executable).parent

needs_gold = needs_record("ameriflux_gold_openpath")
needs_fluxpart = needs_record("fluxpart_csat3_toa5")


def _run(out: Path, campaign: str, *extra: str) -> Path:
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    run = subprocess.run([str(BIN / "snakemake"), "--cores", "2", *extra, "--config",
                          f"campaign={ROOT / 'config' / 'campaigns' / campaign}.yaml", f"results_dir={out}"],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=1200)
    assert run.returncode == 0, run.stderr[-3000:]
    return out / campaign


@pytest.fixture(scope="module")
def gold(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("towers"), "real_ameriflux_gold")


@pytest.fixture(scope="module")
def fluxpart(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("towers"), "real_fluxpart", "--configfile",
                str(ROOT / "config" / "blocks_15min.yaml"))


def _agreement(results: Path, tmp: Path) -> dict:
    out = tmp / "agreement.json"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    run = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "metpy_agreement.py"), "--results", str(results),
                          "--out", str(out)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    return json.loads(out.read_text())["records"][0]["summary"]


@needs_gold
def test_gold_96_half_hours_in_blocks(gold):
    table = pd.read_csv(gold / "tables" / "block_stats.csv", keep_default_na=False)
    assert list(table.columns) == list(BLOCK_STATS_COLUMNS)
    assert len(table) == 96 and table["usable"].all()
    # the files' half hours are the blocks: 17998-17999 of 18000 rows each, and the despiked samples
    assert table["missing_fraction"].astype(float).between(1.0 / 18000 - 1e-12, 0.02).all()
    assert set(table["start_utc"].str[14:]) == {"00:00Z", "30:00Z"}
    # clock UTC-8: the day's largest w'T' lies within 2 h of local solar noon (20:04 UTC at 120.95 W)
    day = table["start_utc"].str[:10]
    for start in table.loc[table.groupby(day)["wT_Kms"].idxmax(), "start_utc"]:
        if start.endswith("T00:00:00Z"):
            continue  # the day's UTC tail (local afternoon of the previous day's file)
        hour = int(start[11:13]) + int(start[14:16]) / 60 + 0.25
        assert abs(hour - 20.07) < 2.0, start
    for name in ("figures/block_series.png", "figures/block_series.pdf", "report/summary.html",
                 "report/tables/block_stats.html", "report/captions/block_series.rst"):
        assert (gold / name).is_file(), name


@needs_gold
def test_gold_block_l4_is_cf_and_records_the_detrending(gold):
    path = gold / "netcdf" / "L4" / "blocks" / "gill2m.nc"
    ds = open_product(path)
    assert ds.sizes["time"] == 96 and ds.attrs["detrending"].startswith("linear")
    assert ds.attrs["rotation_method"] == "double" and float(ds.attrs["block_s"]) == 1800.0
    assert np.isfinite(ds["Sw_Su"].values).sum() > 0 and np.isfinite(ds["L_u_m"].values).sum() > 0
    passed, report = check_compliance(path)
    assert passed, report[-2000:]


@needs_gold
def test_gold_agrees_with_metpy(gold, tmp_path):
    summary = _agreement(gold, tmp_path)
    for name, limit in (("U_ms", 0.005), ("sigma_w_ms", 0.005), ("ustar_ms", 0.005), ("wT_Kms", 0.02)):
        s = summary[name]
        assert s["n_blocks"] == 96
        assert s["median_relative_difference"] <= limit
        assert s["max_relative_difference"] < 1e-5, (name, s)  # 6 significant digits in the CSV


@needs_fluxpart
def test_fluxpart_in_15_min_blocks_agrees_with_metpy(fluxpart, tmp_path):
    table = pd.read_csv(fluxpart / "tables" / "block_stats.csv", keep_default_na=False)
    assert list(table["start_utc"]) == ["2012-06-07T12:45:00Z", "2012-06-07T13:00:00Z", "2012-06-07T13:15:00Z"]
    assert list(table["usable"]) == [True, True, False]
    assert table["reason"][2].startswith("missing fraction 0.9999 > processing.max_missing_fraction 0.02")
    assert float(table["height_m"][0]) == 7.11
    summary = _agreement(fluxpart, tmp_path)
    for name, limit in (("U_ms", 0.005), ("sigma_w_ms", 0.005), ("ustar_ms", 0.005), ("wT_Kms", 0.02)):
        assert summary[name]["n_blocks"] == 2
        assert summary[name]["median_relative_difference"] <= limit
        assert summary[name]["max_relative_difference"] < 1e-5, (name, summary[name])
    assert open_product(fluxpart / "netcdf" / "L4" / "blocks" / "csat3.nc").attrs["detrending"].startswith("linear")
