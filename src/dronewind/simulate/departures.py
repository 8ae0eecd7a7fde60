"""Departures of the simulated field from the similarity model, for truths the diagnosis' forward model does not know.

Selected by the ``simulation.atmosphere`` settings (:mod:`dronewind.simulate.settings`):
:func:`reshape_field` gives u, v, w von Karman spectral shapes instead of Kaimal's
(:func:`von_karman_spectra`, :func:`von_karman_length_scales`), stretches their length
scales and multiplies their sigmas; :func:`mean_wind_trend` makes the mean wind change
linearly in time.

References
----------
Burton, T., Jenkins, N., Sharpe, D. and Bossanyi, E. (2011), Wind Energy Handbook, 2nd ed.,
Wiley, Sect. 2.6.3 (von Karman spectra); IEC 61400-1 Ed. 2 (1999), Annex B.
Hogstrom, U., Hunt, J. C. R. and Smedman, A.-S. (2002), Bound.-Layer Meteor. 103, 101-124.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from dronewind.core.angles import deg2rad
from dronewind.core.surface_layer import (
    dissipation_phi,
)
from dronewind.errors import InputError
from dronewind.simulate.atmosphere import FieldSpec
from dronewind.simulate.spectral_model import (
    FieldDiagnostics,
    component_spectra,
)

__all__ = [
    "von_karman_length_scales",
    "von_karman_spectra",
    "reshape_field",
    "mean_wind_trend",
]


# --------------------------------------------------------------------------------------
# Departures from the similarity model (model-error truths)
# --------------------------------------------------------------------------------------
#: von Karman constants: f S_u / sigma^2 = 4x / (1 + 70.8 x^2)^(5/6) and
#: f S_{v,w} / sigma^2 = 4x (1 + 755.2 x^2) / (1 + 283.2 x^2)^(11/6), x = f L / U.
_VK_A_U = 70.8


_VK_A_LAT = 283.2


_VK_B_LAT = 755.2


def von_karman_length_scales(sigmas: dict[str, float], friction_velocity_ms: float, zeta: float,
                             z_m: float) -> dict[str, float]:
    """Length scales of von Karman spectra with the similarity sigmas and dissipation rate.

    Parameters
    ----------
    sigmas : dict
        Output of :func:`turbulence_sigmas` (``sigma_u_ms``, ``sigma_v_ms``, ``sigma_w_ms``).
    friction_velocity_ms : float
        u* [m s-1].
    zeta : float
        z/L [1].
    z_m : float
        Height [m].

    Returns
    -------
    dict
        ``L_u, L_v, L_w`` [m].

    Notes
    -----
    Each L is solved so that the von Karman spectrum (:func:`von_karman_spectra`) of
    variance sigma^2 has the inertial-subrange level of :func:`spectral_parameters`
    (:math:`K_u = 0.3\\phi_\\epsilon^{2/3}u_*^2`, :math:`K_{v,w} = \\tfrac43 K_u`): with
    the asymptotes :math:`S_u \\to 4\\sigma_u^2 a_u^{-5/6}(L/U)^{-2/3}f^{-5/3}` and
    :math:`S_{v,w} \\to 4\\sigma^2 b\\,a^{-11/6}(L/U)^{-2/3}f^{-5/3}`,

    .. math:: L_u = z\\left[\\frac{4\\sigma_u^2 a_u^{-5/6}}{K_u}\\right]^{3/2},\\qquad
              L_{v,w} = z\\left[\\frac{4\\sigma^2 b\\,a^{-11/6}}{K_{v,w}}\\right]^{3/2}

    (a_u = 70.8; a = 283.2, b = 755.2). Neutral: L_u = 3.2 z, L_v = 1.2 z, L_w = 0.23 z.
    Same variance and dissipation as the Kaimal model, another shape: the spectral peak
    of f S moves (up by about 1.4 for u in neutral air) and the low-frequency plateau
    is flat.

    References
    ----------
    Burton et al. (2011), Eqs 2.24-2.25; Kaimal and Finnigan (1994), Eq. 1.34.
    """
    us2 = friction_velocity_ms**2
    phi23 = dissipation_phi(zeta) ** (2 / 3)
    k_u, k_vw = 0.3 * phi23 * us2, 0.4 * phi23 * us2
    c_u = 4 * _VK_A_U ** (-5 / 6)
    c_lat = 4 * _VK_B_LAT * _VK_A_LAT ** (-11 / 6)
    return {"L_u": float(z_m * (c_u * sigmas["sigma_u_ms"] ** 2 / k_u) ** 1.5),
            "L_v": float(z_m * (c_lat * sigmas["sigma_v_ms"] ** 2 / k_vw) ** 1.5),
            "L_w": float(z_m * (c_lat * sigmas["sigma_w_ms"] ** 2 / k_vw) ** 1.5)}


def von_karman_spectra(freq_hz: np.ndarray, speed_ms: float, sigmas: dict[str, float],
                       length_scales_m: dict[str, float]) -> dict[str, np.ndarray]:
    """One-sided von Karman spectra of u, v, w.

    Parameters
    ----------
    freq_hz : numpy.ndarray
        Frequencies [Hz] (> 0).
    speed_ms : float
        Mean speed (Taylor advection) [m s-1].
    sigmas : dict
        ``sigma_u_ms, sigma_v_ms, sigma_w_ms`` [m s-1].
    length_scales_m : dict
        ``L_u, L_v, L_w`` [m] (e.g. :func:`von_karman_length_scales`).

    Returns
    -------
    dict
        ``S_u, S_v, S_w`` [m2 s-2 Hz-1], each integrating to its sigma^2 over (0, inf).

    Notes
    -----
    .. math::
        S_u(f) = \\sigma_u^2\\frac{4L_u/U}{(1 + 70.8x_u^2)^{5/6}},\\qquad
        S_{v,w}(f) = \\sigma^2\\frac{4L/U\\,(1 + 755.2x^2)}{(1 + 283.2x^2)^{11/6}},\\quad x = fL/U

    References
    ----------
    Burton et al. (2011), Eqs 2.24-2.25; IEC 61400-1 Ed. 2 (1999), Annex B.
    """
    f = np.asarray(freq_hz, dtype=float)
    out = {}
    lu = length_scales_m["L_u"] / speed_ms
    out["S_u"] = sigmas["sigma_u_ms"] ** 2 * 4 * lu / (1 + _VK_A_U * (f * lu) ** 2) ** (5 / 6)
    for comp in ("v", "w"):
        lc = length_scales_m[f"L_{comp}"] / speed_ms
        x2 = (f * lc) ** 2
        out[f"S_{comp}"] = sigmas[f"sigma_{comp}_ms"] ** 2 * 4 * lc * (1 + _VK_B_LAT * x2) / \
            (1 + _VK_A_LAT * x2) ** (11 / 6)
    return out


def reshape_field(spec: FieldSpec, z_m: np.ndarray, spectrum: str = "kaimal",
                  sigma_factors: tuple[float, float, float] = (1.0, 1.0, 1.0),
                  length_scale_factor: float = 1.0) -> FieldSpec:
    """Another spectral shape and other sigmas for u, v, w of a generated field.

    Parameters
    ----------
    spec : FieldSpec
        From :func:`field_coefficients` (without a constraint point).
    z_m : numpy.ndarray
        Height of each point of ``spec`` [m].
    spectrum : {"kaimal", "von_karman"}
        Spectral shape of u, v, w: Kaimal's (that of :func:`field_coefficients`) or von
        Karman's with the same sigmas and dissipation rate (:func:`von_karman_spectra`,
        :func:`von_karman_length_scales`).
    sigma_factors : tuple of 3 float
        Factors on sigma_u, sigma_v, sigma_w (the similarity sigmas of
        :func:`turbulence_sigmas`).
    length_scale_factor : float
        Factor lambda on the length scales of the u, v, w spectra (both shapes):
        :math:`S(f) \\to \\lambda S(\\lambda f)`, same variance, spectral peak at f/lambda,
        inertial-subrange level times :math:`\\lambda^{-2/3}` (dissipation rate over
        lambda). Surface-layer u and v spectra peak at frequencies that vary by a factor
        2 with the boundary-layer depth in near-neutral air (Hogstrom et al. 2002), which
        the z-scaling of the similarity model ignores.

    Returns
    -------
    FieldSpec
        ``spec`` itself for the defaults (Kaimal, factors 1: bit-identical fields);
        otherwise a copy whose u, v, w coefficients are multiplied per point and
        frequency by :math:`c_i\\sqrt{S_i^{new}(f)/S_i^{Kaimal}(f)}`, and whose
        diagnostic sigmas are multiplied by the factors.

    Notes
    -----
    The latent phases, the spatial coherence, the Taylor delays and the u-w and w-theta
    coherencies per frequency are kept, so the covariances follow the new amplitudes:
    u'w' becomes :math:`c_u c_w\\sum\\rho_{uw}\\sqrt{S_u^{new}S_w^{new}}\\Delta f` instead
    of :math:`-u_*^2`. The temperature keeps its spectrum. Factors change the
    inertial-subrange level by c^2 (another dissipation rate for that component), so that
    the 4/3 ratio of local isotropy no longer holds unless c_v = c_w.
    """
    factors = np.asarray(sigma_factors, dtype=float)
    if spectrum not in ("kaimal", "von_karman"):
        raise InputError("reshape_field.spectrum", f"expected kaimal or von_karman, got {spectrum!r}")
    lam = float(length_scale_factor)
    if spectrum == "kaimal" and np.all(factors == 1.0) and lam == 1.0:
        return spec
    coeffs = spec.coeffs.copy()
    n_freq = coeffs.shape[2]
    fpos = np.arange(1, n_freq) / spec.period_s
    diag = spec.diagnostics
    z = np.asarray(z_m, dtype=float).reshape(-1)
    sigmas = []
    for p in range(coeffs.shape[0]):
        gain = np.broadcast_to(factors[:, None], (3, n_freq - 1)).copy()
        sig = diag["sigmas"][p]
        if spectrum == "von_karman" or lam != 1.0:
            speed = max(float(np.hypot(spec.mean_enu[p, 0], spec.mean_enu[p, 1])), 0.5)
            kaimal = component_spectra(fpos, z[p], speed, sig, diag["spectral_parameters"][p])
            if spectrum == "von_karman":
                lengths = von_karman_length_scales(sig, spec.friction_velocity_ms, diag["zeta"][p], z[p])
                target = von_karman_spectra(lam * fpos, speed, sig, lengths)
            else:
                target = component_spectra(lam * fpos, z[p], speed, sig, diag["spectral_parameters"][p])
            for i, comp in enumerate(("u", "v", "w")):
                gain[i] *= np.sqrt(lam * target[f"S_{comp}"] / kaimal[f"S_{comp}"])
        coeffs[p, :3, 1:] *= gain
        sigmas.append({**sig, **{f"sigma_{c}_ms": sig[f"sigma_{c}_ms"] * float(k)
                                 for c, k in zip(("u", "v", "w"), factors, strict=True)}})
    new_diag = FieldDiagnostics(**{**diag, "sigmas": sigmas})
    return dataclasses.replace(spec, coeffs=coeffs, diagnostics=new_diag)


def mean_wind_trend(series: np.ndarray, mean_enu: np.ndarray, t_s: np.ndarray, reference_speed_ms: float,
                    speed_trend_ms_per_h: float, direction_trend_deg_per_h: float) -> np.ndarray:
    """A field whose mean wind changes linearly in time: speed trend and veering.

    Parameters
    ----------
    series : numpy.ndarray
        (n_p, 4, n) east, north, up wind [m s-1] and temperature [K] (:func:`synthesize`).
    mean_enu : numpy.ndarray
        (n_p, 3) mean wind of the points [m s-1] (``FieldSpec.mean_enu``).
    t_s : numpy.ndarray
        (n,) time of each sample from the reference time at which the trends are zero [s].
    reference_speed_ms : float
        Mean speed at the reference height [m s-1] (the speed the trend refers to).
    speed_trend_ms_per_h : float
        Change of the mean speed at the reference height [m s-1 per hour]; every point's
        mean speed changes in proportion (the profile keeps its shape).
    direction_trend_deg_per_h : float
        Change of the direction the wind comes from [degree per hour], positive veering
        (clockwise seen from above).

    Returns
    -------
    numpy.ndarray
        ``series`` with, at time t, the mean speed of point p multiplied by
        :math:`1 + a t / U_{ref}` along its mean direction, then the horizontal wind
        (mean and fluctuations) turned clockwise by :math:`b t`. The vertical wind and
        temperature are unchanged. The input itself when both trends are 0.

    Raises
    ------
    InputError
        The trend would reverse the mean wind within the series (speed <= 0).
    """
    if speed_trend_ms_per_h == 0.0 and direction_trend_deg_per_h == 0.0:
        return series
    hours = np.asarray(t_s, dtype=float) / 3600.0
    rel = 1.0 + speed_trend_ms_per_h * hours / reference_speed_ms
    if np.any(rel <= 0):
        raise InputError("simulation.atmosphere.speed_trend_ms_per_h",
                         f"{speed_trend_ms_per_h} m/s per hour reverses the mean wind of "
                         f"{reference_speed_ms:.2f} m/s within {np.abs(hours).max():.2f} h of the hover centre")
    out = series.copy()
    east = series[:, 0] + mean_enu[:, 0, None] * (rel - 1.0)[None, :]
    north = series[:, 1] + mean_enu[:, 1, None] * (rel - 1.0)[None, :]
    delta = deg2rad(direction_trend_deg_per_h * hours)[None, :]
    out[:, 0] = east * np.cos(delta) + north * np.sin(delta)
    out[:, 1] = -east * np.sin(delta) + north * np.cos(delta)
    return out
