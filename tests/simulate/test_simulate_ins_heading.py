"""The INS heading error held over a flight (``simulation.payload.ins_heading_offset_deg``).

A dual-antenna GNSS heading errs by carrier-phase multipath, which holds over a hover
(:data:`dronewind.simulate.defaults.PAYLOAD_DEFAULTS`): the setting adds one heading offset
per flight and seed, of the given standard deviation, to the INS yaw and changes nothing
else. Its default, 0, leaves every record as it was, bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from dronewind.diagnose.experiments import Draw, campaign_manifest
from dronewind.errors import InputError
from dronewind.simulate.defaults import PAYLOAD_DEFAULTS
from dronewind.simulate.payload import _ins_noise, payload_records

SIGMA_DEG = 0.4


def _campaign(offset_deg: float | None) -> dict:
    data = campaign_manifest(Draw("none", {}, 3), n_flights=1, hover_min=5.0)
    if offset_deg is not None:
        data["simulation"]["payload"] = {"ins_heading_offset_deg": offset_deg}
    return data


def _columns(data: dict) -> list[dict[str, np.ndarray]]:
    records, _ = payload_records(data, "h01")
    return [dict(r.columns) for r in records]


@pytest.fixture(scope="module")
def plain() -> list[dict[str, np.ndarray]]:
    return _columns(_campaign(None))


def test_default_is_zero_and_spelled_out_changes_no_record(plain):
    assert PAYLOAD_DEFAULTS["ins_heading_offset_deg"][0] == 0.0
    for got, want in zip(_columns(_campaign(0.0)), plain, strict=True):
        assert got.keys() == want.keys()
        for key in want:
            np.testing.assert_array_equal(got[key], want[key], err_msg=key)


def test_offset_moves_the_ins_yaw_by_one_constant_and_nothing_else(plain):
    sonic, ins, mast = _columns(_campaign(SIGMA_DEG))
    for got, want in ((sonic, plain[0]), (mast, plain[2])):
        for key in want:
            np.testing.assert_array_equal(got[key], want[key], err_msg=key)
    for key in plain[1]:
        if key != "yaw_deg":
            np.testing.assert_array_equal(ins[key], plain[1][key], err_msg=key)
    diff = (np.asarray(ins["yaw_deg"], float) - np.asarray(plain[1]["yaw_deg"], float) + 180.0) % 360.0 - 180.0
    # the same offset on every row: the log writes the yaw to 1e-4 degree, so the difference of
    # two written yaws varies by at most one step
    assert np.ptp(diff) <= 1e-4 + 1e-9
    assert 0.0 < abs(diff[0]) < 5 * SIGMA_DEG


@pytest.mark.slow
def test_offsets_over_seeds_have_the_standard_deviation_set_and_leave_the_other_errors():
    settings = {"ins_noise_time_s": 1.0, "ins_velocity_noise_ms": 0.03, "ins_roll_pitch_noise_deg": 0.05,
                "ins_heading_noise_deg": 0.4, "ins_horizontal_position_noise_m": 0.01,
                "ins_vertical_position_noise_m": 0.02}
    offsets = []
    for seed in range(2000):
        without = _ins_noise({**settings, "ins_heading_offset_deg": 0.0}, 8, np.random.default_rng(seed), 50.0)
        with_offset = _ins_noise({**settings, "ins_heading_offset_deg": SIGMA_DEG}, 8,
                                 np.random.default_rng(seed), 50.0)
        # the offset is the stream's last draw: the other errors are those without it
        for a, b in zip(without[:-1], with_offset[:-1], strict=True):
            np.testing.assert_array_equal(a, b)
        assert float(without[-1]) == 0.0
        offsets.append(float(with_offset[-1]))
    # 2000 normal draws: the sample standard deviation has a relative standard error of
    # 1/sqrt(2 * 1999) = 1.6 %; 5 % is three of them. The mean's standard error is 0.009 degree.
    assert np.std(offsets, ddof=1) == pytest.approx(SIGMA_DEG, rel=0.05)
    assert abs(np.mean(offsets)) < 3 * SIGMA_DEG / np.sqrt(2000)


def test_offset_outside_its_range_is_refused():
    with pytest.raises(InputError, match=r"simulation\.payload\.ins_heading_offset_deg: -0\.1 outside"):
        payload_records(_campaign(-0.1), "h01")
