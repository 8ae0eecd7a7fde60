"""Diagnosis candidates of a multi-day campaign: per-flight pitch offsets and the logged air density.

Windows are made from the drag balance itself (Wetz et al. 2021, Eqs. 12-18 with the law of
Eq. 18): for a reference speed the tilt of the balance is found on a fine grid, the logged
pitch is that tilt (nose into the wind, weather vane) plus the hidden offset, with seeded
attitude noise. 8 flights x 3 UAVs x 5 two-minute windows of 12 ten-second blocks.

* Days: the IMUs are re-levelled between day 1 (flights 1-4) and day 2 (flights 5-8), so each
  UAV's offset changes by 1-2 degrees: ``flight_pitch_offset`` must be named, and recover the
  offsets of each flight; with one offset per UAV for both days it must not be.
* One day: only the second day's IMUs are off (the first day's are level): the per-flight
  offsets must be named, the per-UAV ones not.
* Density: the flights are flown in air of 0.95 to 1.30 kg m-3 (the balance is evaluated at
  each flight's density, which the records log): ``air_density`` must be named; with one
  density for all flights it must not be.
* Null: level IMUs and one logged density: nothing is named.

The per-flight offsets and the logged density are candidates of the same naming rounds as the
per-UAV ones (one paired test per flight and UAV, Bonferroni over the round's up to five
candidates: level 0.01 / 5 = 0.002, gain >= 0.05).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from dronewind.core.constants import AIR_DENSITY_KGM3, WETZ2021_AERO
from dronewind.diagnose import quadrotor as dq
from dronewind.quadrotor.drag import speed_from_tilt

#: fleet diagnoses of eight flights each (seconds apiece): outside the fast tier
pytestmark = pytest.mark.slow

UAVS = ("q01", "q02", "q03")
FLIGHTS = tuple(f"d{k // 4 + 1}f{k + 1}" for k in range(8))
TILT_GRID = np.radians(np.linspace(0.0, 25.0, 25001))


def _tilt_for(speed_ms: np.ndarray, rho: float) -> np.ndarray:
    """Tilt [rad] at which the drag balance gives ``speed_ms`` (fine grid, monotonic law)."""
    v = speed_from_tilt(TILT_GRID, WETZ2021_AERO["cd0a0_m2"], WETZ2021_AERO["cp_m2_per_rad"], rho_kgm3=rho)
    return np.interp(speed_ms, v, TILT_GRID)


def _windows(seed: int, offset_deg, rho_of_flight, log_density: bool = True, flights=FLIGHTS):
    rng = np.random.default_rng(seed)
    blocks, windows = [], []
    for flight in flights:
        for u in UAVS:
            for k in range(5):
                key = f"{flight}/{u}/{k}"
                ref = 2.5 + 8.5 * rng.random()
                frm = float(rng.uniform(180, 330))
                speed = ref * (1 + 0.1 * rng.standard_normal(12))  # 10-s blocks of a turbulent wind
                tilt = np.degrees(_tilt_for(np.clip(speed, 0.5, None), rho_of_flight(flight)))
                blocks.append(pd.DataFrame({
                    "window_key": key, "roll_deg": rng.normal(0.0, 0.3, 12),
                    "pitch_deg": -tilt + offset_deg(flight, u) + rng.normal(0.0, 0.3, 12),
                    "yaw_deg": (frm + rng.normal(0, 5, 12)) % 360, "vel_n_ms": rng.normal(0, 0.05, 12),
                    "vel_e_ms": rng.normal(0, 0.05, 12),
                    "rho_kgm3": rho_of_flight(flight) if log_density else np.nan}))
                windows.append({"window_key": key, "flight": flight, "uav": u, "ref_speed_ms": ref,
                                "ref_from_deg": frm})
    return pd.concat(blocks, ignore_index=True), pd.DataFrame(windows)


def _cand(res, name):
    return next((c for c in res["candidates"] if c["mechanism"] == name), None)


BASE = {"q01": 1.5, "q02": -2.0, "q03": 0.5}
RELEVEL = {"q01": -1.5, "q02": 2.0, "q03": 1.2}


def _two_days(flight: str, uav: str) -> float:
    return BASE[uav] + (RELEVEL[uav] if flight.startswith("d2") else 0.0)


def test_relevelled_imus_give_per_flight_offsets():
    blocks, windows = _windows(7, _two_days, lambda f: AIR_DENSITY_KGM3, log_density=False)
    res = dq.diagnose_quadrotor("days", blocks, windows, block_s=10.0)
    cand = _cand(res, "flight_pitch_offset")
    assert cand is not None and cand["significant"], cand
    assert "flight_pitch_offset" in res["named_causes"]
    assert cand["heldout"].endswith("within flights")
    # offsets of each flight and UAV within 0.5 degree, under half the smallest re-levelling (1.2 degree);
    # measured 0.33 degree at most: the 10 % turbulence of the 10-s blocks over 5 windows per flight
    # and UAV dominates (the common part trades off against the law, as for per-UAV offsets)
    err = np.array([cand["estimate"][f"{f}/{u}"] - _two_days(f, u) for f in FLIGHTS for u in UAVS])
    assert np.max(np.abs(err - err.mean())) < 0.5
    assert _cand(res, "air_density") is None  # no density logged: not scored


def test_one_levelling_names_no_per_flight_offsets():
    blocks, windows = _windows(8, lambda f, u: BASE[u], lambda f: AIR_DENSITY_KGM3, log_density=False)
    res = dq.diagnose_quadrotor("one day", blocks, windows, block_s=10.0)
    assert "pitch_offset" in res["named_causes"]
    cand = _cand(res, "flight_pitch_offset")
    assert cand is not None and not cand["significant"] and cand["gain"] < 0.05


def test_an_offset_on_one_day_is_named_per_flight_not_per_uav():
    """12 flights, 6 a day; the second day's IMUs off by RELEVEL. Measured over seeds 11-14:
    per-flight offsets named in 4 of 4 (p 1.3e-6 to 4.6e-4, held-out gain 0.61-0.67), the
    per-UAV offsets never (p 0.017-0.043, gain 0.26-0.28: half the flights have no offset). With
    8 flights (4 a day) the per-flight offsets are named in 5 of 7 draws (seeds 11-17; the two
    others name nothing: with half the flight-UAV units level, the rank test's p is 0.004-0.006)."""
    flights = tuple(f"d{k // 6 + 1}f{k + 1}" for k in range(12))
    blocks, windows = _windows(12, lambda f, u: RELEVEL[u] if f.startswith("d2") else 0.0,
                               lambda f: AIR_DENSITY_KGM3, log_density=False, flights=flights)
    res = dq.diagnose_quadrotor("one day", blocks, windows, block_s=10.0)
    assert res["named_causes"] == ["flight_pitch_offset"], res["named_causes"]
    per_uav = _cand(res, "pitch_offset")
    # scored in the same round, against the same baseline, and not significant
    assert per_uav is not None and not per_uav["significant"]
    cand = _cand(res, "flight_pitch_offset")
    assert cand["gain"] > per_uav["gain"] + 0.2 and cand["alpha_bonferroni"] == per_uav["alpha_bonferroni"]
    assert res["ambiguity_sets"] == [["flight_pitch_offset"]]
    err = np.array([cand["estimate"][f"{f}/{u}"] - (RELEVEL[u] if f.startswith("d2") else 0.0)
                    for f in flights for u in UAVS])
    assert np.max(np.abs(err - err.mean())) < 0.5


def test_null_fleet_names_nothing():
    """Level IMUs, one logged density (1.1 kg m-3): every candidate is scored in the first round
    and none is named (measured over seeds 21-23: largest gain 0.007, the density's 0.000)."""
    blocks, windows = _windows(21, lambda f, u: 0.0, lambda f: 1.1)
    res = dq.diagnose_quadrotor("null", blocks, windows, block_s=10.0)
    assert res["named_causes"] == [] and res["ambiguity_sets"] == []
    field = [c for c in res["candidates"] if c["source"] == "field"]
    assert {c["mechanism"] for c in field} == {"pitch_offset", "yaw_offset", "drag_regime", "flight_pitch_offset",
                                               "air_density"}
    assert len({c["alpha_bonferroni"] for c in field}) == 1  # one round, one family
    assert all(c["gain"] < 0.05 for c in field)


@pytest.mark.parametrize("varies", [True, False])
def test_logged_air_density(varies):
    """Measured (seeds 9-11): over 0.95-1.30 kg m-3 named in 3 of 3 (p 2e-6 to 4e-4, gain
    0.35-0.42); over 1.00-1.25 kg m-3 in 2 of 3 (seed 9: p 0.003 above the round's 0.002)."""
    rho = {f: (0.95 + 0.35 * k / 7 if varies else 1.1) for k, f in enumerate(FLIGHTS)}
    blocks, windows = _windows(9, lambda f, u: 0.0, rho.__getitem__)
    res = dq.diagnose_quadrotor("density", blocks, windows, block_s=10.0)
    cand = _cand(res, "air_density")
    assert cand is not None and cand["heldout"] == "5-fold over flights"
    if varies:
        assert cand["significant"] and res["named_causes"] == ["air_density"], cand
    else:
        # one density for all flights: the fitted law absorbs it, the logged density adds nothing
        assert not cand["significant"] and abs(cand["gain"]) < 0.05
