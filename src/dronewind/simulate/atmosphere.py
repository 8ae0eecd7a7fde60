"""Synthesis of surface-layer turbulence at arbitrary points: u, v, w and sonic temperature.

The field is a stationary Gaussian process built in the frequency domain
(Shinozuka/Veers spectral method, as in pyconturb) from

* a Monin-Obukhov mean profile, similarity standard deviations and a dissipation rate
  (:mod:`dronewind.core.surface_layer`);
* Kaimal-type point spectra, u-w and w-theta coherencies and an exponential spatial
  coherence (:mod:`dronewind.simulate.spectral_model`);
* optionally, a measured mast record reproduced at its point, with its measured spectral
  amplitudes (:mod:`dronewind.simulate.constraint`).

Why hand-written and not ``pyconturb.gen_turb`` (pyconturb 2.7.4): (1) its spectral matrix
has no cross-component terms, so a 3-point 20-min 32 Hz box gave corr(u, w) = -0.03 at one
point while surface-layer turbulence needs about -0.35 (u'w' = -u*^2), and there is no
temperature/w'theta'; (2) it loops in Python over the frequencies with one Cholesky each
(22.3 s for that box on a 2-core machine); (3) it seeds numpy's global RNG. The algorithm
here is the same (per-frequency Cholesky of the coherence matrix, constraints by solving
for the constraint's unit phasors, Rinker 2018), vectorised over frequencies and extended
with the component cross-spectra.

Frames: points and outputs are ENU (x east, y north, z up above ground). Internally the
fluctuations live in the wind frame (u along the mean wind, v to its left, w up). The
mean wind blows *from* ``wind_from_deg`` (clockwise from north), so its ENU direction
unit vector is (-sin(from), -cos(from)).

Departures from this model, for truths the diagnosis' forward model does not know, are in
:mod:`dronewind.simulate.departures`.

References
----------
Rinker, J. M. (2018), PyConTurb, J. Phys.: Conf. Ser. 1037, 062032.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core.reuse import reused
from dronewind.core.surface_layer import (
    friction_velocity,
    mean_speed_profile,
    theta_profile,
)
from dronewind.errors import InputError
from dronewind.simulate.constraint import (
    ConstraintLatents,
    _constraint_latents,
    _measured_spectra,
    constraint_from_record,
)
from dronewind.simulate.spectral_model import (
    FieldDiagnostics,
    _coherence_factor,
    _CoherenceKey,
    _point_spectra,
    _PointSpectra,
    _separations,
    wind_frame_unit_vectors,
)

__all__ = [
    "simulate_wind",
    "FieldSpec",
    "field_coefficients",
    "synthesize",
]


@dataclass(frozen=True)
class FieldSpec:
    """Fourier coefficients of a simulated field and what is needed to synthesise it.

    Attributes
    ----------
    coeffs : numpy.ndarray
        Complex, shape (n_points, 4, n_freq): wind-frame u, v, w, theta fluctuation
        coefficients c_k (k = 0 .. n_freq-1, frequency k / period_s), scaled so that
        x(t) = sum_k 2 Re(c_k exp(2 pi i f_k t)).
    period_s : float
        Period of the generated (periodic) field [s].
    mean_enu : numpy.ndarray
        (n_points, 3) mean wind east, north, up [m s-1].
    theta_mean_k : numpy.ndarray
        (n_points,) mean sonic temperature [K].
    e_u, e_v : numpy.ndarray
        ENU unit vectors of the wind frame (horizontal).
    friction_velocity_ms : float
    diagnostics : FieldDiagnostics
        Target sigma's, fluxes, spectral parameters per point and the advection speed.
    """

    coeffs: np.ndarray
    period_s: float
    mean_enu: np.ndarray
    theta_mean_k: np.ndarray
    e_u: np.ndarray
    e_v: np.ndarray
    friction_velocity_ms: float
    diagnostics: FieldDiagnostics


def _check_inputs(points: np.ndarray, duration_s: float, fs_hz: float, mean_speed_ms: float,
                  z_ref_m: float, obukhov_length_m: float, roughness_length_m: float) -> np.ndarray:
    pts = np.asarray(points, dtype=float)
    if pts.ndim == 1 and pts.size == 3:
        pts = pts[None, :]
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] < 1:
        raise InputError("simulate_wind.points_enu_m", f"expected shape (n, 3), got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise InputError("simulate_wind.points_enu_m", "non-finite coordinates")
    if roughness_length_m <= 0 or roughness_length_m > 5:
        raise InputError("simulate_wind.roughness_length_m",
                         f"{roughness_length_m} m outside (0, 5] m")
    if np.any(pts[:, 2] <= roughness_length_m):
        raise InputError("simulate_wind.points_enu_m",
                         f"heights must exceed the roughness length {roughness_length_m} m; "
                         f"got min z = {pts[:, 2].min()} m")
    checks = [("duration_s", duration_s, duration_s > 0, "> 0 s"),
              ("fs_hz", fs_hz, 0 < fs_hz <= 1000, "in (0, 1000] Hz"),
              ("mean_speed_ms", mean_speed_ms, 0 < mean_speed_ms <= 60, "in (0, 60] m/s"),
              ("z_ref_m", z_ref_m, roughness_length_m < z_ref_m <= 2000, "above z0 and <= 2000 m"),
              ("obukhov_length_m", obukhov_length_m,
               obukhov_length_m != 0 and not np.isnan(obukhov_length_m), "non-zero (inf = neutral)")]
    for name, value, ok, expected in checks:
        if not ok:
            raise InputError(f"simulate_wind.{name}", f"{value!r}: expected {expected}")
    return pts


def _standard_latents(rng: np.random.Generator, n_f: int, n_p: int) -> np.ndarray:
    """Complex standard normal eta of the four latent components, (4, n_f, n_p), read-only; ``rng`` advanced.

    Drawn per component in the order of :func:`_latent_fields` (real part, then imaginary
    part). The draws depend on the generator's state and the shape only: the truths of one
    seed at other hover heights (the same number of points) draw the same, so inside a
    forward flight's runs they are found by that state (:mod:`dronewind.core.reuse`), and
    the generator is then set to the state drawing them would have left it in.
    """
    def draw() -> tuple[np.ndarray, Mapping[str, Any]]:
        eta = np.empty((4, n_f, n_p), dtype=complex)
        for j in range(4):
            eta[j] = (rng.standard_normal((n_f, n_p)) + 1j * rng.standard_normal((n_f, n_p))) / np.sqrt(2)
        return eta, rng.bit_generator.state

    eta, after = reused("latent draws", {}, repr((rng.bit_generator.state, n_f, n_p)), draw)
    rng.bit_generator.state = after
    return eta


def _latent_fields(rng: np.random.Generator, fpos_hz: np.ndarray, d_eff_m: np.ndarray,
                   advection_speed_ms: float, z_pair_m: np.ndarray,
                   constraint_latents: list[np.ndarray] | None) -> np.ndarray:
    """Spatially coherent complex latents xi of (w, u, theta, v), shape (4, n_p, nf).

    Per latent component (in that order, the generator's draw order), complex standard
    normal eta (n_f, n_p) are correlated across points by the Cholesky factor of the
    coherence matrix (IEC 61400-1 Ed. 3, Annex B); a constraint point (first) takes the
    record's latents instead of its draws (Rinker 2018, Eq. 6).
    """
    n_f, n_p = fpos_hz.size, d_eff_m.shape[0]
    latents = ("w", "u", "theta", "v")
    xi = np.empty((4, n_p, n_f), dtype=complex)
    n_con = 0 if constraint_latents is None else constraint_latents[0].size  # positive freqs constrained
    draws = _standard_latents(rng, n_f, n_p)
    for j, comp in enumerate(latents):
        eta = draws[j] if constraint_latents is None else draws[j].copy()
        if n_p == 1:
            chol = np.ones((n_f, 1, 1))
        else:
            chol = _coherence_factor(_CoherenceKey(fpos_hz, d_eff_m, float(advection_speed_ms), z_pair_m, comp))
        if constraint_latents is not None and n_con > 0:
            obs = constraint_latents[j]  # (n_c,) latent of the constraint point or NaN
            if np.all(np.isfinite(obs[:n_con])):
                eta[:n_con, 0] = obs[:n_con] / chol[:n_con, 0, 0]
        xi[j] = np.einsum("fpq,fq->pf", chol, eta)
    return xi


def _component_coefficients(spectra: _PointSpectra, xi: np.ndarray, fpos_hz: np.ndarray,
                            delay_s: np.ndarray) -> np.ndarray:
    """Fourier coefficients (n_p, 4, n_freq) of u, v, w, theta from the latents, Taylor-delayed.

    w = A_w xi_w, u = A_u (rho_uw xi_w + sqrt(1 - rho_uw^2) xi_u), theta likewise with
    rho_wt, v = A_v xi_v; times exp(-2 pi i f delay) (a point s metres downwind sees the
    field s/U later). The zero-frequency coefficient stays 0.
    """
    amp, rho_uw, rho_wt = spectra.amplitude, spectra.rho_uw, spectra.rho_wt
    n_p, n_freq = amp.shape[0], fpos_hz.size + 1
    a_w, a_u, a_t, a_v = amp[:, 2], amp[:, 0], amp[:, 3], amp[:, 1]
    coeffs = np.zeros((n_p, 4, n_freq), dtype=complex)
    coeffs[:, 2, 1:] = a_w * xi[0]
    coeffs[:, 0, 1:] = a_u * (rho_uw * xi[0] + np.sqrt(1 - rho_uw**2) * xi[1])
    coeffs[:, 3, 1:] = a_t * (rho_wt * xi[0] + np.sqrt(1 - rho_wt**2) * xi[2])
    coeffs[:, 1, 1:] = a_v * xi[3]
    coeffs[:, :, 1:] *= np.exp(-2j * np.pi * fpos_hz[None, :] * delay_s[:, None])[:, None, :]
    return coeffs


def field_coefficients(points_enu_m: np.ndarray, period_s: float, fs_max_hz: float,
                       mean_speed_ms: float, wind_from_deg: float, z_ref_m: float,
                       obukhov_length_m: float, roughness_length_m: float = 0.05,
                       rng: np.random.Generator | None = None, theta_mean_k: float = 293.15,
                       boundary_layer_height_m: float = 1000.0,
                       constraint: ConstraintLatents | None = None,
                       amplitudes: str = "model",
                       spectral_sampling: np.random.Generator | None = None) -> FieldSpec:
    """Fourier coefficients of u, v, w, theta at the points (the core generator).

    Parameters
    ----------
    points_enu_m : numpy.ndarray
        (n, 3) ENU positions [m], z above ground. Earlier points do not depend on later
        ones (lower-triangular construction), so adding a point at the end leaves the
        others' series unchanged for the same generator state.
    period_s : float
        Period of the generated field [s]; frequencies are k / period_s.
    fs_max_hz : float
        Highest sampling rate the field will be synthesised at [Hz]; coefficients up
        to fs_max_hz / 2 (exclusive) are generated.
    mean_speed_ms, wind_from_deg, z_ref_m, obukhov_length_m, roughness_length_m,
    theta_mean_k, boundary_layer_height_m
        As in :func:`simulate_wind`.
    rng : numpy.random.Generator
        Random generator (consumed in a fixed order).
    constraint : ConstraintLatents, optional
        Internal form prepared by :func:`simulate_wind`: ``point`` (3,), ``latents``
        (the record's wind-frame latents, NaN for a missing theta), ``n_freq`` number
        of constrained frequencies.
    amplitudes : {"model", "constraint"}
        Spectral amplitudes of the points: the similarity model's (default), or the
        constraint record's smoothed spectra carried to each point's height by the model's
        height ratio (:func:`_measured_spectra`; needs a constraint). The u-w and w-theta
        coherencies are then rescaled so that the fluxes stay -u*^2 and w'theta'.
    spectral_sampling : numpy.random.Generator, optional
        With ``amplitudes="constraint"``: draw the record's smoothed spectra again from their
        sampling distribution (:func:`spectral_sampling_factors`), so that the field's
        unconstrained remainder carries the record's spectral sampling error; the record is
        still reproduced at its point. Not drawn by default (and ignored for model amplitudes).

    Returns
    -------
    FieldSpec

    Notes
    -----
    Per frequency f_k, point p and latent component b in (w, u, theta, v), complex
    standard normal eta are correlated across points by the Cholesky factor of the
    coherence matrix gamma_b(f_k, Delta_pq); the point's components are then

    .. math::
        w = A_w\\xi_w,\\ u = A_u(\\rho_{uw}\\xi_w + \\sqrt{1-\\rho_{uw}^2}\\xi_u),\\
        \\theta = A_\\theta(\\rho_{w\\theta}\\xi_w + \\sqrt{1-\\rho_{w\\theta}^2}\\xi_\\theta),\\
        v = A_v\\xi_v,\\quad A_i = \\sqrt{S_i(f_k)\\Delta f/2}

    times the Taylor delay :math:`e^{-2\\pi i f_k s_p/U}` (s_p downwind coordinate).
    The spectra are NOT rescaled to sigma^2 over the discrete band (pyconturb does):
    a finite record sampled at fs misses the variance below 1/period and above fs/2,
    as a real sensor does; rescaling inflated S_w/S_u in the inertial subrange by 6 %
    (measured: 1.47 instead of 1.31 at n = 2.5-9, fs = 16 Hz, z = 10 m). The u-w and
    w-theta coherencies are scaled so that the covariances over the resolved band are
    -u*^2 and w'theta' in expectation. A constraint point is put first; its latents are solved from the
    observed coefficients (Rinker 2018, Eq. 6) instead of being drawn.

    References
    ----------
    Shinozuka and Jan (1972); Veers (1988); Rinker (2018); see module docstring.
    """
    rng = np.random.default_rng(0) if rng is None else rng
    pts = _with_constraint_point(np.asarray(points_enu_m, dtype=float).reshape(-1, 3), constraint)
    n_freq = int(np.ceil(period_s * fs_max_hz / 2.0))  # k < fs/2 * T
    df = 1.0 / period_s
    fpos = (np.arange(n_freq) * df)[1:]
    ustar = friction_velocity(mean_speed_ms, z_ref_m, roughness_length_m, obukhov_length_m)
    z = pts[:, 2]
    speed = mean_speed_profile(z, ustar, roughness_length_m, obukhov_length_m)
    adv = max(float(mean_speed_profile(z_ref_m, ustar, roughness_length_m, obukhov_length_m)), 0.5)
    e_u, e_v = wind_frame_unit_vectors(wind_from_deg)
    # the same points and conditions for every seed of a forward flight: made once inside its
    # runs (dronewind.core.reuse; arrays read-only, the diagnostics copied)
    spectra = reused("point spectra", {"z": z, "speed": speed, "fpos": fpos},
                     repr((df, ustar, obukhov_length_m, boundary_layer_height_m, theta_mean_k)),
                     lambda: _point_spectra(z, speed, fpos, df, ustar, obukhov_length_m, boundary_layer_height_m,
                                            theta_mean_k))
    spectra = dataclasses.replace(spectra, diagnostics=copy.deepcopy(spectra.diagnostics))
    if amplitudes not in ("model", "constraint"):
        raise InputError("field_coefficients.amplitudes", f"{amplitudes!r}; expected 'model' or 'constraint'")
    latents = None
    offset = np.zeros(4)
    if constraint is not None:
        n_c = min(int(constraint["n_freq"]) - 1, fpos.size)
        coefficients = np.asarray(constraint["coefficients"])[:, :n_c]
        if amplitudes == "constraint":
            spectra = _measured_spectra(spectra, coefficients, fpos, df, constraint.get("noise_power"),
                                        sampling=spectral_sampling)
        latents = _constraint_latents(coefficients, pts[0], fpos, adv, e_u, spectra.amplitude[0], spectra.rho_uw[0],
                                      spectra.rho_wt[0])
        offset = np.asarray(constraint.get("offset", offset), float)
    elif amplitudes == "constraint":
        raise InputError("field_coefficients.amplitudes", "'constraint' needs a constraint record")
    s_down, d_eff, z_pair = _separations(pts, e_u, e_v)
    xi = _latent_fields(rng, fpos, d_eff, adv, z_pair, latents)
    coeffs = _component_coefficients(spectra, xi, fpos, s_down / adv)
    user = slice(1, None) if constraint is not None else slice(None)  # the constraint point is not output
    targets = spectra.diagnostics
    diag = FieldDiagnostics(sigmas=targets["sigmas"][user], spectral_parameters=targets["spectral_parameters"][user],
                            zeta=targets["zeta"][user], advection_speed_ms=adv)
    mean_enu = _mean_wind_enu(speed[user], e_u) + offset[None, :3]
    theta_mean = np.asarray(theta_profile(z[user], z_ref_m, theta_mean_k, ustar, obukhov_length_m), float) + offset[3]
    return FieldSpec(coeffs=coeffs[user], period_s=float(period_s), mean_enu=mean_enu, theta_mean_k=theta_mean,
                     e_u=e_u, e_v=e_v, friction_velocity_ms=ustar, diagnostics=diag)


def _with_constraint_point(points_enu_m: np.ndarray, constraint: ConstraintLatents | None) -> np.ndarray:
    """The points with the constraint's point put first (unchanged without a constraint)."""
    if constraint is None:
        return points_enu_m
    return np.vstack([np.asarray(constraint["point"], float)[None, :], points_enu_m])


def _mean_wind_enu(speed_ms: np.ndarray, e_u: np.ndarray) -> np.ndarray:
    """(n, 3) mean wind east, north, up [m s-1] of mean speeds along e_u (no mean vertical wind)."""
    mean_enu = np.zeros((speed_ms.size, 3))
    mean_enu[:, 0] = speed_ms * e_u[0]
    mean_enu[:, 1] = speed_ms * e_u[1]
    return mean_enu


def synthesize(spec: FieldSpec, fs_hz: float, point_index: Sequence[int] | np.ndarray | None = None,
               start_s: float = 0.0, n_samples: int | None = None) -> np.ndarray:
    """Time series of the field at one sampling rate (band-limited to fs/2).

    Parameters
    ----------
    spec : FieldSpec
        From :func:`field_coefficients`.
    fs_hz : float
        Output rate [Hz]; ``spec.period_s * fs_hz`` must be an integer. Coefficients
        at or above fs/2 are dropped (ideal anti-alias filter).
    point_index : array_like of int, optional
        Points to synthesise (default all).
    start_s : float
        Time of the first sample within the period [s] (must be a multiple of 1/fs).
    n_samples : int, optional
        Number of samples (default: one period).

    Returns
    -------
    numpy.ndarray
        (n_sel, 4, n_samples) ENU-plus-temperature series: east, north, up wind
        [m s-1] and sonic temperature [K], means included.
    """
    n_total = int(round(spec.period_s * fs_hz))
    if abs(n_total - spec.period_s * fs_hz) > 1e-6:
        raise InputError("synthesize.fs_hz", f"period {spec.period_s} s x {fs_hz} Hz is not an integer")
    idx = np.arange(spec.coeffs.shape[0]) if point_index is None else np.asarray(point_index)
    n_keep = min(spec.coeffs.shape[2], (n_total + 1) // 2)  # strictly below Nyquist
    c = np.zeros((len(idx), 4, n_total // 2 + 1), dtype=complex)
    c[:, :, :n_keep] = spec.coeffs[idx][:, :, :n_keep]
    wind = np.fft.irfft(c * n_total, n=n_total, axis=-1)  # x = sum 2 Re(c e^{iwt})
    i0 = int(round(start_s * fs_hz))
    n = n_total - i0 if n_samples is None else int(n_samples)
    if i0 < 0 or i0 + n > n_total:
        raise InputError("synthesize", f"samples {i0}..{i0 + n} outside the period of {n_total}")
    wind = wind[:, :, i0:i0 + n]
    out = np.empty_like(wind)
    u, v = wind[:, 0], wind[:, 1]
    out[:, 0] = spec.mean_enu[idx, 0, None] + u * spec.e_u[0] + v * spec.e_v[0]
    out[:, 1] = spec.mean_enu[idx, 1, None] + u * spec.e_u[1] + v * spec.e_v[1]
    out[:, 2] = spec.mean_enu[idx, 2, None] + wind[:, 2]
    out[:, 3] = spec.theta_mean_k[idx, None] + wind[:, 3]
    return out


def _padded_period_s(points_enu_m: np.ndarray, n_samples: int, fs_hz: float, mean_speed_ms: float,
                     wind_from_deg: float, z_ref_m: float, obukhov_length_m: float,
                     roughness_length_m: float) -> float:
    """Period of an unconstrained field [s]: the record plus the largest Taylor delay between points."""
    ustar = friction_velocity(mean_speed_ms, z_ref_m, roughness_length_m, obukhov_length_m)
    adv = max(float(mean_speed_profile(z_ref_m, ustar, roughness_length_m, obukhov_length_m)), 0.5)
    e_u, _ = wind_frame_unit_vectors(wind_from_deg)
    s = points_enu_m[:, :2] @ e_u
    pad = (s.max() - s.min()) / adv
    n_total = n_samples + int(np.ceil(pad * fs_hz))
    return n_total / fs_hz


def _wind_dataset(data: np.ndarray, points_enu_m: np.ndarray, spec: FieldSpec, fs_hz: float,
                  obukhov_length_m: float, roughness_length_m: float, wind_from_deg: float, seed: int,
                  constraint: ConstraintLatents | None) -> xr.Dataset:
    """The (point, time) Dataset of :func:`simulate_wind` from synthesised series (n, 4, n_samples)."""
    n_samples = data.shape[-1]
    t = np.arange(n_samples) / fs_hz
    dims = ("point", "time")
    sig = spec.diagnostics["sigmas"]
    pts = points_enu_m
    return xr.Dataset(
        {
            "u_east_ms": (dims, data[:, 0], {"units": "m s-1", "standard_name": "eastward_wind"}),
            "v_north_ms": (dims, data[:, 1], {"units": "m s-1", "standard_name": "northward_wind"}),
            "w_up_ms": (dims, data[:, 2], {"units": "m s-1", "standard_name": "upward_air_velocity"}),
            "theta_v_k": (dims, data[:, 3], {"units": "K", "standard_name": "virtual_temperature",
                                             "comment": "sonic temperature"}),
        },
        coords={
            "time_s": ("time", t, {"units": "s", "long_name": "time since start of simulation"}),
            "x_m": ("point", pts[:, 0], {"units": "m", "long_name": "east position"}),
            "y_m": ("point", pts[:, 1], {"units": "m", "long_name": "north position"}),
            "z_m": ("point", pts[:, 2], {"units": "m", "long_name": "height above ground"}),
        },
        attrs={
            "friction_velocity_ms": spec.friction_velocity_ms,
            "obukhov_length_m": float(obukhov_length_m),
            "roughness_length_m": float(roughness_length_m),
            "wind_from_deg": float(wind_from_deg),
            "seed": int(seed),
            "sampling_rate_hz": float(fs_hz),
            "sigma_u_ms": [s["sigma_u_ms"] for s in sig],
            "sigma_v_ms": [s["sigma_v_ms"] for s in sig],
            "sigma_w_ms": [s["sigma_w_ms"] for s in sig],
            "sigma_theta_k": [s["sigma_theta_k"] for s in sig],
            "wtheta_kms": [s["wtheta_kms"] for s in sig],
            "constrained": int(constraint is not None),
            "n_constraint_missing": 0 if constraint is None else int(constraint["n_missing"]),
        },
    )


def simulate_wind(points_enu_m: np.ndarray, duration_s: float, fs_hz: float, mean_speed_ms: float,
                  wind_from_deg: float, z_ref_m: float, obukhov_length_m: float,
                  roughness_length_m: float = 0.05, seed: int = 0, theta_mean_k: float = 293.15,
                  constraint: xr.Dataset | None = None,
                  boundary_layer_height_m: float = 1000.0, amplitudes: str = "model") -> xr.Dataset:
    """Turbulent wind and sonic temperature at points (binding interface, interfaces.md).

    Parameters
    ----------
    points_enu_m : numpy.ndarray
        (n, 3) positions [m]: x east, y north, z up above ground.
    duration_s : float
        Length of the series [s].
    fs_hz : float
        Sampling rate [Hz].
    mean_speed_ms : float
        Mean horizontal speed at ``z_ref_m`` [m s-1]; the profile follows
        Monin-Obukhov similarity.
    wind_from_deg : float
        Mean direction the wind blows from, clockwise from true north [degree].
    z_ref_m : float
        Reference height of ``mean_speed_ms`` and ``theta_mean_k`` [m].
    obukhov_length_m : float
        Obukhov length L [m] (negative unstable, ``inf`` neutral).
    roughness_length_m : float
        z0 [m].
    seed : int
        Seed of the random generator (PCG64); same inputs and seed, same output.
    theta_mean_k : float
        Mean sonic temperature at ``z_ref_m`` [K].
    constraint : xarray.Dataset, optional
        A measured record to constrain the field (pyconturb-style, Rinker 2018): L1
        mast names ``u_east_ms, v_north_ms, w_up_ms`` (and optionally ``t_sonic_k``)
        on a regular ``time`` (datetime64) or ``time_s`` axis, attribute ``height_m``
        and optional ``x_m, y_m`` (ENU position). Its first ``duration_s`` are used
        (fluctuations about its own means, rotated into the wind frame of
        ``wind_from_deg``); the field then reproduces the record at its position for
        frequencies below its Nyquist frequency and is coherent with it elsewhere.
        The means stay those of the model. Gaps up to 2 % are interpolated.
        With a constraint the field is not padded, so its circular period equals
        ``duration_s``.
    boundary_layer_height_m : float
        Convective boundary-layer depth z_i [m] (unstable sigma_u, sigma_v).
    amplitudes : {"model", "constraint"}
        Spectral amplitudes at the points: the similarity model's, or the constraint's
        smoothed spectra scaled to each point's height (see :func:`field_coefficients`).

    Returns
    -------
    xarray.Dataset
        Dims (point, time): ``u_east_ms``, ``v_north_ms``, ``w_up_ms``, ``theta_v_k``;
        coords ``time_s`` (seconds from 0), ``x_m, y_m, z_m`` (point). Attrs:
        ``friction_velocity_ms``, ``obukhov_length_m``, ``seed``, targets per point
        as ``sigma_u_ms`` etc. (lists).

    Raises
    ------
    InputError
        Bad shapes or values (named), constraint too short or too gappy.

    Notes
    -----
    See :func:`field_coefficients` (and the module docstring for the references).
    Without a constraint the generated period is padded by the largest Taylor delay
    between points so that the delayed series do not wrap around.
    """
    pts = _check_inputs(points_enu_m, duration_s, fs_hz, mean_speed_ms, z_ref_m,
                        obukhov_length_m, roughness_length_m)
    n_samples = int(round(duration_s * fs_hz))
    rng = np.random.default_rng(np.random.SeedSequence(int(seed)))
    period = n_samples / fs_hz if constraint is not None else _padded_period_s(
        pts, n_samples, fs_hz, mean_speed_ms, wind_from_deg, z_ref_m, obukhov_length_m, roughness_length_m)
    con = None if constraint is None else constraint_from_record(constraint, period, fs_hz, wind_from_deg)
    spec = field_coefficients(pts, period, fs_hz, mean_speed_ms, wind_from_deg, z_ref_m,
                              obukhov_length_m, roughness_length_m, rng, theta_mean_k,
                              boundary_layer_height_m, con, amplitudes)
    data = synthesize(spec, fs_hz, n_samples=n_samples)
    return _wind_dataset(data, pts, spec, fs_hz, obukhov_length_m, roughness_length_m, wind_from_deg, seed, con)


