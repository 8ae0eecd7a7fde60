"""Known-answer tests of dronewind.core.rotation (McMillen 1988; Wilczak et al. 2001;
Ghirardelli et al. (2025), Sect. 4.4)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from dronewind.core import rotation
from dronewind.errors import InputError, ProcessingError


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _pitch(b):  # maps x to (cos b, 0, sin b): mean wind tilted upwards by b
    c, s = np.cos(b), np.sin(b)
    return np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])


def _roll(g):  # rotation of the (y, z) plane
    c, s = np.cos(g), np.sin(g)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _streamline_record(seed=0, n=20_000, speed=7.0):
    """Streamline record: mean (speed, 0, 0), u'w' < 0, v'w' = 0 exactly, var v > var w."""
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n, 3))
    x -= x.mean(axis=0)
    # make v and w exactly uncorrelated (Gram-Schmidt) before scaling
    x[:, 2] -= x[:, 1] * (x[:, 1] @ x[:, 2]) / (x[:, 1] @ x[:, 1])
    u = speed + 0.9 * x[:, 0]
    v = 0.7 * x[:, 1]
    w = 0.4 * x[:, 2] - 0.15 * x[:, 0]  # u'w' < 0
    w -= w.mean()
    v -= v.mean()
    # re-impose v'w' = 0 after mixing u into w (v is uncorrelated with x0 only approximately)
    w -= v * (v @ w) / (v @ v)
    return u, v, w


def _tilt(u, v, w, yaw, pitch, roll=0.0):
    q = _rz(yaw) @ _pitch(pitch) @ _roll(roll)
    return q @ np.stack([u, v, w])


def test_single_rotation_zero_mean_v_and_angle():
    u0, v0, w0 = _streamline_record(1)
    ue, vn, wu = _tilt(u0, v0, w0, np.deg2rad(123.0), 0.0)
    u, v, w, ang = rotation.single_rotation(ue, vn, wu)
    assert ang["yaw_deg"] == pytest.approx(123.0, abs=1e-9)
    assert abs(v.mean()) < 1e-12
    assert u.mean() == pytest.approx(7.0, abs=1e-9)
    np.testing.assert_allclose(w, wu)


def test_double_rotation_recovers_streamline_record():
    """Tilted by yaw -150 deg and pitch 4 deg: double rotation gives mean v = w = 0 and the
    original series back (to 1e-10 m/s), and recovers both angles."""
    u0, v0, w0 = _streamline_record(2)
    ue, vn, wu = _tilt(u0, v0, w0, np.deg2rad(-150.0), np.deg2rad(4.0))
    u, v, w, ang = rotation.double_rotation(ue, vn, wu)
    assert abs(v.mean()) < 1e-12 and abs(w.mean()) < 1e-12
    assert ang["yaw_deg"] == pytest.approx(-150.0, abs=1e-9)
    assert ang["pitch_deg"] == pytest.approx(4.0, abs=1e-9)
    np.testing.assert_allclose(np.stack([u, v, w]), np.stack([u0, v0, w0]), atol=1e-10)


def test_triple_rotation_zero_vw_and_roll_angle():
    u0, v0, w0 = _streamline_record(3)
    assert abs(np.mean(v0 * w0)) < 1e-12
    ue, vn, wu = _tilt(u0, v0, w0, np.deg2rad(20.0), np.deg2rad(-3.0), np.deg2rad(10.0))
    u, v, w, ang = rotation.triple_rotation(ue, vn, wu)
    assert abs(v.mean()) < 1e-12 and abs(w.mean()) < 1e-12
    assert abs(np.mean((v - v.mean()) * (w - w.mean()))) < 1e-12
    assert ang["roll_deg"] == pytest.approx(10.0, abs=1e-8)
    np.testing.assert_allclose(np.stack([u, v, w]), np.stack([u0, v0, w0]), atol=1e-9)
    # double rotation alone leaves v'w' != 0 for this record
    _, v2, w2, _ = rotation.double_rotation(ue, vn, wu)
    assert abs(np.mean((v2 - v2.mean()) * (w2 - w2.mean()))) > 0.01


def _plane_blocks(seed, tilt_deg, azimuth_deg, b0=0.05, noise=0.01, n_blocks=60):
    """Block means lying in a plane whose normal is tilted by tilt_deg towards azimuth_deg."""
    rng = np.random.default_rng(seed)
    t, a = np.deg2rad(tilt_deg), np.deg2rad(azimuth_deg)
    k = np.array([-np.sin(t) * np.cos(a), -np.sin(t) * np.sin(a), np.cos(t)])  # plane rises towards a
    e1 = np.cross([0.0, 1.0, 0.0], k)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(k, e1)
    d = rng.uniform(0, 2 * np.pi, n_blocks)
    s = rng.uniform(1.0, 10.0, n_blocks)
    m = np.outer(s * np.cos(d), e1) + np.outer(s * np.sin(d), e2) + noise * rng.standard_normal((n_blocks, 3))
    m[:, 2] += b0
    return m, k


def test_planar_fit_recovers_tilt_within_0p1_deg():
    """60 blocks, tilt 3 deg towards 40 deg, offset 0.05 m/s, 0.01 m/s noise on the block
    means: the fitted normal is within 0.1 deg of the truth (measured 0.026 deg)."""
    m, k_true = _plane_blocks(4, 3.0, 40.0)
    fit = rotation.planar_fit_tilt(m[:, 0], m[:, 1], m[:, 2])
    err_deg = np.rad2deg(np.arccos(np.clip(fit.normal @ k_true, -1, 1)))
    assert err_deg < 0.1
    assert fit.tilt_deg == pytest.approx(3.0, abs=0.1)
    assert fit.tilt_azimuth_deg == pytest.approx(40.0, abs=2.0)
    assert fit.b0_ms == pytest.approx(0.05, abs=0.01)
    assert fit.n_blocks == 60 and fit.rms_residual_ms < 0.02
    p = fit.matrix()
    np.testing.assert_allclose(p @ p.T, np.eye(3), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(p), 1.0)


def test_apply_planar_fit_levels_the_blocks():
    m, _ = _plane_blocks(5, 5.0, 200.0, noise=0.0)
    fit = rotation.planar_fit_tilt(m[:, 0], m[:, 1], m[:, 2])
    # every block mean, after the tilt correction, has w = 0 (noise-free)
    for row in m[:5]:
        rec = np.tile(row, (10, 1)) + np.linspace(-0.1, 0.1, 10)[:, None]
        u, v, w, ang = rotation.apply_planar_fit(rec[:, 0], rec[:, 1], rec[:, 2], fit)
        assert abs(w.mean()) < 1e-10 and abs(v.mean()) < 1e-12 and u.mean() > 0
        assert ang["tilt_deg"] == pytest.approx(5.0, abs=1e-9)


def test_planar_fit_ill_posed_and_bad_input():
    s = np.linspace(1, 10, 20)
    with pytest.raises(ProcessingError):
        rotation.planar_fit_tilt(s, 0.5 * s, 0.01 * s)  # all blocks from one direction
    with pytest.raises(InputError):
        rotation.planar_fit_tilt([1.0, 2.0], [0.0, 1.0], [0.0, 0.0])


def test_rotate_by_name():
    u0, v0, w0 = _streamline_record(6, n=2000)
    ue, vn, wu = _tilt(u0, v0, w0, np.deg2rad(70.0), np.deg2rad(2.0))
    for name in ("none", "single", "double", "triple"):
        u, v, w, ang = rotation.rotate(ue, vn, wu, name)
        assert set(ang) == {"yaw_deg", "pitch_deg", "roll_deg"}
    u, v, w, ang = rotation.rotate(ue, vn, wu, "none")
    np.testing.assert_array_equal(u, ue)
    m, _ = _plane_blocks(7, 2.0, 0.0)
    fit = rotation.planar_fit_tilt(m[:, 0], m[:, 1], m[:, 2])
    u, v, w, ang = rotation.rotate(ue, vn, wu, "planar_fit", planar_fit=fit)
    assert abs(v.mean()) < 1e-12
    with pytest.raises(InputError, match="planar_fit"):
        rotation.rotate(ue, vn, wu, "planar_fit")
    with pytest.raises(InputError, match="unknown rotation"):
        rotation.rotate(ue, vn, wu, "quadruple")
    with pytest.raises(InputError, match="finite"):
        rotation.rotate(np.array([1.0, np.nan]), np.zeros(2), np.zeros(2))


def test_rotations_on_real_csat3_record(real_record):
    """Real 20 Hz CSAT3 record (fluxpart, CC0): double rotation zeroes mean v and w, triple
    also v'w'; the result does not depend on the sensor's heading (input pre-rotated by
    an arbitrary yaw gives the same streamline series to 1e-10 m/s); the rotation
    conserves the wind speed of every sample."""
    csat = real_record("fluxpart_csat3_toa5") / "TOA5_6843.ts_Above_2012_06_07_1300.dat"
    df = pd.read_csv(csat, skiprows=[0, 2, 3], na_values=["NAN"])
    x = df[["Ux", "Uy", "Uz"]].to_numpy(float)
    x = x[np.all(np.isfinite(x), axis=1)]
    u, v, w, ang = rotation.double_rotation(*x.T)
    assert abs(v.mean()) < 1e-12 and abs(w.mean()) < 1e-12
    np.testing.assert_allclose(np.sqrt(u * u + v * v + w * w), np.linalg.norm(x, axis=1), rtol=1e-12)
    xr_ = (_rz(np.deg2rad(77.0)) @ x.T)
    u2, v2, w2, ang2 = rotation.double_rotation(*xr_)
    np.testing.assert_allclose(np.stack([u2, v2, w2]), np.stack([u, v, w]), atol=1e-10)
    assert ang2["yaw_deg"] == pytest.approx(ang["yaw_deg"] + 77.0, abs=1e-9)
    u3, v3, w3, _ = rotation.triple_rotation(*x.T)
    assert abs(np.mean((v3 - v3.mean()) * (w3 - w3.mean()))) < 1e-12


def test_block_means_of_a_long_record_recover_the_plane():
    """A 10 Hz record of 12 half-hours (one of them mostly missing), each with a constant wind
    from another direction lying in a tilted plane: block means, fit, attrs round trip."""
    m, k_true = _plane_blocks(7, 2.0, 120.0, noise=0.0, n_blocks=12)
    fs, block = 10.0, 1800.0
    n = int(block * fs)
    t0 = np.datetime64("2023-12-13T00:00:00", "ns")
    time = t0 + (np.arange(12 * n) * int(1e9 / fs)).astype("timedelta64[ns]")
    u, v, w = (np.repeat(m[:, i], n) for i in range(3))
    rng = np.random.default_rng(1)
    u = u + rng.normal(0, 0.5, u.size)
    u[3 * n: 3 * n + int(0.6 * n)] = np.nan  # block 4: only 40 % valid -> not used
    bu, bv, bw = rotation.block_means(time, u, v, w, block_s=block)
    assert bu.size == 11
    fit = rotation.planar_fit_tilt(bu, bv, bw)
    assert np.rad2deg(np.arccos(fit.normal @ k_true)) < 0.05
    again = rotation.planar_fit_from_attrs(rotation.planar_fit_attrs(fit))
    np.testing.assert_allclose(again.matrix(), fit.matrix(), atol=1e-12)
    assert again.tilt_deg == pytest.approx(fit.tilt_deg)
    assert rotation.planar_fit_from_attrs(rotation.planar_fit_attrs(None, "too few blocks")) is None


@pytest.mark.parametrize("sigma_v, sigma_w, vw", [
    (1.2, 1.3, 0.019),   # Table 5, s7 drone: sigma_w > sigma_v (Ghirardelli et al. 2025); gamma = -4.3 deg
    (1.2, 1.3, -0.019),
    (1.0, 0.7, 0.05),    # the usual case sigma_v > sigma_w
    (0.6, 1.1, 0.20),
])
def test_triple_rotation_keeps_roll_within_45_degrees(sigma_v, sigma_w, vw):
    """McMillen (1988): the roll is the root of tan(2 gamma) with |gamma| <= 45 deg; the other
    root (chosen by a full-range atan2 when sigma_w > sigma_v) swaps v and w."""
    rng = np.random.default_rng(5)
    n = 40_000
    cov = np.array([[sigma_v**2, vw], [vw, sigma_w**2]])
    v, w = rng.multivariate_normal([0.0, 0.0], cov, size=n).T
    u = 8.0 + rng.standard_normal(n)
    v -= v.mean()
    w -= w.mean()
    _, v3, w3, ang = rotation.triple_rotation(u, v, w)
    vv, ww, c = np.mean(v * v), np.mean(w * w), np.mean(v * w)
    expected = np.rad2deg(0.5 * np.arctan(2.0 * c / (vv - ww)))
    assert abs(ang["roll_deg"]) <= 45.0
    assert ang["roll_deg"] == pytest.approx(expected, abs=1e-6)
    assert abs(np.mean(v3 * w3)) < 1e-10
    # v stays the crosswind and w the vertical component (no exchange of variances): each
    # rotated standard deviation is nearer its own unrotated value than the other one
    assert abs(np.std(w3) - np.std(w)) < abs(np.std(w3) - np.std(v))
    assert abs(np.std(v3) - np.std(v)) < abs(np.std(v3) - np.std(w))


def test_triple_rotation_table5_s7_angle():
    """With Table 5's s7 drone values (sigma_v 1.2, sigma_w 1.3 m/s) and v'w' = 0.019 m2/s2 the
    roll is -4.3 deg (the old full-range atan2 gave +85.7 deg)."""
    gamma = np.rad2deg(rotation.roll_angle_rad(0.019, 1.2**2, 1.3**2))
    assert gamma == pytest.approx(-4.3, abs=0.05)
    assert np.rad2deg(rotation.roll_angle_rad(0.0, 1.0, 2.0)) == 0.0
    assert np.rad2deg(rotation.roll_angle_rad(0.1, 1.0, 1.0)) == pytest.approx(45.0)
