"""The quadrotor fleet: calibration of pitch and yaw offsets against the tower (Wetz et al. 2021 tables)."""

from __future__ import annotations

import pytest

from conftest import DEFAULT_CAMPAIGN, cpu_round

N_FLIGHTS = 6  # of the default campaign's fleet flights (9-min hovers of four to eight UAVs each)


@pytest.fixture(scope="module")
def fleet_windows(setup, tmp_path_factory):
    """The first flights of the default fleet campaign, simulated and cut into 10-min windows (not timed)."""
    import pandas as pd

    from dronewind.quadrotor import windows as qw
    from dronewind.quadrotor.io import read_quadrotor
    from dronewind.quadrotor.reference import read_tower_reference
    from dronewind.simulate.quadrotor import simulate_quadrotor_flight

    data = setup["data"]
    out = tmp_path_factory.mktemp("bench_fleet")
    site_alt = float(data["site"]["altitude_m"])
    blocks, windows = [], []
    for f in data["quadrotor_flights"][:N_FLIGHTS]:
        paths = simulate_quadrotor_flight(data, DEFAULT_CAMPAIGN.parent, f["id"], out)
        ref = read_tower_reference(paths[-1])
        for p in paths[:-1]:
            b, w = qw.flight_windows(read_quadrotor(p), ref, site_alt, f["id"], p.stem, window_s=600.0)
            blocks.append(b)
            windows.append(w)
    return pd.concat(blocks, ignore_index=True), pd.concat(windows, ignore_index=True)


def test_quadrotor_calibration(benchmark, fleet_windows):
    """Offsets, drag-law fit and validation tables of the fleet (the quadrotor_calibration job's computation)."""
    from dronewind.quadrotor import validation

    blocks, windows = fleet_windows
    _, cpu = cpu_round(benchmark, validation.wetz2021_tables, blocks, windows, rounds=3)
    benchmark.extra_info.update(windows=len(windows), blocks=len(blocks),
                                windows_per_cpu_s=round(len(windows) / cpu, 1))
