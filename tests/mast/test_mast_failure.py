"""A reference mast record that cannot be read or used: its flights go on without it, the campaign completes.

The measured two-flight campaign of :mod:`tests.workflow.test_faults` (one mast sonic, one TOA5
file per flight) is run through the workflow's steps (:mod:`dronewind.steps.payload`, the
functions the Snakemake rules call), file to ``flight_stats.csv``: once clean, then with

* the mast file of flight s01 unreadable (a damaged header): that file is left out of the
  sonic's record, flight s01 has no reference over its window and is processed drone-only
  with ``usable = 0`` and the reason (naming the file and line); flight s02's row is the
  clean run's, number for number;
* every mast file unreadable: both flights drone-only, ``usable = 0``, the campaign's table
  still written.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
import yaml

from dronewind.manifest import default_config, load_campaign
from dronewind.steps import payload as steps
from dronewind.steps.payload import simulate_payload, simulation_manifest
from tests.small_campaign import write_small_campaign

#: a small campaign simulated and carried through the file steps: outside the fast tier
pytestmark = pytest.mark.slow

PROCESSING = default_config()["processing"]
HOVER = {**PROCESSING["hover"], "min_duration_s": 300.0}
FLIGHTS = ("s01", "s02")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> tuple[Path, dict[str, Any]]:
    sim = tmp_path_factory.mktemp("mastfail_sim")
    virtual = load_campaign(write_small_campaign(sim, name="mastfail", n_flights=2))
    folder = tmp_path_factory.mktemp("mastfail_l0")
    for fid in FLIGHTS:
        simulate_payload(simulation_manifest(virtual.data), fid, sim, folder)
    data = {k: v for k, v in virtual.data.items() if k != "simulation"}
    (folder / "mastfail.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    return folder, data


def run_campaign(folder: Path, data: dict[str, Any], out: Path) -> pd.DataFrame:
    """Every step of the payload chain for both flights, as the workflow runs them; the flight_stats table."""
    camp = load_campaign(folder / "mastfail.yaml")
    (sonic_id, sonic), = camp.mast_sonics().items()
    site = data["site"]
    l1 = steps.mast_l1([str(p) for p in camp.mast_files(sonic_id, folder)], out / f"mast_{sonic_id}.nc",
                       campaign=camp.name, sonic=sonic, despike=PROCESSING["despike"], simulated=False)
    l4_files = []
    for fid in FLIGHTS:
        flight = camp.payload_flight(fid)
        s1, i1 = steps.payload_l1(folder / flight["sonic"]["file"], folder / flight["ins"]["file"],
                                  out / f"{fid}_sonic.nc", out / f"{fid}_ins.nc", campaign=camp.name, flight_id=fid,
                                  site=site, target_height_m=flight.get("target_height_m"),
                                  despike=PROCESSING["despike"], simulated=False)
        l2 = steps.payload_l2(s1, i1, out / f"{fid}_drone.nc", campaign=camp.name, flight_id=fid, flight=flight,
                              site=site, sonic_ins_lag=PROCESSING["sonic_ins_lag"], hover=HOVER,
                              max_missing_fraction=PROCESSING["max_missing_fraction"])
        m2 = steps.mast_l2(l1, l2, out / f"{fid}_mast.nc", campaign=camp.name, flight_id=fid, reference=sonic,
                           drone_mast=PROCESSING["drone_mast"])
        l3 = steps.l3(l2, m2, out / f"{fid}_l3.nc", campaign=camp.name, flight_id=fid, flight=flight,
                      reference=sonic, drone_mast=PROCESSING["drone_mast"], rotation=PROCESSING["rotation"])
        for sensor in ("drone", "mast"):
            l4_files.append(steps.l4(l3, out / f"{fid}_{sensor}.nc", campaign=camp.name, flight_id=fid,
                                     sensor=sensor, reference=sonic, spectra=PROCESSING["spectra"],
                                     quadrant=PROCESSING["quadrant"], detrending=PROCESSING["detrending"]))
    table = steps.flight_stats(l4_files, out / "flight_stats.csv")
    return pd.read_csv(table, keep_default_na=False, na_values=[""])


@pytest.fixture(scope="module")
def clean(campaign, tmp_path_factory) -> pd.DataFrame:
    folder, data = campaign
    return run_campaign(folder, data, tmp_path_factory.mktemp("mastfail_clean"))


def _damaged(campaign, tmp_path: Path, files: list[str]) -> Path:
    folder, _ = campaign
    case = tmp_path / "l0"
    shutil.copytree(folder, case)
    for name in files:
        p = case / "mast" / name
        lines = p.read_text().splitlines()
        p.write_text("\n".join([lines[0], lines[1].replace('"Uz",', ""), *lines[2:]]) + "\n")
    return case


def _row(table: pd.DataFrame, flight: str, sensor: str) -> pd.Series:
    return table[(table["flight"] == flight) & (table["sensor"] == sensor)].iloc[0]


def test_one_mast_file_unreadable(campaign, clean, tmp_path):
    assert (clean["usable"] == 1).all() and len(clean) == 4
    case = _damaged(campaign, tmp_path, ["mast30_s01.dat"])
    table = run_campaign(case, campaign[1], tmp_path / "out")
    drone, mast = _row(table, "s01", "drone"), _row(table, "s01", "mast")
    assert drone["usable"] == 0 and mast["usable"] == 0
    for reason in (drone["unusable_reason"], mast["unusable_reason"]):
        assert "reference mast record not usable over the flight's window" in reason
        assert "mast30_s01.dat:2: required column(s) Uz missing" in reason
    # drone-only numbers are written (as for a flight without a reference); the mast's are empty
    assert np.isfinite(drone["U_ms"]) and np.isfinite(drone["sigma_w_ms"]) and np.isnan(drone["lag_drone_mast_s"])
    assert np.isnan(mast["U_ms"]) and np.isnan(mast["sigma_w_ms"])
    assert abs(drone["lag_sonic_ins_s"] - _row(clean, "s01", "drone")["lag_sonic_ins_s"]) == 0.0
    # the other flight: every number of the clean run, exactly
    for sensor in ("drone", "mast"):
        pd.testing.assert_series_equal(_row(table, "s02", sensor), _row(clean, "s02", sensor), check_names=False)


def test_every_mast_file_unreadable(campaign, clean, tmp_path):
    case = _damaged(campaign, tmp_path, ["mast30_s01.dat", "mast30_s02.dat"])
    table = run_campaign(case, campaign[1], tmp_path / "out")
    assert len(table) == 4 and (table["usable"] == 0).all()
    assert all("reference mast record cannot be read" in r and "required column(s) Uz missing" in r
               for r in table["unusable_reason"])
    for fid in FLIGHTS:
        drone = _row(table, fid, "drone")
        assert np.isfinite(drone["U_ms"]) and drone["lag_sonic_ins_s"] == _row(clean, fid, "drone")["lag_sonic_ins_s"]
