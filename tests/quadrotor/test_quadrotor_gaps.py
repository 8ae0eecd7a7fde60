"""Gaps in a quadrotor record or its reference skip the windows they touch and no others.

A synthetic 1-Hz record of a hovering multicopter (roll, pitch only, as a hand-converted
vehicle log: no yaw, no velocities, one height) with the tower's speed and direction as
columns of the same record, and 20 gaps of 30 s to 7 min at seeded random places. The
windows that hold every second of the record are known from the gap positions alone; the
test asks for exactly those, before and after every gap, and for one listed skip per other
window.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from dronewind.errors import InputError
from dronewind.quadrotor.chain import compute_flight_windows
from dronewind.quadrotor.delimited import read_quadrotor_delimited, reference_from_record
from dronewind.quadrotor.io import read_quadrotor
from dronewind.quadrotor.reference import read_tower_reference
from dronewind.quadrotor.windows import flight_windows, flight_windows_with_gaps

START = np.datetime64("2021-06-01T08:00:00", "s")
DURATION_S = 6 * 3600
GAP_S = [420, 30, 45, 60, 90, 120, 150, 180, 200, 240, 30, 35, 50, 75, 100, 130, 160, 300, 360, 40]

FORMAT = {"name": "delimited", "time": {"column": "time", "kind": "iso"}, "altitude_m": 150.0,
          "variables": {"roll": {"column": "roll", "unit": "degree"}, "pitch": {"column": "pitch", "unit": "degree"},
                        "ref_speed": {"column": "speed", "unit": "m/s"},
                        "ref_from": {"column": "direction", "unit": "degree"}}}


def _gap_starts(rng: np.random.Generator) -> list[tuple[int, int]]:
    """Non-overlapping gaps (first missing second, length) at least 5 s apart, seeded."""
    while True:
        starts = np.sort(rng.integers(60, DURATION_S - 500, len(GAP_S)))
        lengths = rng.permutation(GAP_S)
        if np.all(starts[1:] > starts[:-1] + lengths[:-1] + 5):
            return [(int(a), int(n)) for a, n in zip(starts, lengths, strict=True)]


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    rng = np.random.default_rng(20210601)
    gaps = _gap_starts(rng)
    present = np.ones(DURATION_S, dtype=bool)
    for a, n in gaps:
        present[a:a + n] = False
    sec = np.flatnonzero(present)
    t = START + sec.astype("timedelta64[s]")
    frame = pd.DataFrame({
        "time": pd.to_datetime(t).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "roll": np.round(rng.normal(1.0, 0.3, sec.size), 3), "pitch": np.round(rng.normal(-4.0, 0.3, sec.size), 3),
        "speed": np.round(5.0 + rng.normal(0, 0.5, sec.size), 3),
        "direction": np.round(rng.uniform(200, 220, sec.size), 2),
    })
    path = tmp_path_factory.mktemp("gaps") / "uav_1hz.csv"
    frame.to_csv(path, index=False)
    return path, gaps, present


def _expected_windows(present: np.ndarray, first_s: int, window_s: int) -> tuple[list[int], int]:
    """Windows from the first sample on that hold every second, and how many windows there are."""
    last = int(np.flatnonzero(present)[-1])
    n = (last - first_s) // window_s
    full = [k for k in range(n) if present[first_s + k * window_s: first_s + (k + 1) * window_s].all()]
    return full, n


def test_delimited_record_without_yaw_and_velocities_says_so(record):
    path, _, present = record
    ds = read_quadrotor(path, FORMAT)
    assert ds.sizes["time"] == int(present.sum())
    assert ds.attrs["yaw_known"] == 0 and ds.attrs["hover_assumed"] == 1 and ds.attrs["position_known"] == 0
    log = ds.attrs["processing_log"]
    assert "taken as hovering still" in log and "relative to the nose" in log
    assert float(ds["vel_n_ms"].max()) == 0.0 and float(ds["alt_m"].min()) == 150.0


@pytest.mark.parametrize("window_s", [600, 120])
def test_gaps_skip_only_the_windows_they_touch(record, window_s):
    path, gaps, present = record
    ds = read_quadrotor_delimited(path, FORMAT)
    ref = reference_from_record(ds, 50.0)
    blocks, windows, skipped = flight_windows_with_gaps(ds, ref, 100.0, "day1", "m600", window_s=window_s)
    first = int(np.flatnonzero(present)[0])
    full, n = _expected_windows(present, first, window_s)
    assert list(windows["window"]) == full
    assert len(windows) + len(skipped) == n
    assert skipped["reason"].str.contains("UAV record does not cover it").all()
    # the search never ends at a gap: windows are kept after the longest gap and after the last one
    kept_start = (windows["start"].to_numpy() - START.astype("datetime64[ns]")).astype("int64") // 10**9
    longest = max(gaps, key=lambda g: g[1])
    assert (kept_start >= longest[0] + longest[1]).any() and (kept_start + window_s <= longest[0]).any()
    assert (kept_start >= gaps[-1][0] + gaps[-1][1]).any()
    # and before the first gap where a window fits there
    if gaps[0][0] - first >= window_s:
        assert (kept_start + window_s <= gaps[0][0]).any()
    # every kept window holds a block per second and the reference of every second
    assert (windows["n_blocks"] == window_s).all() and (windows["n_ref"] == window_s).all()
    assert len(blocks) == window_s * len(windows)
    if window_s == 600:
        # the numbers of this seeded record (20 gaps, longest 7 min), for the report
        assert (len(windows), len(skipped)) == (len(full), n - len(full))
        assert skipped["reason"].str.contains("longest 420 s").sum() >= 1


def test_reference_gap_in_a_separate_file(record, tmp_path):
    path, _, present = record
    ds = read_quadrotor_delimited(path, FORMAT)
    # a tower file with 1-min means and one hour missing in the middle of the day
    t = np.arange(START, START + np.timedelta64(DURATION_S, "s"), np.timedelta64(60, "s"))
    keep = ~((t >= START + np.timedelta64(3 * 3600, "s")) & (t < START + np.timedelta64(4 * 3600, "s")))
    tower = pd.DataFrame({"time_utc": pd.to_datetime(t[keep]).strftime("%Y-%m-%dT%H:%M:%SZ"), "height_m": 50.0,
                          "wind_speed_ms": 5.0, "wind_from_deg": 210.0})
    tower.to_csv(tmp_path / "tower.csv", index=False)
    ref = read_tower_reference(tmp_path / "tower.csv")
    _, windows, skipped = flight_windows_with_gaps(ds, ref, 100.0, "day1", "m600", window_s=600)
    reasons = skipped["reason"]
    assert reasons.str.contains("reference does not cover it").sum() >= 5  # the hour holds 6 windows, some partly
    start_s = (windows["start"].to_numpy() - START.astype("datetime64[ns]")).astype("int64") // 10**9
    assert not ((start_s + 600 > 3 * 3600) & (start_s < 4 * 3600)).any()
    assert (start_s > 4 * 3600).any() and (start_s < 3 * 3600).any()


def test_skipped_windows_are_problems_of_the_flight(record):
    path, _, present = record
    ds = read_quadrotor_delimited(path, FORMAT)
    ref = reference_from_record(ds, 50.0)
    w, _, problems = compute_flight_windows({"m600": ds}, ref, "day1", 100.0, {"m600": path.name})
    for window_s in (600, 120):
        full, n = _expected_windows(present, int(np.flatnonzero(present)[0]), window_s)
        assert (w["window_s"] == window_s).sum() == len(full)
        assert (problems["window_s"] == window_s).sum() == n - len(full)
    assert problems["error"].str.match(r"window \d+ \(.*Z to .*Z\) skipped: the UAV record does not cover it").all()


def test_no_covered_window_is_a_named_error(record):
    path, _, _ = record
    ds = read_quadrotor_delimited(path, FORMAT)
    ref = reference_from_record(ds, 50.0)
    ref = ref.isel(time=slice(0, 10))  # ten seconds of reference
    with pytest.raises(InputError, match="no window covered.*reference does not cover it"):
        flight_windows(ds, ref, 100.0, "day1", "m600", window_s=600)


def test_record_reference_through_the_workflow_steps(record, tmp_path):
    """A delimited UAV record whose reference is its own columns: L1, then the flight's windows."""
    from dronewind.steps.quadrotor import quadrotor_l1, quadrotor_windows

    path, _, present = record
    site = {"latitude": 0.0, "longitude": 0.0, "altitude_m": 100.0}
    l1 = quadrotor_l1("gaps", "day1", "m600", path, site, tmp_path / "l1.nc", simulated=False, fmt=FORMAT)
    flight = {"id": "day1", "reference": {"from_record": True, "height_m": 50.0},
              "uavs": [{"id": "m600", "file": path.name, "format": FORMAT}]}
    out = [tmp_path / f"{k}.csv" for k in ("windows", "blocks", "problems")]
    quadrotor_windows(flight, {"m600": l1}, path, 100.0, 1.0, {}, *out)
    windows, problems = pd.read_csv(out[0]), pd.read_csv(out[2])
    for window_s in (600, 120):
        full, n = _expected_windows(present, int(np.flatnonzero(present)[0]), window_s)
        assert (windows["window_s"] == window_s).sum() == len(full)
        assert (problems["window_s"] == window_s).sum() == n - len(full)


def test_delimited_record_format_check_and_manifest(record, tmp_path):
    """The start-up check reads the mapped columns; a from_record reference needs mapped reference columns."""
    import yaml

    from dronewind.errors import ManifestError
    from dronewind.formats import check_file_format
    from dronewind.manifest import load_campaign

    path, _, _ = record
    check_file_format(path, FORMAT, "quadrotor_uav")
    bad = {**FORMAT, "variables": {**FORMAT["variables"], "roll": {"column": "bank", "unit": "degree"}}}
    with pytest.raises(InputError, match="bank"):
        check_file_format(path, bad, "quadrotor_uav")
    manifest = {"name": "gaps", "site": {"latitude": 0.0, "longitude": 0.0, "altitude_m": 100.0},
                "data_root": str(path.parent),
                "quadrotor_flights": [{"id": "day1", "role": "calibration",
                                       "reference": {"from_record": True, "height_m": 50.0},
                                       "uavs": [{"id": "m600", "file": path.name, "format": FORMAT}]}]}
    (tmp_path / "ok.yaml").write_text(yaml.safe_dump(manifest))
    assert load_campaign(tmp_path / "ok.yaml").quadrotor_flights[0]["role"] == "calibration"
    no_ref = {**FORMAT, "variables": {k: v for k, v in FORMAT["variables"].items() if not k.startswith("ref_")}}
    manifest["quadrotor_flights"][0]["uavs"][0]["format"] = no_ref
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(manifest))
    with pytest.raises(ManifestError, match="ref_speed"):
        load_campaign(tmp_path / "bad.yaml")


def test_contract_csv_without_yaw_and_a_tower_file(record, tmp_path):
    """The record converted by hand to the contract CSV (yaw empty, velocities 0, one height) and
    the tower's 1-Hz speed and direction as the reference file: the same windows as above."""
    path, _, present = record
    src = pd.read_csv(path)
    uav = pd.DataFrame({"time_utc": src["time"], "roll_deg": src["roll"], "pitch_deg": src["pitch"], "yaw_deg": "",
                        "vel_n_ms": 0.0, "vel_e_ms": 0.0, "vel_d_ms": 0.0, "lat_deg": 60.0, "lon_deg": 7.0,
                        "alt_m": 150.0})
    uav.to_csv(tmp_path / "uav.csv", index=False)
    tower = pd.DataFrame({"time_utc": src["time"], "height_m": 50.0, "wind_speed_ms": src["speed"],
                          "wind_from_deg": src["direction"]})
    tower.to_csv(tmp_path / "tower.csv", index=False)
    ds = read_quadrotor(tmp_path / "uav.csv")
    assert ds.attrs["yaw_known"] == 0 and "relative to the nose" in ds.attrs["processing_log"]
    _, windows, skipped = flight_windows_with_gaps(ds, read_tower_reference(tmp_path / "tower.csv"), 100.0, "day1",
                                                   "m600", window_s=600)
    full, n = _expected_windows(present, int(np.flatnonzero(present)[0]), 600)
    assert list(windows["window"]) == full and len(skipped) == n - len(full)
