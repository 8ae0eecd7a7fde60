"""The independent world (tests/worlds) against known answers, and the diagnosis against it.

Fast checks (no marker, about 20 CPU-s together): the Mann box's variances and inertial
slope, the pendulum's period, the written files read back by dronewind's readers, the
sonic-INS lag found where it was put. Slow (``-m slow``): a null campaign of three 11-minute
hovers diagnosed in-process and judged (:func:`judged_draw`); the hidden-mechanism campaign
is judged in tests/diagnose/test_independent_world_heading.py, a module of its own so that
the two campaigns, each a module's fixture, may run on different workers.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.signal

from dronewind.diagnose import probes
from dronewind.diagnose.experiments import Draw, judge
from dronewind.diagnose.in_process import diagnose_evidence, measured_campaign_evidence
from dronewind.manifest import default_config, load_campaign
from dronewind.mast.chain import compute_mast_l1
from dronewind.payload.chain import compute_payload_l1, compute_payload_l2
from tests.worlds import WorldSettings, pendulum, turbulence, write_campaign


def test_mann_box_variances_and_inertial_slope() -> None:
    """hipersim's box at Gamma 3.9 scaled to sigma_u = 1: sigma_u exact, sigma_v/sigma_u and
    sigma_w/sigma_u near the Mann (1994) / IEC 61400-1 Annex C ratios 0.7-0.8 and 0.5, and
    the u spectrum falling as k^(-5/3) between 4/L and a quarter of the Nyquist wavenumber."""
    uvw = turbulence.mann_box(17.7, 3.9, 1.0, (4096, 16, 8), (1.0, 4.0, 4.0), seed=3)
    sig = uvw.std(axis=(1, 2, 3))
    assert sig[0] == pytest.approx(1.0, rel=1e-4)
    # a 4-km box holds ~230 length scales: sampling error of the ratios about 5 %
    assert 0.6 < sig[1] / sig[0] < 0.9
    assert 0.4 < sig[2] / sig[0] < 0.65
    spec = (np.abs(np.fft.rfft(uvw[0], axis=0)) ** 2).mean(axis=(1, 2))
    k = np.fft.rfftfreq(4096, d=1.0) * 2 * np.pi
    band = (k > 4 / 17.7) & (k < np.pi / 4)
    slope = np.polyfit(np.log(k[band]), np.log(spec[band]), 1)[0]
    assert slope == pytest.approx(-5 / 3, abs=0.2)     # 2 decades of a 1-realisation spectrum


def test_inertial_deficit_known_answer() -> None:
    """A spectrum that follows -5/3 up to 1 rad/m and falls as k^-4 beyond: the level is read in
    the fit band, nothing is added below its top, the law minus the box above, all of it beyond
    the box's last wavenumber."""
    k = np.linspace(0.0, 5.0, 501)
    law = 0.2 * np.where(k > 0, k, np.inf) ** (-5 / 3)
    box = np.where(k <= 1.0, law, 0.2 * np.where(k > 0, k, np.inf) ** -4.0)
    box = np.broadcast_to(box, (3, k.size)) * np.array([[1.0], [4 / 3], [4 / 3]])
    k_out, deficit = turbulence.inertial_deficit(k, box, (0.3, 0.8), k_max_rad_m=50.0)
    assert k_out[0] == 0.0 and k_out[-1] == pytest.approx(50.0) and np.all(np.diff(k_out) > 0)
    assert np.all(deficit[:, k_out <= 0.8] == 0.0)
    above = (k_out > 1.0) & (k_out <= 5.0)
    expected = 0.2 * (k_out[above] ** (-5 / 3) - k_out[above] ** -4.0)
    np.testing.assert_allclose(deficit[0, above], expected, rtol=1e-9)
    np.testing.assert_allclose(deficit[2, above], 4 / 3 * expected, rtol=1e-9)
    beyond = k_out > 5.0
    np.testing.assert_allclose(deficit[1, beyond], 4 / 3 * 0.2 * k_out[beyond] ** (-5 / 3), rtol=1e-9)


def test_topup_series_has_the_deficit_spectrum() -> None:
    """A sensor's top-up at 20 Hz: variance the integral of the deficit over the record's band
    (Taylor: f = k U / 2 pi), its spectrum -5/3, independent between calls (sensors)."""
    k = np.geomspace(1e-3, 100.0, 4000)
    deficit = np.where(k > 1.0, 0.05 * k ** (-5 / 3), 0.0)
    field = turbulence.WindField(np.zeros((3, 8, 2, 2), np.float32), (1.0, 4.0, 4.0), 6.0, 1.0, 0.0, 6.0, 270.0,
                                 30.0, 0.4, 0.05, math.inf, topup=(k, np.stack([deficit] * 3)))
    rng = np.random.default_rng(5)
    a, b = field.topup_enu(rng, 2**16, 20.0), field.topup_enu(rng, 2**16, 20.0)
    k_band = np.linspace(1.0, 2 * np.pi * 10.0 / 6.0, 20000)
    expected = np.trapezoid(0.05 * k_band ** (-5 / 3), k_band)      # over 1 rad/m .. the 10 Hz Nyquist
    assert a[:, 2].var() == pytest.approx(expected, rel=0.05)      # 2**16 samples: about 1 % error
    assert a[:, 0].var() + a[:, 1].var() == pytest.approx(2 * expected, rel=0.05)   # u, v turned to east, north
    assert abs(np.corrcoef(a[:, 2], b[:, 2])[0, 1]) < 0.02
    f, p = scipy.signal.welch(a[:, 2], fs=20.0, nperseg=4096)
    band = (f > 1.5) & (f < 8.0)      # the deficit starts at 1 rad/m: 0.95 Hz at 6 m/s
    assert np.polyfit(np.log(f[band]), np.log(p[band]), 1)[0] == pytest.approx(-5 / 3, abs=0.1)
    assert np.all(turbulence.WindField(np.zeros((3, 8, 2, 2), np.float32), (1.0, 4.0, 4.0), 6.0, 1.0, 0.0, 6.0,
                                       270.0, 30.0, 0.4, 0.05, math.inf).topup_enu(rng, 100, 20.0) == 0.0)


def test_turbulence_from_the_nearest_node() -> None:
    """Across and up the wind a sensor gets its nearest node's series (no averaging of
    partly incoherent nodes, which would take small-scale energy from it); along the wind the
    box is carried at the mean speed (Taylor): a point 10 m downwind sees the series 2 s later."""
    uvw = turbulence.mann_box(17.7, 3.9, 1.0, (2048, 16, 12), (0.5, 4.0, 4.0), seed=3)
    field = turbulence.WindField(uvw, (0.5, 4.0, 4.0), 6.0, 32.0, 20.0, 5.0, 270.0, 30.0, 0.4, 0.05, math.inf)
    t = np.arange(0.0, 150.0, 0.1)
    zero = np.zeros_like(t)
    on_node = field.turbulence(t, zero, zero, np.full_like(t, 30.0))
    np.testing.assert_array_equal(field.turbulence(t, zero, zero + 1.9, np.full_like(t, 31.9)), on_node)
    downwind = field.turbulence(t + 2.0, zero + 10.0, zero, np.full_like(t, 30.0))   # wind from the west
    np.testing.assert_allclose(downwind, on_node, atol=1e-5)


def test_log_profile_and_stability() -> None:
    """u* reproduces the speed at its height; the Högström psi_m is 0 at neutral, positive
    unstable, -6 zeta stable."""
    ustar = turbulence.friction_velocity_ms(6.0, 30.0, 0.05, -100.0)
    assert turbulence.profile_speed_ms(np.array([30.0]), ustar, 0.05, -100.0)[0] == pytest.approx(6.0)
    assert float(turbulence.psi_m(0.0)) == 0.0
    assert float(turbulence.psi_m(-0.5)) > 0.0
    assert float(turbulence.psi_m(0.2)) == pytest.approx(-1.2)


def test_pendulum_period_small_drag() -> None:
    """With drag 1e-6 of the default and a still hook, the swing's period is 2 pi sqrt(L/g)
    within 0.5 % (small amplitude: the finite-amplitude correction theta0^2/16 is 2e-5)."""
    line = pendulum.LineSettings(payload_cda_m2=1e-8, line_diameter_m=1e-9)
    t = np.arange(0.0, 90.0, 0.05)
    zeros3 = np.zeros((t.size, 3))
    hook = np.zeros((t.size, 9))
    y0 = np.array([0.3, 0.0, -math.sqrt(18.0**2 - 0.09), 0.0, 0.0, 0.0, 0.0, 0.0])
    out = pendulum.solve_pendulum(line, t, hook, zeros3, np.zeros((t.size, line.n_segments, 3)), np.zeros(t.size),
                                  t, y0=y0)
    x = out[:, 0]
    up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    crossings = t[up] - x[up] * (t[up + 1] - t[up]) / (x[up + 1] - x[up])
    period = float(np.mean(np.diff(crossings)))
    assert period == pytest.approx(2 * math.pi * math.sqrt(18.0 / 9.81), rel=5e-3)
    assert np.linalg.norm(out[:, :3], axis=1) == pytest.approx(18.0, abs=1e-3)   # the line stays taut


def test_euler_convention_matches_contract() -> None:
    """The world's body axes -> roll, pitch, yaw -> R(phi, theta, psi) gives the axes back in NED."""
    rng = np.random.default_rng(0)
    r = np.column_stack([rng.normal(0, 3, 50), rng.normal(0, 3, 50), -np.full(50, 17.0)])
    heading = rng.uniform(-np.pi, np.pi, 50)
    axes = pendulum.body_axes_enu(r, heading)
    att = pendulum.euler_deg(axes)
    rot = pendulum.body_to_ned(att[:, 0], att[:, 1], att[:, 2])
    np.testing.assert_allclose(rot, np.einsum("ij,njk->nik", pendulum.ENU_TO_NED, axes), atol=1e-9)
    assert np.all((att[:, 2] >= 0) & (att[:, 2] < 360))


@pytest.fixture(scope="module")
def short_campaign(tmp_path_factory: pytest.TempPathFactory):
    """One 3-minute flight (box of 4096 points) hiding a sonic-INS lag of 0.4 s."""
    folder = tmp_path_factory.mktemp("world")
    settings = WorldSettings(n_flights=1, hover_s=180.0, nx=4096)
    truth = Draw("sonic_ins_lag", {"lag_s": 0.4}, seed=11)
    manifest = write_campaign(truth, folder, settings)
    return folder, manifest, json.loads((folder / "truth.json").read_text())


def test_files_read_back(short_campaign) -> None:
    """The manifest validates as measured data; the readers count what the world wrote: the
    repeated sonic lines as duplicates, the dropped ones as missing, the INS rows from the
    first stable GNSS time on, every mast row (the NAN ones flagged)."""
    folder, manifest, _ = short_campaign
    campaign = load_campaign(manifest)
    assert not campaign.simulated
    proc = default_config()["processing"]
    flight = campaign.payload_flights[0]
    s1, i1 = compute_payload_l1(folder / flight["sonic"]["file"], folder / flight["ins"]["file"], proc["despike"])
    sonic_lines = (folder / flight["sonic"]["file"]).read_text().splitlines()[1:]
    n_unique = len(set(sonic_lines))
    assert s1.attrs["n_duplicates"] == len(sonic_lines) - n_unique
    assert s1.attrs["sampling_rate_hz"] == 32.0 and i1.attrs["sampling_rate_hz"] == 50.0
    # logged span (pre 90 s + 180 s + post 30 s) at 32 Hz, less what precedes the stable GNSS time
    assert 0.8 * 300 * 32 < s1.sizes["time"] <= 300 * 32
    ins_rows = [line.split(",") for line in (folder / flight["ins"]["file"]).read_text().splitlines()[1:]]
    valid = np.array([int(r[2]) for r in ins_rows])
    first_stable = np.flatnonzero(valid)[np.flatnonzero(np.diff(np.flatnonzero(valid)) > 1)[-1] + 1]
    assert i1.sizes["time"] == len(ins_rows) - first_stable
    mast = compute_mast_l1(campaign.mast_files("mast30"), campaign.mast_sonics()["mast30"], proc["despike"])
    mast_lines = campaign.mast_files("mast30")[0].read_text().splitlines()[4:]
    assert mast.sizes["time"] == len(mast_lines)
    assert int(np.isnan(mast["w_up_ms"].values).sum()) >= sum('"NAN"' in line for line in mast_lines)


def _l2_lag_s(folder, manifest) -> float:
    campaign = load_campaign(manifest)
    proc = default_config()["processing"]
    flight = campaign.payload_flights[0]
    s1, i1 = compute_payload_l1(folder / flight["sonic"]["file"], folder / flight["ins"]["file"], proc["despike"])
    lag = {k: proc[k] for k in probes.LAG_SETTINGS}
    lag["hover"] = {**lag["hover"], "min_duration_s": 120.0}
    return float(compute_payload_l2(s1, i1, flight, float(campaign.data["site"]["altitude_m"]), **lag
                                    ).attrs["lag_sonic_ins_s"])


@pytest.mark.slow
def test_sonic_ins_lag_applied_as_declared(short_campaign, tmp_path) -> None:
    """The same flight without the hidden lag: every sonic stamp 0.4 s later (to the
    microsecond, the contract's sign: lag_s is added to the sonic clock to align it), and the
    chain's lag search moves by 0.4 s within one search step (1/32 s)."""
    folder, manifest, truth = short_campaign
    plain = write_campaign(Draw("none", {}, seed=11), tmp_path, WorldSettings(n_flights=1, hover_s=180.0, nx=4096))
    lagged_us = np.loadtxt(folder / "flights/w01/sonic.csv", delimiter=",", skiprows=1, usecols=0, dtype=np.int64)
    plain_us = np.loadtxt(tmp_path / "flights/w01/sonic.csv", delimiter=",", skiprows=1, usecols=0, dtype=np.int64)
    drift = 1 + truth["flights"]["w01"]["logger_drift_ppm"] * 1e-6     # the logger clock's own rate
    np.testing.assert_allclose(plain_us - lagged_us, 0.4e6 * drift, atol=1.0)
    assert _l2_lag_s(folder, manifest) - _l2_lag_s(tmp_path, plain) == pytest.approx(0.4, abs=0.03125 + 1e-9)


def judged_draw(truth: Draw, folder) -> dict:
    """Three 11-minute hovers hiding ``truth``, written to ``folder``, diagnosed in-process and judged."""
    settings = WorldSettings(n_flights=3, hover_s=660.0)   # the chain needs 600 s of detected hover
    manifest = write_campaign(truth, folder, settings)
    config = default_config()
    # Fewer baseline seeds and bootstrap replicates than a campaign's defaults (sized for 400
    # pooled dof and 600 draws), for the suite's time: 30 seeds per flight (the least the error
    # model takes) and 300 replicates (smallest family-wise p 1/301, below alpha 0.01).
    config["diagnosis"] = {**config["diagnosis"], "seeds": [101 * (k + 1) for k in range(30)], "bootstrap": 300}
    out = judge(truth, diagnose_evidence(measured_campaign_evidence(manifest, config), config))
    print(truth.label, json.dumps(out, default=str))   # shown with pytest -s: the measured outcome
    return out


@pytest.fixture(scope="module")
def null_outcome(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """Nothing hidden (only the per-flight base lags), three flights, judged."""
    return judged_draw(Draw("none", {}, seed=5), tmp_path_factory.mktemp("null"))


@pytest.mark.slow
def test_null_campaign_names_nothing(null_outcome) -> None:
    """Nothing hidden: the diagnosis names no cause."""
    assert null_outcome["named"] == [], null_outcome
