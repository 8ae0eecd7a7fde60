"""Calibration on some flights, validation on others (the manifest's ``role`` per quadrotor flight).

Windows of a two-day campaign made from the drag balance (as in test_diagnose_quadrotor_days):
the IMUs are re-levelled between day 1 and day 2. Calibrated on day 1 alone, the pitch offsets
are day 1's and the validation on day 2 shows the re-levelling as error; calibrated on every
flight, the offsets fall between the days.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from dronewind.core.constants import AIR_DENSITY_KGM3
from dronewind.quadrotor.validation import wetz2021_tables
from tests.diagnose.test_diagnose_quadrotor_days import BASE, FLIGHTS, RELEVEL, UAVS, _two_days, _windows


def _full(windows: pd.DataFrame) -> pd.DataFrame:
    return windows.assign(sigma_h_m=0.2, sigma_v_m=0.5)


def test_calibration_flights_only_fit_the_calibration():
    blocks, windows = _windows(11, _two_days, lambda f: AIR_DENSITY_KGM3, log_density=False)
    day1 = [f for f in FLIGHTS if f.startswith("d1")]
    day2 = [f for f in FLIGHTS if f.startswith("d2")]
    res = wetz2021_tables(blocks, _full(windows), calibration=day1, validation=day2)
    assert res["validation"] == day2 and res["independent_validation"]
    assert res["scenarios"] == {"a_calibration": day1}
    off = res["universal_offsets"].set_index("uav")["pitch_offset_deg"]
    # day-1 offsets, up to the common part that trades off against the law (measured below 0.1 degree)
    err = np.array([off[u] - BASE[u] for u in UAVS])
    assert np.ptp(err) < 0.3
    # calibrated on both days, the UAV-to-UAV differences lie between the days' (half the re-levelling)
    both = wetz2021_tables(blocks, _full(windows), calibration=FLIGHTS, validation=day2)
    off_all = both["universal_offsets"].set_index("uav")["pitch_offset_deg"]
    err_all = np.array([off_all[u] - BASE[u] - RELEVEL[u] / 2 for u in UAVS])
    assert np.ptp(err_all) < 0.3
    # validation on day 2: worse with day-1 offsets than with offsets that saw day 2
    rmse_day1 = float(res["calibration_table"]["rmse_ms"].mean())
    rmse_all = float(both["calibration_table"]["rmse_ms"].mean())
    assert rmse_day1 > rmse_all


@pytest.mark.slow
def test_two_day_campaign_of_delimited_records_through_the_workflow(tmp_path):
    """Delimited 1-Hz records with gaps, the reference in their own columns, day 1 calibration and
    day 2 validation: the workflow calibrates on day 1 and lists every skipped window."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    import yaml

    from dronewind.core.constants import WETZ2021_AERO
    from dronewind.quadrotor.drag import speed_from_tilt

    root = Path(__file__).resolve().parents[2]
    rng = np.random.default_rng(5)
    grid = np.radians(np.linspace(0, 25, 25001))
    v = speed_from_tilt(grid, WETZ2021_AERO["cd0a0_m2"], WETZ2021_AERO["cp_m2_per_rad"])
    fmt = {"name": "delimited", "time": {"column": "time", "kind": "iso"}, "altitude_m": 1265.0,
           "variables": {"roll": {"column": "roll", "unit": "degree"}, "pitch": {"column": "pitch", "unit": "degree"},
                         "ref_speed": {"column": "tower_speed", "unit": "m/s"},
                         "ref_from": {"column": "tower_dir", "unit": "degree"}}}
    flights = []
    for d, day in enumerate(("day1", "day2")):
        uavs = []
        for u, off in (("m1", 1.0), ("m2", -1.5)):
            n = 5400
            t = np.datetime64(f"2023-06-0{d + 1}T08:00:00") + np.arange(n).astype("timedelta64[s]")
            speed = 5 + 2 * np.sin(np.arange(n) / 900) + rng.normal(0, 0.5, n)
            keep = np.ones(n, bool)
            keep[1000:1300] = False  # a 5-min gap
            pd.DataFrame({"time": pd.to_datetime(t[keep]).strftime("%Y-%m-%dT%H:%M:%SZ"), "roll": 0.0,
                          "pitch": -np.degrees(np.interp(speed[keep], v, grid)) + off, "tower_speed": speed[keep],
                          "tower_dir": 230.0}).to_csv(tmp_path / f"{day}_{u}.csv", index=False)
            uavs.append({"id": u, "file": f"{day}_{u}.csv", "format": fmt})
        flights.append({"id": day, "role": ("calibration", "validation")[d],
                        "reference": {"from_record": True, "height_m": 50.0}, "uavs": uavs})
    manifest = tmp_path / "campaign.yaml"
    manifest.write_text(yaml.safe_dump({"name": "days", "site": {"latitude": 60.6, "longitude": 7.5,
                                                                 "altitude_m": 1215.0},
                                        "quadrotor_flights": flights}, sort_keys=False))
    out = tmp_path / "results" / "days"
    targets = [str(out / "quadrotor" / "calibration.json"), str(out / "figures" / "quadrotor_fig7_timeseries.png")]
    run = subprocess.run([str(Path(sys.executable).with_name("snakemake")), "--cores", "1", "--config",
                          f"campaign={manifest}", f"results_dir={tmp_path / 'results'}", "--", *targets],
                         cwd=root, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(root / "src")})
    assert run.returncode == 0, run.stderr[-3000:]
    import json

    summary = json.loads(Path(targets[0]).read_text())
    assert summary["validation_flights"] == ["day2"] and summary["scenarios"] == {"a_calibration": ["day1"]}
    # 5400 s from the first sample: 8 ten-minute windows per UAV and day, 2 touched by the gap (1000-1300 s)
    problems = pd.read_csv(out / "tables" / "quadrotor_problems.csv")
    ten = problems[problems["window_s"] == 600]
    assert len(ten) == 4 * 2 and ten["error"].str.contains("UAV record does not cover it").all()
    assert sorted(set(ten["error"].str.extract(r"^window (\d+)")[0].astype(int))) == [1, 2]
    assert summary["n_windows_600s"] == 4 * 6
    table = pd.read_csv(out / "tables" / "quadrotor_calibration.csv").set_index("uav")
    # the records' tilt is the drag balance's exactly (no attitude noise): the offsets come back to 0.05 degree
    assert abs(table.loc["m1", "pitch_offset_deg"] - 1.0) < 0.05
    assert abs(table.loc["m2", "pitch_offset_deg"] + 1.5) < 0.05
