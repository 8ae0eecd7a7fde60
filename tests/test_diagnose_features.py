"""Residual features on synthetic flights with known answers."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from dronewind.diagnose.features import flight_features
from dronewind.simulate.atmosphere import simulate_wind

FS_HZ = 8.0


def _flight(gain_w: float = 1.0, seed: int = 3) -> tuple[xr.Dataset, xr.Dataset]:
    """L3/L2 stand-ins: drone and mast 60 m apart across the wind at 50 m, wind from the west."""
    points = np.array([[0.0, 0.0, 50.0], [0.0, 60.0, 50.0]])
    wind = simulate_wind(points, 1800.0, FS_HZ, 8.0, 270.0, 50.0, float("inf"), 0.1, seed=seed)
    u = wind.u_east_ms.values  # along-wind (from the west)
    v = wind.v_north_ms.values
    w = wind.w_up_ms.values.copy()
    w[0] *= gain_w
    time = pd.date_range("2023-12-13T07:00", periods=u.shape[1], freq="125ms").values
    l3 = xr.Dataset(
        {"u_ms": (("sensor", "time"), u), "v_ms": (("sensor", "time"), v), "w_ms": (("sensor", "time"), w),
         "wind_from_deg": ("sensor", [270.0, 270.0]), "height_m": ("sensor", [50.0, 50.0]),
         "rotation_pitch_deg": ("sensor", [0.0, 0.0])},
        coords={"sensor": ["drone", "mast"], "time": time}, attrs={"sampling_rate_hz": FS_HZ, "lag_drone_mast_s": 0.0})
    rng = np.random.default_rng(seed)
    l2 = xr.Dataset({"pitch_deg": ("time", rng.normal(0, 1, time.size)),
                     "roll_deg": ("time", rng.normal(0, 1, time.size))},
                    coords={"time": time}, attrs={"lag_sonic_ins_s": 0.0})
    return l3, l2


def test_isotropy_ratio_is_four_thirds_and_unbiased():
    """Simulated isotropic inertial subrange: <S_w/S_u> over 2 < f_r < 10 near 4/3 (not 8/6 x 4/3)."""
    l3, l2 = _flight()
    feats = flight_features(l3, l2)
    for sensor in ("drone", "mast"):
        value = feats.values[f"sw_su_{sensor}"]
        # tolerance: 3 sampling errors of the band average plus 0.1 for the Kaimal shape at f_r = 2
        assert value == pytest.approx(4 / 3, abs=0.1 + 3 * feats.sigma[f"sw_su_{sensor}"]), value


def test_w_gain_shows_in_sigma_and_spectral_ratios():
    gain = 1.2
    base = flight_features(*_flight())
    feats = flight_features(*_flight(gain_w=gain))
    assert feats.values["ln_sigma_ratio_w"] - base.values["ln_sigma_ratio_w"] == pytest.approx(np.log(gain), abs=1e-9)
    ratio = feats.values["sw_su_drone"] / base.values["sw_su_drone"]
    assert ratio == pytest.approx(gain**2, rel=1e-9)
    assert feats.values["sw_su_mast"] == base.values["sw_su_mast"]
