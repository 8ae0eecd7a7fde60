"""End to end: a small virtual campaign through the whole Snakemake workflow.

Checks what every run must keep true: every NetCDF passes the IOOS compliance checker
(CF-1.11 and ACDD-1.3, normal criteria, exit code 0), flight_stats.csv has the contract's
columns, and a rerun with the same inputs and config gives bit-identical data. The runs
are the session's (tests/conftest.py): the whole workflow once, and the same campaign
again up to every NetCDF and flight_stats.csv (the data compared here), shared with
tests/workflow/test_faults.py, which compares the two runs' files byte for byte.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from dronewind.core.cf import check_compliance_files
from dronewind.steps import FLIGHT_STATS_COLUMNS, open_product

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def campaign_run(small_campaign_run):
    """The small campaign run through the workflow once (tests/conftest.py), shared with
    tests/figures/test_report.py."""
    return small_campaign_run


def test_every_netcdf_passes_the_compliance_checker(campaign_run):
    *_, results = campaign_run
    files = sorted(results.rglob("*.nc"))
    levels = {p.parent.name for p in files}
    assert {"L1", "L2", "L3", "L4"} <= levels, levels
    failed = {path: report for path, (ok, report) in check_compliance_files(files).items() if not ok}
    assert not failed, "\n".join(f"{path}\n{report[-3000:]}" for path, report in failed.items())


def test_flight_stats_has_contract_columns(campaign_run):
    *_, results = campaign_run
    table = pd.read_csv(results / "tables" / "flight_stats.csv")
    assert list(table.columns[: len(FLIGHT_STATS_COLUMNS)]) == list(FLIGHT_STATS_COLUMNS)
    assert sorted(table["sensor"]) == ["drone", "mast"]
    drone = table[table.sensor == "drone"].iloc[0]
    mast = table[table.sensor == "mast"].iloc[0]
    assert np.isfinite(drone.lag_sonic_ins_s) and np.isnan(mast.lag_sonic_ins_s)
    assert drone.lag_drone_mast_s == mast.lag_drone_mast_s
    # the simulated wind was 4 m/s at 30 m from 250 degrees: both sensors see it
    for row in (drone, mast):
        assert 3.0 < row.U_ms < 5.5 and abs(row.wind_from_deg - 250) < 15


def test_processing_log_and_provenance(campaign_run):
    *_, results = campaign_run
    l1 = open_product(results / "netcdf" / "L1" / "s01_sonic.nc")
    assert "processing_log" in l1.attrs and l1.attrs["input_checksums"].startswith("{")
    assert "config_sha256" in l1.attrs and l1.attrs["software_version"]
    assert any(k.startswith("n_") for k in l1.attrs), "counts of removed/filled samples are stored"


def test_html_report_with_captions(small_campaign_report):
    """`snakemake --report` builds the HTML report of the finished run, figure captions included."""
    html = small_campaign_report
    text = html.read_text(errors="replace")
    assert html.stat().st_size > 100_000
    assert "fig04_tke_lag" in text and "Diagnosis" in text
