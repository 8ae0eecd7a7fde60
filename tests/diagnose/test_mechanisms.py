"""Tests of the mechanism catalog (dronewind.mechanisms)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from dronewind.errors import InputError
from dronewind.mechanisms import CATALOG, get_mechanism, mechanisms_for, validate_parameters

CONTRACT = Path(__file__).resolve().parents[2] / "docs" / "data-contract.md"
PAYLOAD = {"sonic_ins_lag", "clock_drift", "mount_misalignment", "heading_bias", "attitude_lag",
           "lever_arm", "w_gain", "sonic_noise", "height_offset", "downwash"}


def test_catalog_matches_data_contract_table():
    """Every mechanism of the table in docs/data-contract.md is in the catalog with the same parameters."""
    text = CONTRACT.read_text(encoding="utf-8").split("## Mechanisms", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| `([a-z_]+)` \| ([^|]*)\|", text, flags=re.M)
    assert len(rows) >= 16
    for name, params in rows:
        mech = get_mechanism(name)
        expected = [p.strip() for p in params.split(",") if p.strip()]
        if name == "drag_regime":
            expected = ["coefficients"]
        assert list(mech.parameter_names) == expected, name
    assert set(CATALOG) == {r[0] for r in rows}


def test_platforms():
    assert {m.name for m in mechanisms_for("payload")} == PAYLOAD
    assert [m.name for m in mechanisms_for("mast")] == ["mast_w_attenuation"]
    assert [m.name for m in mechanisms_for("rigid_mount")] == ["platform_velocity_response"]
    assert {m.name for m in mechanisms_for("quadrotor")} == {"pitch_offset", "yaw_offset", "drag_regime",
                                                             "response_lag"}
    for m in CATALOG.values():
        for p in m.parameters:
            assert p.units and p.description
            if p.kind == "float":
                assert p.lower < p.upper


def test_validate_parameters_accepts_and_converts():
    out = validate_parameters("downwash", {"w0_ms": 1, "u_scale_ms": 4.0})
    assert out == {"w0_ms": 1.0, "u_scale_ms": 4.0}
    assert validate_parameters("none", None) == {}
    assert validate_parameters("pitch_offset", {"uav": "q01", "deg": 1.5}) == {"uav": "q01", "deg": 1.5}
    assert validate_parameters("platform_velocity_response", {"gain_h": 1, "gain_v": 0.7}) == {
        "gain_h": 1.0, "gain_v": 0.7}


@pytest.mark.parametrize("name,params,fragment", [
    ("attitude_lag", {"lag_s": 5.0}, "lag_s"),
    ("attitude_lag", {}, "lag_s"),
    ("attitude_lag", {"lag_s": 0.1, "extra": 1}, "extra"),
    ("w_gain", {"gain": "big"}, "gain"),
    ("downwash", {"w0_ms": 1.0, "u_scale_ms": 0.0}, "u_scale_ms"),
    ("mast_w_attenuation", {"gain": float("nan")}, "gain"),
    ("platform_velocity_response", {"gain_h": 1.0, "gain_v": -0.1}, "gain_v"),
    ("platform_velocity_response", {"gain_h": 1.6, "gain_v": 1.0}, "gain_h"),
    ("platform_velocity_response", {"gain_h": 1.0}, "gain_v"),
])
def test_validate_parameters_rejects(name, params, fragment):
    with pytest.raises(InputError) as err:
        validate_parameters(name, params, where="simulation.mechanisms[0].parameters")
    assert fragment in str(err.value)
    assert "simulation.mechanisms[0].parameters" in err.value.where


def test_unknown_mechanism_named():
    with pytest.raises(InputError, match="unknown mechanism 'wobble'"):
        get_mechanism("wobble", "simulation.mechanisms[3].mechanism")
    with pytest.raises(InputError):
        mechanisms_for("balloon")


def test_catalog_is_read_only():
    with pytest.raises(TypeError):
        CATALOG["new"] = None  # type: ignore[index]
