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


def test_feature_steps_give_every_feature_once():
    from dronewind.diagnose.features import FEATURE_STEPS, FEATURES

    named = [f for names in FEATURE_STEPS.values() for f in names]
    assert sorted(named) == sorted(FEATURES)


@pytest.mark.parametrize("subset", [("sw_su_drone",), ("ln_sigma_ratio_w", "sw_su_mast"), ("corr_wres_roll_rate",)])
def test_requested_features_and_values_without_errors_are_those_of_the_full_call(subset):
    """A subset gives the full call's values bit for bit; the others are NaN 'not requested'.
    Without errors the values are the same and every error is NaN."""
    l3, l2 = _flight(gain_w=1.1)
    full = flight_features(l3, l2)
    part = flight_features(l3, l2, features=subset)
    bare = flight_features(l3, l2, errors=False)
    for name in full.values:
        assert bare.values[name] == full.values[name] or (np.isnan(bare.values[name]) and np.isnan(full.values[name]))
        assert np.isnan(bare.sigma[name])
        if name in _run_steps(subset):  # requested, or given by a step that was run for one that was
            assert part.values[name] == full.values[name] or (np.isnan(part.values[name])
                                                              and np.isnan(full.values[name]))
            assert part.sigma[name] == full.sigma[name] or (np.isnan(part.sigma[name]) and np.isnan(full.sigma[name]))
        else:
            assert np.isnan(part.values[name]) and part.reasons[name] == "not requested", name
    assert part.conditions == full.conditions
    assert any(r == "not requested" for r in part.reasons.values())


def _run_steps(subset):
    """The features of the steps that give one of ``subset``."""
    from dronewind.diagnose.features import FEATURE_STEPS

    return {f for names in FEATURE_STEPS.values() if set(names) & set(subset) for f in names}


def test_unknown_feature_is_refused():
    with pytest.raises(ValueError, match="unknown feature"):
        flight_features(*_flight(), features=("sigma_w",))
