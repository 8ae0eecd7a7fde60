"""Surface-layer turbulence at arbitrary points: u, v, w and sonic temperature.

The field is a stationary Gaussian process built in the frequency domain
(Shinozuka/Veers spectral method, as in pyconturb) from

* a Monin-Obukhov mean profile (Paulson 1970 / Dyer 1974 unstable, Beljaars and
  Holtslag 1991 stable) fixed by the mean speed at ``z_ref_m``;
* standard deviations from surface-layer similarity (Panofsky et al. 1977;
  Panofsky and Dutton 1984; Kaimal and Finnigan 1994), and a dissipation rate from
  phi_eps(zeta) (Kaimal and Finnigan 1994, Ch. 1, after Kaimal et al. 1972);
* Kaimal-type spectral shapes (Kaimal et al. 1972) whose length parameter is solved so
  that each spectrum integrates to its sigma^2 AND has the inertial-subrange level
  set by eps: S_u -> 0.3 u*^2 phi_eps^(2/3) (z/U)^(-2/3) f^(-5/3), S_v = S_w -> 4/3 S_u
  (local isotropy); the spectral peak thus moves with stability as observed (up in
  stable, down in unstable air);
* coherencies between u and w and between w and theta with Kaimal-type cospectral
  shape (-7/3 inertial slope), scaled so that u'w' = -u*^2 and
  w'theta' = -u*^3 theta/(kappa g L) (Ghirardelli et al. 2025, Eq. 9 inverted), u'theta' =
  rho_uw rho_wtheta (u and theta conditionally independent given w);
* spatial coherence of each component decaying exponentially with separation and
  frequency (IEC 61400-1 Ed. 3 Annex B exponential model, with pyconturb's "iec3d"
  component length scales); the along-wind part of a separation enters the coherence
  with weight 0.5 (longitudinal coherence decays about half as fast as lateral,
  Pielke and Panofsky 1970) and, through Taylor's frozen turbulence, as a delay
  s/U (downwind points see a structure later).

Why hand-written and not ``pyconturb.gen_turb`` (measured 2026-11-22 on this 2-core
machine, pyconturb 2.7.4): (1) its spectral matrix has no cross-component terms, so a
3-point 20-min 32 Hz box gave corr(u, w) = -0.03 at one point while surface-layer
turbulence needs about -0.35 (u'w' = -u*^2), and there is no temperature/w'theta';
(2) the same box took 22.3 s (a Python loop over 19 200 frequencies with one Cholesky
each) against a 2 s budget per flight; (3) it seeds numpy's global RNG. The algorithm
below is the same (per-frequency Cholesky of the coherence matrix, constraints by
solving for the constraint's unit phasors, Rinker 2018), vectorised over frequencies
and extended with the component cross-spectra; here it takes a few tens of ms.

Measured amplitudes (``amplitudes="constraint"``): the constraint record's periodogram,
divided by the model spectrum at its point and averaged over log-frequency bins, replaces
the model's spectral level at every point (times the model's height ratio
S_model(z_point, f)/S_model(z_record, f), Kaimal et al. 1972), so another spectral shape or
isotropy measured at the record's point carries to the others; the latents of the record
are solved with those amplitudes (Rinker 2018, Eq. 6), so the record is still reproduced
at its point. With ``spectral_sampling`` the smoothed spectra are drawn again from their
sampling distribution given the record (:func:`spectral_sampling_factors`), so that fields
of different seeds differ also by what the record's spectra got wrong by chance.

Frames: points and outputs are ENU (x east, y north, z up above ground). Internally the
fluctuations live in the wind frame (u along the mean wind, v to its left, w up). The
mean wind blows *from* ``wind_from_deg`` (clockwise from north), so its ENU direction
unit vector is (-sin(from), -cos(from)).

References
----------
Beljaars, A. C. M. and Holtslag, A. A. M. (1991), J. Appl. Meteor. 30, 327-341.
Dyer, A. J. (1974), Bound.-Layer Meteor. 7, 363-372.
IEC 61400-1 Ed. 3 (2005), Annex B.
Kaimal, J. C., Wyngaard, J. C., Izumi, Y. and Coté, O. R. (1972), QJRMS 98, 563-589.
Kaimal, J. C. and Finnigan, J. J. (1994), Atmospheric Boundary Layer Flows, OUP, Ch. 1-2.
Panofsky, H. A., Tennekes, H., Lenschow, D. H. and Wyngaard, J. C. (1977), BLM 11, 355-361.
Panofsky, H. A. and Dutton, J. A. (1984), Atmospheric Turbulence, Wiley, Ch. 7.
Paulson, C. A. (1970), J. Appl. Meteor. 9, 857-861.
Pielke, R. A. and Panofsky, H. A. (1970), Bound.-Layer Meteor. 1, 115-130.
Rinker, J. M. (2018), PyConTurb, J. Phys.: Conf. Ser. 1037, 062032.
Burton, T., Jenkins, N., Sharpe, D. and Bossanyi, E. (2011), Wind Energy Handbook, 2nd ed.,
Wiley, Sect. 2.6.3 (von Karman spectra); IEC 61400-1 Ed. 2 (1999), Annex B.
Hogstrom, U., Hunt, J. C. R. and Smedman, A.-S. (2002), Bound.-Layer Meteor. 103, 101-124.
Ghirardelli et al. (2025): SAMURAI-S (sling-load sonic), Eq. 9 (Obukhov length).

Departures from this model, for truths the diagnosis' forward model does not know
(``simulation.atmosphere`` settings, :mod:`dronewind.simulate`): :func:`reshape_field`
gives u, v, w von Karman spectral shapes instead of Kaimal's, stretches their length
scales and multiplies their sigmas;
:func:`mean_wind_trend` makes the mean wind change linearly in time.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypedDict

import numpy as np
import xarray as xr

from dronewind.core.angles import deg2rad
from dronewind.core.constants import GRAVITY_MS2, KARMAN
from dronewind.core.raw import content_digest
from dronewind.core.reuse import reused
from dronewind.errors import InputError

__all__ = [
    "psi_m",
    "psi_h",
    "friction_velocity",
    "mean_speed_profile",
    "theta_profile",
    "turbulence_sigmas",
    "dissipation_phi",
    "spectral_parameters",
    "component_spectra",
    "coherence",
    "wind_frame_unit_vectors",
    "simulate_wind",
    "FieldSpec",
    "field_coefficients",
    "synthesize",
    "von_karman_length_scales",
    "von_karman_spectra",
    "reshape_field",
    "mean_wind_trend",
    "constraint_from_record",
    "ConstraintLatents",
    "spectral_sampling_factors",
]

CP_DRY_JKGK = 1004.0
_COMPONENTS = ("u", "v", "w", "theta")
#: IEC 61400-1 exponential coherence: decay constant a, b and component length factors
#: (pyconturb "iec3d": L_c scaled by 1, 2.7/8.1, 0.66/8.1 for u, v, w; theta as w).
_COH_A = 12.0
_COH_B = 0.12
_COH_LC_FACTOR = {"u": 1.0, "v": 2.7 / 8.1, "w": 0.66 / 8.1, "theta": 0.66 / 8.1}
_ALONG_WIND_COH_WEIGHT = 0.5
_MAX_COHERENCY = 0.95


# --------------------------------------------------------------------------------------
# Monin-Obukhov similarity
# --------------------------------------------------------------------------------------
def psi_m(zeta: np.ndarray | float) -> np.ndarray:
    """Integrated stability function for momentum.

    Parameters
    ----------
    zeta : array_like
        Stability parameter z/L [1].

    Returns
    -------
    numpy.ndarray
        psi_m [1].

    Notes
    -----
    Unstable (Paulson 1970 with the Businger-Dyer phi_m, x = (1 - 16 zeta)^(1/4)):

    .. math:: \\psi_m = 2\\ln\\frac{1+x}{2} + \\ln\\frac{1+x^2}{2} - 2\\arctan x + \\frac{\\pi}{2}

    Stable (Beljaars and Holtslag 1991, a=1, b=2/3, c=5, d=0.35):

    .. math:: -\\psi_m = a\\zeta + b(\\zeta - c/d)e^{-d\\zeta} + bc/d

    References
    ----------
    Paulson (1970); Dyer (1974); Beljaars and Holtslag (1991), Eq. 28.
    """
    z = np.asarray(zeta, dtype=float)
    out = np.zeros_like(z)
    neg = z < 0
    x = (1.0 - 16.0 * np.where(neg, z, 0.0)) ** 0.25
    unstable = 2 * np.log((1 + x) / 2) + np.log((1 + x**2) / 2) - 2 * np.arctan(x) + np.pi / 2
    a, b, c, d = 1.0, 2.0 / 3.0, 5.0, 0.35
    zp = np.where(neg, 0.0, z)
    stable = -(a * zp + b * (zp - c / d) * np.exp(-d * zp) + b * c / d)
    out[...] = np.where(neg, unstable, stable)
    return out


def psi_h(zeta: np.ndarray | float) -> np.ndarray:
    """Integrated stability function for heat.

    Parameters
    ----------
    zeta : array_like
        z/L [1].

    Returns
    -------
    numpy.ndarray
        psi_h [1].

    Notes
    -----
    Unstable: :math:`\\psi_h = 2\\ln((1+x^2)/2)` with x = (1 - 16 zeta)^(1/4) (Paulson 1970).
    Stable (Beljaars and Holtslag 1991):

    .. math:: -\\psi_h = (1 + 2a\\zeta/3)^{3/2} + b(\\zeta - c/d)e^{-d\\zeta} + bc/d - 1

    References
    ----------
    Paulson (1970); Beljaars and Holtslag (1991), Eq. 32.
    """
    z = np.asarray(zeta, dtype=float)
    neg = z < 0
    x = (1.0 - 16.0 * np.where(neg, z, 0.0)) ** 0.25
    unstable = 2 * np.log((1 + x**2) / 2)
    a, b, c, d = 1.0, 2.0 / 3.0, 5.0, 0.35
    zp = np.where(neg, 0.0, z)
    stable = -((1 + 2 * a * zp / 3) ** 1.5 + b * (zp - c / d) * np.exp(-d * zp) + b * c / d - 1)
    return np.where(neg, unstable, stable)


def _zeta(z_m: np.ndarray | float, obukhov_length_m: float) -> np.ndarray:
    return np.asarray(z_m, dtype=float) / obukhov_length_m


def friction_velocity(mean_speed_ms: float, z_ref_m: float, roughness_length_m: float,
                      obukhov_length_m: float) -> float:
    """Friction velocity from one mean speed and the Monin-Obukhov profile.

    Parameters
    ----------
    mean_speed_ms : float
        Mean horizontal speed at ``z_ref_m`` [m s-1].
    z_ref_m : float
        Height of that speed [m].
    roughness_length_m : float
        Aerodynamic roughness length z0 [m].
    obukhov_length_m : float
        Obukhov length L [m] (use +-inf for neutral).

    Returns
    -------
    float
        u* [m s-1].

    Notes
    -----
    .. math:: u_* = \\kappa U(z) / [\\ln(z/z_0) - \\psi_m(z/L) + \\psi_m(z_0/L)]

    References
    ----------
    Kaimal and Finnigan (1994), Eq. 1.29; Paulson (1970).
    """
    denom = (np.log(z_ref_m / roughness_length_m) - psi_m(_zeta(z_ref_m, obukhov_length_m))
             + psi_m(_zeta(roughness_length_m, obukhov_length_m)))
    return float(KARMAN * mean_speed_ms / denom)


def mean_speed_profile(z_m: np.ndarray | float, friction_velocity_ms: float,
                       roughness_length_m: float, obukhov_length_m: float) -> np.ndarray:
    """Monin-Obukhov mean wind speed at heights ``z_m``.

    Parameters
    ----------
    z_m : array_like
        Heights above ground [m]; values below ``2 z0`` are evaluated at ``2 z0``.
    friction_velocity_ms : float
        u* [m s-1].
    roughness_length_m : float
        z0 [m].
    obukhov_length_m : float
        L [m].

    Returns
    -------
    numpy.ndarray
        U(z) [m s-1].

    Notes
    -----
    .. math:: U(z) = \\frac{u_*}{\\kappa}[\\ln(z/z_0) - \\psi_m(z/L) + \\psi_m(z_0/L)]

    References
    ----------
    Kaimal and Finnigan (1994), Eq. 1.29.
    """
    z = np.maximum(np.asarray(z_m, dtype=float), 2 * roughness_length_m)
    return friction_velocity_ms / KARMAN * (
        np.log(z / roughness_length_m) - psi_m(_zeta(z, obukhov_length_m))
        + psi_m(_zeta(roughness_length_m, obukhov_length_m)))


def theta_profile(z_m: np.ndarray | float, z_ref_m: float, theta_ref_k: float,
                  friction_velocity_ms: float, obukhov_length_m: float) -> np.ndarray:
    """Mean sonic (virtual) temperature at heights ``z_m``.

    Parameters
    ----------
    z_m : array_like
        Heights [m].
    z_ref_m : float
        Height where the temperature is ``theta_ref_k`` [m].
    theta_ref_k : float
        Mean sonic temperature at ``z_ref_m`` [K].
    friction_velocity_ms : float
        u* [m s-1].
    obukhov_length_m : float
        L [m].

    Returns
    -------
    numpy.ndarray
        Temperature [K] (actual, not potential: includes the dry-adiabatic lapse).

    Notes
    -----
    With :math:`\\theta_* = u_*^2\\theta/(\\kappa g L)` (from Ghirardelli et al. (2025), Eq. 9):

    .. math:: T(z) = T_r + \\frac{\\theta_*}{\\kappa}[\\ln(z/z_r) - \\psi_h(z/L) + \\psi_h(z_r/L)]
              - \\frac{g}{c_p}(z - z_r)

    References
    ----------
    Kaimal and Finnigan (1994), Eq. 1.30; Ghirardelli et al. (2025), Eq. 9.
    """
    z = np.maximum(np.asarray(z_m, dtype=float), 0.1)
    theta_star = friction_velocity_ms**2 * theta_ref_k / (KARMAN * GRAVITY_MS2 * obukhov_length_m)
    return (theta_ref_k + theta_star / KARMAN * (
        np.log(z / z_ref_m) - psi_h(_zeta(z, obukhov_length_m)) + psi_h(_zeta(z_ref_m, obukhov_length_m)))
        - GRAVITY_MS2 / CP_DRY_JKGK * (z - z_ref_m))


def turbulence_sigmas(friction_velocity_ms: float, z_m: float, obukhov_length_m: float,
                      boundary_layer_height_m: float = 1000.0,
                      theta_mean_k: float = 293.15) -> dict[str, float]:
    """Standard deviations of u, v, w and sonic temperature from similarity.

    Parameters
    ----------
    friction_velocity_ms : float
        u* [m s-1].
    z_m : float
        Height [m].
    obukhov_length_m : float
        L [m].
    boundary_layer_height_m : float
        Convective boundary-layer depth z_i [m] (only used when L < 0).
    theta_mean_k : float
        Mean temperature [K] (for theta*).

    Returns
    -------
    dict
        ``sigma_u_ms, sigma_v_ms, sigma_w_ms, sigma_theta_k, theta_star_k`` and the
        target fluxes ``uw_m2s2`` (= -u*^2) and ``wtheta_kms``.

    Notes
    -----
    Neutral/stable: sigma_u/u* = 2.39, sigma_v/u* = 1.92 (Panofsky and Dutton 1984),
    :math:`\\sigma_w/u_* = 1.25(1 + 0.2\\zeta)` (Kaimal and Finnigan 1994, Eq. 1.33).
    Unstable: :math:`\\sigma_{u,v}/u_* = (a_{u,v}^3 + 0.5 z_i/|L|)^{1/3}` (Panofsky et al.
    1977, whose 12 = a^3 is replaced by the neutral constants above so that the
    functions are continuous at zeta = 0), :math:`\\sigma_w/u_* = 1.25(1 - 3\\zeta)^{1/3}`.
    Temperature: :math:`\\theta_* = u_*^2\\theta/(\\kappa g L)`,
    :math:`\\sigma_\\theta = 2|\\theta_*|(1 - 9.5\\zeta)^{-1/3}` (unstable),
    :math:`2|\\theta_*|` (stable), floored at 0.02 K (residual sonic-temperature
    variance in neutral air). :math:`\\overline{w'\\theta'} = -u_*\\theta_*`.

    References
    ----------
    Panofsky et al. (1977); Panofsky and Dutton (1984), Ch. 7; Kaimal and Finnigan
    (1994), Eqs 1.33-1.35; Ghirardelli et al. (2025), Eq. 9.
    """
    ustar = float(friction_velocity_ms)
    zeta = z_m / obukhov_length_m
    if zeta < 0:
        conv = 0.5 * boundary_layer_height_m / abs(obukhov_length_m)
        su = ustar * (2.39**3 + conv) ** (1 / 3)
        sv = ustar * (1.92**3 + conv) ** (1 / 3)
        sw = ustar * 1.25 * (1 - 3 * zeta) ** (1 / 3)
    else:
        su, sv = 2.39 * ustar, 1.92 * ustar
        sw = ustar * 1.25 * (1 + 0.2 * zeta)
    theta_star = ustar**2 * theta_mean_k / (KARMAN * GRAVITY_MS2 * obukhov_length_m)
    st = 2 * abs(theta_star) * ((1 - 9.5 * zeta) ** (-1 / 3) if zeta < 0 else 1.0)
    return {"sigma_u_ms": su, "sigma_v_ms": sv, "sigma_w_ms": sw,
            "sigma_theta_k": max(st, 0.02), "theta_star_k": theta_star,
            "uw_m2s2": -ustar**2, "wtheta_kms": -ustar * theta_star}


def dissipation_phi(zeta: float) -> float:
    """Dimensionless dissipation rate phi_eps = kappa z eps / u*^3.

    Parameters
    ----------
    zeta : float
        z/L [1].

    Returns
    -------
    float
        phi_eps [1].

    Notes
    -----
    .. math:: \\phi_\\epsilon = (1 + 0.5|\\zeta|^{2/3})^{3/2}\\ (\\zeta<0),\\qquad
              1 + 5\\zeta\\ (\\zeta\\ge 0)

    References
    ----------
    Kaimal and Finnigan (1994), Eq. 1.34 (after Kaimal et al. 1972).
    """
    if zeta < 0:
        return float((1 + 0.5 * abs(zeta) ** (2 / 3)) ** 1.5)
    return float(1 + 5 * zeta)


def spectral_parameters(sigmas: dict[str, float], friction_velocity_ms: float,
                        zeta: float) -> dict[str, float]:
    """Length parameters b of the spectral shapes from sigma and the dissipation rate.

    Parameters
    ----------
    sigmas : dict
        Output of :func:`turbulence_sigmas`.
    friction_velocity_ms : float
        u* [m s-1].
    zeta : float
        z/L [1].

    Returns
    -------
    dict
        ``b_u, b_v, b_w, b_theta, b_co`` (dimensionless, of the reduced frequency
        n = f z / U).

    Notes
    -----
    Shapes (unit integral over f, Kaimal et al. 1972 forms):

    .. math::
        S_{u,v,\\theta}(f) = \\sigma^2 \\frac{2b}{3}\\frac{z}{U}(1 + b n)^{-5/3},\\qquad
        S_w(f) = \\sigma_w^2 \\frac{b^{3/5}}{c_0}\\frac{z}{U}(1 + b n^{5/3})^{-1},
        \\quad c_0 = \\frac{3\\pi/5}{\\sin(3\\pi/5)}

    The inertial-subrange levels :math:`S_u \\to 0.3 u_*^2\\phi_\\epsilon^{2/3}
    (z/U)^{-2/3} f^{-5/3}` and :math:`S_v = S_w = \\tfrac43 S_u` (local isotropy) give

    .. math:: b_{u,v} = \\left[\\frac{2\\sigma^2}{3K}\\right]^{3/2},\\qquad
              b_w = \\left[\\frac{\\sigma_w^2}{c_0 K_w}\\right]^{5/2}

    with K in units of u*^2 (K_u = 0.3 phi_eps^(2/3), K_v = K_w = 0.4 phi_eps^(2/3)).
    Neutral values: b_u = 45, b_v = 15, b_w = 5.5 (Kaimal: 33, 9.5, 5.3).
    Temperature uses b_u; the cospectral parameter b_co = 1.76 b_w (Kaimal's 9.6/5.3
    ratio for the uw cospectrum).

    References
    ----------
    Kaimal et al. (1972), Eqs 20-24; Kaimal and Finnigan (1994), Eqs 2.25-2.30.
    """
    us2 = friction_velocity_ms**2
    phi23 = dissipation_phi(zeta) ** (2 / 3)
    k_u = 0.3 * phi23 * us2
    k_vw = 0.4 * phi23 * us2
    c0 = (0.6 * np.pi) / np.sin(0.6 * np.pi)
    b_u = (2 * sigmas["sigma_u_ms"] ** 2 / (3 * k_u)) ** 1.5
    b_v = (2 * sigmas["sigma_v_ms"] ** 2 / (3 * k_vw)) ** 1.5
    b_w = (sigmas["sigma_w_ms"] ** 2 / (c0 * k_vw)) ** 2.5
    return {"b_u": float(b_u), "b_v": float(b_v), "b_w": float(b_w), "b_theta": float(b_u),
            "b_co": float(1.76 * b_w)}


def component_spectra(freq_hz: np.ndarray, z_m: float, speed_ms: float,
                      sigmas: dict[str, float], params: dict[str, float]) -> dict[str, np.ndarray]:
    """One-sided spectra of u, v, w, theta and the unscaled u-w cospectral shape.

    Parameters
    ----------
    freq_hz : numpy.ndarray
        Frequencies [Hz] (> 0).
    z_m : float
        Height [m].
    speed_ms : float
        Mean speed used for the reduced frequency [m s-1].
    sigmas : dict
        From :func:`turbulence_sigmas`.
    params : dict
        From :func:`spectral_parameters`.

    Returns
    -------
    dict
        ``S_u, S_v, S_w`` [m2 s-2 Hz-1], ``S_theta`` [K2 Hz-1] and ``co_shape``
        (cospectral shape n/(1 + b_co n)^(7/3) per Hz, arbitrary scale).

    Notes
    -----
    Shapes as in :func:`spectral_parameters`; the cospectral shape has the -7/3
    inertial slope of Kaimal et al. (1972), Eq. 25.

    References
    ----------
    Kaimal et al. (1972).
    """
    zu = z_m / speed_ms
    n = freq_hz * zu
    c0 = (0.6 * np.pi) / np.sin(0.6 * np.pi)
    out = {}
    for comp in ("u", "v", "theta"):
        b = params[f"b_{comp}"]
        s2 = sigmas[f"sigma_{comp}_ms" if comp != "theta" else "sigma_theta_k"] ** 2
        out[f"S_{comp}"] = s2 * (2 * b / 3) * zu * (1 + b * n) ** (-5 / 3)
    b = params["b_w"]
    out["S_w"] = sigmas["sigma_w_ms"] ** 2 * b**0.6 / c0 * zu / (1 + b * n ** (5 / 3))
    out["co_shape"] = zu / (1 + params["b_co"] * n) ** (7 / 3)
    return out


def coherence(freq_hz: np.ndarray, separation_m: np.ndarray, speed_ms: float,
              height_m: float | np.ndarray, component: str) -> np.ndarray:
    """Exponential spatial coherence (IEC 61400-1 Ed. 3, Annex B).

    Parameters
    ----------
    freq_hz : numpy.ndarray
        Frequencies [Hz], shape (nf,).
    separation_m : numpy.ndarray
        Effective separations [m], any shape s.
    speed_ms : float
        Mean speed [m s-1].
    height_m : float or numpy.ndarray
        Representative height of each pair for the coherence scale [m]
        (broadcastable to ``separation_m``).
    component : {"u", "v", "w", "theta"}

    Returns
    -------
    numpy.ndarray
        Coherence (real, in [0, 1]), shape (nf,) + s.

    Notes
    -----
    .. math:: \\gamma(f, \\Delta) = \\exp\\left(-12\\sqrt{(f\\Delta/U)^2 + (0.12\\Delta/L_c)^2}\\right),
              \\quad L_c = 8.1\\,\\Lambda\\,c_i,\\ \\Lambda = 0.7\\min(z, 60\\,\\mathrm{m})

    with c_i = 1, 2.7/8.1, 0.66/8.1 for u, v, w (pyconturb "iec3d"); theta as w.

    References
    ----------
    IEC 61400-1 Ed. 3 (2005), Eq. B.13; Rinker (2018).
    """
    lc = 8.1 * 0.7 * np.clip(np.asarray(height_m, dtype=float), 1.0, 60.0) * _COH_LC_FACTOR[component]
    f = np.asarray(freq_hz, dtype=float).reshape((-1,) + (1,) * np.ndim(separation_m))
    d = np.asarray(separation_m, dtype=float)[None, ...]
    lc = np.broadcast_to(lc, d.shape[1:])[None, ...]
    return np.exp(-_COH_A * np.sqrt((f * d / speed_ms) ** 2 + (_COH_B * d / lc) ** 2))


def wind_frame_unit_vectors(wind_from_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """ENU unit vectors of the streamwise (u) and lateral (v, to the left) axes.

    Parameters
    ----------
    wind_from_deg : float
        Direction the wind blows from, clockwise from true north [degree].

    Returns
    -------
    e_u, e_v : numpy.ndarray
        Horizontal (east, north) unit vectors. Wind from the west (270) gives
        e_u = (1, 0) (blowing east) and e_v = (0, 1) (north is to the left).
    """
    a = deg2rad(wind_from_deg)
    e_u = np.array([-np.sin(a), -np.cos(a)])
    e_v = np.array([-e_u[1], e_u[0]])
    return e_u, e_v


# --------------------------------------------------------------------------------------
# Spectral field
# --------------------------------------------------------------------------------------
class ConstraintLatents(TypedDict):
    """Internal form of a measured record constraining the field (see :func:`simulate_wind`).

    Keys: ``point`` (3,) ENU position [m]; ``coefficients`` (4, n_freq - 1) complex Fourier
    coefficients of the record's wind-frame u, v, w, theta fluctuations at the positive
    constrained frequencies (NaN for a missing theta), scaled as :attr:`FieldSpec.coeffs`;
    ``n_freq`` number of constrained frequencies (the zero frequency included);
    ``n_missing`` samples interpolated over gaps; ``offset`` (4,) the record's mean over the
    period minus its mean over the averaging window (east, north, up [m s-1], temperature
    [K]; zeros when the window is the whole period), added to the mean of every point;
    ``noise_power`` the record's white-noise power per coefficient (:func:`_measured_spectra`).
    The latents are solved from the coefficients by :func:`field_coefficients`, with the
    amplitudes it uses at the constraint point.
    """

    point: np.ndarray
    coefficients: np.ndarray
    n_freq: int
    n_missing: int
    offset: np.ndarray
    #: (4,) expected |c|^2 per coefficient of the record's white measurement noise in u, v, w
    #: [m2 s-2] and theta [K2] (variance / samples), removed from its spectra before they
    #: become amplitudes (zeros: none)
    noise_power: np.ndarray


class FieldDiagnostics(TypedDict, total=False):
    """Targets of a field per point: similarity sigmas and fluxes, spectral parameters, z/L."""

    sigmas: list[dict[str, float]]
    spectral_parameters: list[dict[str, float]]
    zeta: list[float]
    advection_speed_ms: float


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


def _scaled_coherency(shape: np.ndarray, s_x: np.ndarray, s_y: np.ndarray, df: float,
                      target: float) -> np.ndarray:
    """Coherency rho(f) = c * shape / sqrt(S_x S_y) scaled so sum rho sqrt(SxSy) df = target.

    Where |rho| would exceed 0.95 it is clipped and the rest rescaled (a few passes);
    if the target is not reachable the closest achievable covariance is produced.
    """
    root = np.sqrt(s_x * s_y)
    base = shape / np.maximum(root, 1e-300)
    rho = np.zeros_like(base)
    if target == 0 or not np.any(root > 0):
        return rho
    scale = target / np.sum(shape * df)
    for _ in range(6):
        rho = np.clip(scale * base, -_MAX_COHERENCY, _MAX_COHERENCY)
        got = np.sum(rho * root * df)
        if abs(got - target) <= 1e-9 * abs(target):
            break
        free = np.abs(scale * base) < _MAX_COHERENCY
        free_cov = np.sum(scale * base[free] * root[free] * df)
        if free_cov == 0:
            break
        scale *= 1 + (target - got) / free_cov
    return rho


@dataclass(frozen=True)
class _PointSpectra:
    """Per point: component amplitudes A_i(f_k) (n_p, 4, nf), u-w and w-theta coherencies (n_p, nf)."""

    amplitude: np.ndarray
    rho_uw: np.ndarray
    rho_wt: np.ndarray
    diagnostics: FieldDiagnostics
    #: unscaled u-w (and w-theta) cospectral shape per point (n_p, nf)
    co_shape: np.ndarray


def _point_spectra(z_m: np.ndarray, speed_ms: np.ndarray, fpos_hz: np.ndarray, df_hz: float,
                   friction_velocity_ms: float, obukhov_length_m: float, boundary_layer_height_m: float,
                   theta_mean_k: float) -> _PointSpectra:
    """Amplitudes sqrt(S_i df / 2) and scaled coherencies of every point (Kaimal shapes, similarity sigmas).

    Parameters
    ----------
    z_m, speed_ms : numpy.ndarray
        Height [m] and mean speed [m s-1] of each point.
    fpos_hz : numpy.ndarray
        Positive frequencies k / period [Hz].
    df_hz : float
        Frequency step 1 / period [Hz].
    friction_velocity_ms, obukhov_length_m, boundary_layer_height_m, theta_mean_k : float
        u* [m s-1], L [m], z_i [m], mean temperature [K].

    Returns
    -------
    _PointSpectra
        Amplitudes, coherencies (u'w' = -u*^2 and w'theta' over the resolved band) and
        the targets per point.
    """
    n_p, n_f = z_m.size, fpos_hz.size
    amp = np.zeros((n_p, 4, n_f))
    rho_uw = np.zeros((n_p, n_f))
    rho_wt = np.zeros((n_p, n_f))
    co_shape = np.zeros((n_p, n_f))
    sigmas, params, zetas = [], [], []
    for p in range(n_p):
        zeta = z_m[p] / obukhov_length_m
        sig = turbulence_sigmas(friction_velocity_ms, z_m[p], obukhov_length_m, boundary_layer_height_m,
                                theta_mean_k)
        par = spectral_parameters(sig, friction_velocity_ms, zeta)
        spec = component_spectra(fpos_hz, z_m[p], max(speed_ms[p], 0.5), sig, par)
        for i, comp in enumerate(_COMPONENTS):
            amp[p, i] = np.sqrt(spec[f"S_{comp}"] * df_hz / 2.0)
        rho_uw[p] = _scaled_coherency(spec["co_shape"], spec["S_u"], spec["S_w"], df_hz, sig["uw_m2s2"])
        rho_wt[p] = _scaled_coherency(spec["co_shape"], spec["S_w"], spec["S_theta"], df_hz,
                                      sig["wtheta_kms"])
        co_shape[p] = spec["co_shape"]
        sigmas.append(sig)
        params.append(par)
        zetas.append(float(zeta))
    return _PointSpectra(amp, rho_uw, rho_wt,
                         FieldDiagnostics(sigmas=sigmas, spectral_parameters=params, zeta=zetas), co_shape)


def _separations(points_enu_m: np.ndarray, e_u: np.ndarray,
                 e_v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Downwind coordinate, effective separations and pair heights of the points.

    Parameters
    ----------
    points_enu_m : numpy.ndarray
        (n_p, 3) ENU positions [m].
    e_u, e_v : numpy.ndarray
        Wind-frame unit vectors (east, north).

    Returns
    -------
    s_down_m : numpy.ndarray
        (n_p,) coordinate along the mean wind [m].
    d_eff_m : numpy.ndarray
        (n_p, n_p) sqrt(d_lat^2 + d_z^2 + (0.5 d_along)^2) [m] (along-wind weight 0.5,
        Pielke and Panofsky 1970).
    z_pair_m : numpy.ndarray
        (n_p, n_p) mean height of each pair [m] (coherence scale).
    """
    z = points_enu_m[:, 2]
    s_down = points_enu_m[:, :2] @ e_u
    lat = points_enu_m[:, :2] @ e_v
    d_along = s_down[:, None] - s_down[None, :]
    d_lat = lat[:, None] - lat[None, :]
    d_z = z[:, None] - z[None, :]
    d_eff = np.sqrt(d_lat**2 + d_z**2 + (_ALONG_WIND_COH_WEIGHT * d_along) ** 2)
    z_pair = 0.5 * (z[:, None] + z[None, :])  # pair heights: earlier points independent of later
    return s_down, d_eff, z_pair


class _CoherenceKey:
    """The arguments of one coherence matrix, hashable by their content (:func:`_coherence_factor`)."""

    __slots__ = ("freq_hz", "separation_m", "speed_ms", "height_m", "component", "_digest")

    def __init__(self, freq_hz: np.ndarray, separation_m: np.ndarray, speed_ms: float, height_m: np.ndarray,
                 component: str) -> None:
        self.freq_hz, self.separation_m, self.height_m = freq_hz, separation_m, height_m
        self.speed_ms, self.component = speed_ms, component
        self._digest = content_digest({"freq_hz": freq_hz, "separation_m": separation_m, "height_m": height_m},
                                      prefix=repr((speed_ms, component)))

    def __hash__(self) -> int:
        return hash(self._digest)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _CoherenceKey) and self._digest == other._digest


@functools.lru_cache(maxsize=8)
def _coherence_factor(key: _CoherenceKey) -> np.ndarray:
    """Cholesky factor (n_f, n_p, n_p) of the coherence matrices of one set of points (read-only).

    Remembered by content: the baseline seeds and the measurement probes of a forward flight
    share the points and the wind, so their fields use the same factors. For flight s02 the
    coherences and factorisations of its 40 fields took 2.7 % of the forward runs' profiled
    time; 20 are now made, 20 reused (``benchmarks/results/profile_forward_s02_s26_*.json``).
    Equal arguments give the same factor, so the draws do not change.
    """
    n_p = key.separation_m.shape[0]
    coh = coherence(key.freq_hz, key.separation_m, key.speed_ms, key.height_m, key.component)  # (nf, n_p, n_p)
    coh += 1e-12 * np.eye(n_p)[None]
    chol = np.linalg.cholesky(coh)
    chol.setflags(write=False)
    return chol


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


def _constraint_times_s(constraint: xr.Dataset) -> np.ndarray:
    """Sample times [s] of a constraint record, after checking its variables and attributes."""
    where = "simulate_wind.constraint"
    for var in ("u_east_ms", "v_north_ms", "w_up_ms"):
        if var not in constraint:
            raise InputError(where, f"missing variable {var!r} (L1 mast names expected)")
    if "height_m" not in constraint.attrs:
        raise InputError(where, "missing attribute 'height_m'")
    if "time" in constraint.dims and np.issubdtype(constraint["time"].dtype, np.datetime64):
        return np.asarray((constraint["time"].values - constraint["time"].values[0]) / np.timedelta64(1, "s"))
    if "time_s" in constraint.coords:
        return np.asarray(constraint["time_s"].values, float)
    raise InputError(where, "needs a datetime64 'time' or a 'time_s' coordinate")


def _constraint_series(constraint: xr.Dataset, t_s: np.ndarray, period_s: float, wind_from_deg: float,
                       mean_window_s: tuple[float, float] | None = None
                       ) -> tuple[list[np.ndarray | None], int, int, np.ndarray]:
    """Fluctuations of a record over one period on a regular grid, in the wind frame.

    Parameters
    ----------
    constraint : xarray.Dataset
        The record (see :func:`simulate_wind`).
    t_s : numpy.ndarray
        Its sample times [s].
    period_s : float
        Length to use [s].
    wind_from_deg : float
        Mean wind direction of the field [degree].
    mean_window_s : (float, float), optional
        Times [s] (as ``t_s``) between which the means are taken; the whole period by default.

    Returns
    -------
    series : list
        u, v (wind frame), w [m s-1] and theta [K] (None without a temperature) minus
        their means over ``mean_window_s``, gaps interpolated.
    n_grid : int
        Samples in the period.
    n_missing : int
        Samples interpolated.
    offset : numpy.ndarray
        (4,) mean over the period of the ENU wind and temperature fluctuations (east,
        north, up [m s-1], temperature [K]; 0 without a temperature): zero for the default
        window.
    """
    where = "simulate_wind.constraint"
    dt = np.median(np.diff(t_s))
    fs_c = 1.0 / dt
    n_c = int(round(period_s * fs_c))
    if t_s[-1] - t_s[0] + dt < period_s - 1e-6:
        raise InputError(where, f"record of {t_s[-1] - t_s[0] + dt:.1f} s is shorter than the "
                                f"{period_s:.1f} s to simulate")
    grid = t_s[0] + np.arange(n_c) * dt
    window = np.ones(n_c, bool) if mean_window_s is None else (grid >= mean_window_s[0]) & (grid <= mean_window_s[1])
    if not window.any():
        raise InputError(where, f"averaging window {mean_window_s} s holds no sample of the record")
    e_u, e_v = wind_frame_unit_vectors(wind_from_deg)
    temperature = "t_sonic_k" if "t_sonic_k" in constraint else ("theta_v_k" if "theta_v_k" in constraint else None)
    chans: list[np.ndarray | None] = []
    n_bad = 0
    for var in ("u_east_ms", "v_north_ms", "w_up_ms", temperature):
        if var is None:
            chans.append(None)
            continue
        x = np.asarray(constraint[var].values, float)
        good = np.isfinite(x)
        n_bad += int((~good).sum())
        if good.sum() < 0.98 * x.size:
            raise InputError(f"{where}.{var}", f"{(~good).sum()} of {x.size} samples missing (> 2 %)")
        series_c = np.interp(grid, t_s[good], x[good])
        chans.append(series_c - series_c[window].mean())
    ue, vn, wu, th = chans
    assert ue is not None and vn is not None and wu is not None
    offset = np.array([ue.mean(), vn.mean(), wu.mean(), 0.0 if th is None else th.mean()])
    series = [ue * e_u[0] + vn * e_u[1], ue * e_v[0] + vn * e_v[1], wu, th]
    return series, n_c, n_bad, offset


def _constraint_coefficients(series: list[np.ndarray | None], n_grid: int, period_s: float,
                             fs_hz: float) -> np.ndarray:
    """Fourier coefficients (4, n_freq - 1) of a record's series at the positive constrained frequencies.

    Scaled as :attr:`FieldSpec.coeffs` (x = sum 2 Re(c e^{iwt})); the constrained frequencies
    are those below both the record's and the field's Nyquist frequency; NaN for a missing
    temperature.
    """
    n_freq_c = min((n_grid + 1) // 2, int(np.ceil(period_s * fs_hz / 2.0)))
    obs = np.full((4, n_freq_c), np.nan + 0j)
    for i, x in enumerate(series):
        if x is not None:
            obs[i] = np.fft.rfft(x)[:n_freq_c] / n_grid
    return obs[:, 1:]


def _constraint_latents(coefficients: np.ndarray, point_enu_m: np.ndarray, fpos_hz: np.ndarray,
                        advection_speed_ms: float, e_u: np.ndarray, amplitude: np.ndarray,
                        rho_uw: np.ndarray, rho_wt: np.ndarray) -> list[np.ndarray]:
    """Latents (w, u, theta, v) of a record from its Fourier coefficients and the amplitudes at its point.

    The observed coefficients, freed of the record point's Taylor delay, are divided by the
    amplitudes the field uses at that point (model or measured, :func:`field_coefficients`)
    and the u-w and w-theta coherencies are removed (Rinker 2018, Eq. 6), so that
    :func:`field_coefficients` reproduces the record.

    Parameters
    ----------
    coefficients : numpy.ndarray
        (4, n_c) from :func:`_constraint_coefficients`.
    point_enu_m : numpy.ndarray
        (3,) the record's position [m].
    fpos_hz : numpy.ndarray
        The field's positive frequencies [Hz] (at least n_c).
    advection_speed_ms : float
        Taylor advection speed [m s-1].
    e_u : numpy.ndarray
        Streamwise unit vector (east, north).
    amplitude : numpy.ndarray
        (4, nf) amplitudes of u, v, w, theta at the record's point.
    rho_uw, rho_wt : numpy.ndarray
        (nf,) coherencies at the record's point.

    Returns
    -------
    list of numpy.ndarray
        (w, u, theta, v), each (n_c,) (NaN for a missing temperature).
    """
    n_c = coefficients.shape[1]
    f = fpos_hz[:n_c]
    delay = float(point_enu_m[:2] @ e_u) / advection_speed_ms
    o = coefficients * np.exp(2j * np.pi * f * delay)[None, :]  # the delay is re-applied to all points
    a_u, a_v, a_w, a_t = (amplitude[i, :n_c] for i in range(4))
    r_uw, r_wt = rho_uw[:n_c], rho_wt[:n_c]
    x_w = o[2] / a_w
    x_u = (o[0] / a_u - r_uw * x_w) / np.sqrt(1 - r_uw**2)
    x_t = (o[3] / a_t - r_wt * x_w) / np.sqrt(1 - r_wt**2)
    x_v = o[1] / a_v
    return [x_w, x_u, x_t, x_v]


#: Log-frequency bins per decade of the measured spectra (:func:`_measured_spectra`).
MEASURED_BINS_PER_DECADE = 10


def _log_bins(freq_hz: np.ndarray, bins_per_decade: int) -> tuple[np.ndarray, np.ndarray]:
    """Log-frequency bin of every frequency (0, 1, ... from the lowest) and the number of frequencies per bin."""
    idx = np.floor(np.log10(freq_hz) * bins_per_decade).astype(np.int64)
    _, inverse, counts = np.unique(idx, return_inverse=True, return_counts=True)
    return inverse, counts


def _log_binned_mean(values: np.ndarray, freq_hz: np.ndarray, bins_per_decade: int) -> np.ndarray:
    """Mean of ``values`` over log-frequency bins, given to every frequency of its bin."""
    inverse, counts = _log_bins(freq_hz, bins_per_decade)
    return (np.bincount(inverse, weights=values) / counts)[inverse]


def spectral_sampling_factors(counts: np.ndarray, rng: np.random.Generator, n_components: int = 4) -> np.ndarray:
    r"""Random factors on a log-bin-smoothed periodogram: its sampling error, drawn again.

    A bin of a smoothed spectrum is the mean of ``n`` periodogram ordinates of one record, so
    it is that record's estimate of the spectrum, in error by a chi-square variate with 2n
    degrees of freedom over 2n (Bendat and Piersol 2010, Sect. 8.5.4). The field of a
    measured atmosphere (:func:`field_coefficients` with a constraint and
    ``amplitudes="constraint"``) gives the hover point a remainder drawn with the smoothed
    spectrum; across seeds that remainder scatters as a sensor sampling the smoothed
    spectrum, not as one sampling the true spectrum of which the record's is one estimate.
    The factors multiply each bin's level by a Gamma variate of mean 1 and variance

    .. math:: v(n) = \frac{n - 1}{n^2},

    the variance that a bootstrap resample of the bin's n ordinates gives its mean, relative
    to its square, in expectation for chi-square ordinates (Efron and Tibshirani 1993,
    Sect. 5.2: the plug-in variance (n - 1)/n of an ordinate, over n). A bin of one ordinate
    (the lowest frequencies) holds the record's own coefficient, which already carries its
    sampling error into the remainder's amplitude: v(1) = 0. For many ordinates
    v(n) -> 1/n, the chi-square sampling variance of the bin, which a log band power of the
    drone minus the mast's needs; for a power summed over bins (a variance) the variance
    given the record, :math:`\hat S^2 n (1 + v (n + 1))` per bin with
    :math:`E[\hat S^2] = S^2 (1 + 1/n)`, then exceeds the :math:`2 n S^2` of two independent
    records by at most 31 % in a bin (n = 2), 9 % at n = 10. Measured on the full chain
    (``benchmarks/results/measured_atmosphere_scatter.json``: 100 virtual 12-min flights, 4
    seeds each; 95 % interval of the ratio under a right scatter 0.73-1.40), the seed
    variance (times 1 + 1/K) over the variance of measured minus predicted, without these
    factors and with them: ln sigma ratio u 0.95 and 1.00, v 0.72 and 0.83, w 0.81 and 1.00;
    drone S_w/S_u 0.77 and 1.10; pendulum-band w power 0.75 and 1.05; high-frequency u 0.79
    and 1.12, w 1.01 and 1.42. The mean-wind features (speed ratio 0.79, tilt difference
    0.59), made of the lowest frequencies, do not change.

    Parameters
    ----------
    counts : numpy.ndarray
        Number of periodogram ordinates in each bin (:func:`_log_bins`).
    rng : numpy.random.Generator
        Random generator (one draw per component and bin, in that order, whatever the counts).
    n_components : int
        Number of spectra (u, v, w, theta), each with its own draws.

    Returns
    -------
    numpy.ndarray
        (n_components, n_bins) positive factors, mean 1 (exactly 1 for a bin of one ordinate).

    References
    ----------
    Bendat, J. S. and Piersol, A. G. (2010), Random Data, 4th ed., Wiley, Sect. 8.5.4.
    Efron, B. and Tibshirani, R. J. (1993), An Introduction to the Bootstrap, Chapman & Hall.
    """
    n = np.asarray(counts, float)
    var = (n - 1.0) / n**2
    shape = np.where(var > 0, 1.0 / np.maximum(var, 1e-300), 1.0)
    draws = rng.standard_gamma(np.broadcast_to(shape, (n_components, n.size)))
    return np.where(var > 0, draws * var, 1.0)


def _measured_spectra(spectra: _PointSpectra, coefficients: np.ndarray, fpos_hz: np.ndarray, df_hz: float,
                      noise_power: np.ndarray | None = None,
                      bins_per_decade: int = MEASURED_BINS_PER_DECADE,
                      sampling: np.random.Generator | None = None) -> _PointSpectra:
    """The points' spectra with the amplitudes of a measured record (the constraint, point 0).

    Parameters
    ----------
    spectra : _PointSpectra
        Model spectra of the points (point 0 at the record's position).
    coefficients : numpy.ndarray
        (4, n_c) Fourier coefficients of the record (u, v, w, theta; NaN theta when missing).
    fpos_hz : numpy.ndarray
        Positive frequencies [Hz].
    df_hz : float
        Frequency step [Hz].
    noise_power : numpy.ndarray, optional
        (4,) expected |c|^2 of the record's white measurement noise per coefficient
        (variance / samples), removed from the periodogram (at most 90 % of it); none by
        default.
    bins_per_decade : int
        Log-frequency bins per decade of the smoothing.
    sampling : numpy.random.Generator, optional
        Draw the smoothed spectra again from their sampling distribution given the record
        (each bin times :func:`spectral_sampling_factors`, the same factor at every point);
        the smoothed spectra themselves by default.

    Returns
    -------
    _PointSpectra
        Amplitudes :math:`A_i(z_p, f) = A_i^{model}(z_p, f)\\sqrt{R_i(f)}`, coherencies
        rescaled to the same fluxes with these spectra.

    Notes
    -----
    The record's periodogram is divided by the model spectrum at its point (prewhitened)
    and averaged over log-frequency bins:
    :math:`R_i(f) = \\langle |c_i(f_k)|^2 / A_i^{model}(z_c, f_k)^2\\rangle_{bin}`, so that
    :math:`S_i(z_p, f) = \\hat S_i^{meas}(z_c, f)\\, S_i^{model}(z_p, f) / S_i^{model}(z_c, f)`:
    the measured spectral level, shape and isotropy at the record's height, carried to the
    other heights by the model's height dependence (Kaimal et al. 1972). Above the record's
    Nyquist frequency R holds its mean over the top bin (the measured inertial-subrange
    level). Without a temperature R_theta = 1. The lowest bins hold one coefficient each:
    there the amplitudes are the record's own. The record's own white measurement noise is
    not atmosphere: its expected power is subtracted from the periodogram first (in weak
    turbulence it would otherwise be carried to the other points as high-frequency
    turbulence), keeping at least 10 % of each coefficient's power.

    References
    ----------
    Kaimal et al. (1972); Rinker (2018).
    """
    n_c = coefficients.shape[1]
    f_c = fpos_hz[:n_c]
    top = f_c >= f_c[-1] * 10 ** (-1.0 / bins_per_decade)
    inverse, counts = _log_bins(f_c, bins_per_decade)
    # drawn for every component whether the record has it or not, so that a seed's factors
    # depend on the frequencies only (the probes of a seed share them: common random numbers)
    factors = np.ones((4, counts.size)) if sampling is None else spectral_sampling_factors(counts, sampling)
    amp = spectra.amplitude.copy()
    for i in range(4):
        if not np.all(np.isfinite(coefficients[i])):
            continue
        power = np.abs(coefficients[i]) ** 2
        if noise_power is not None:
            power = np.maximum(power - float(noise_power[i]), 0.1 * power)
        ratio = power / np.maximum(spectra.amplitude[0, i, :n_c] ** 2, 1e-300)
        r = np.full(fpos_hz.size, float(np.mean(ratio[top])) * factors[i, -1])
        r[:n_c] = _log_binned_mean(ratio, f_c, bins_per_decade) * factors[i, inverse]
        amp[:, i] *= np.sqrt(r)[None, :]
    rho_uw = np.empty_like(spectra.rho_uw)
    rho_wt = np.empty_like(spectra.rho_wt)
    for p in range(amp.shape[0]):
        s_u, s_w, s_t = (2 * amp[p, i] ** 2 / df_hz for i in (0, 2, 3))
        sig = spectra.diagnostics["sigmas"][p]
        rho_uw[p] = _scaled_coherency(spectra.co_shape[p], s_u, s_w, df_hz, sig["uw_m2s2"])
        rho_wt[p] = _scaled_coherency(spectra.co_shape[p], s_w, s_t, df_hz, sig["wtheta_kms"])
    return _PointSpectra(amp, rho_uw, rho_wt, spectra.diagnostics, spectra.co_shape)


def constraint_from_record(record: xr.Dataset, period_s: float, fs_hz: float, wind_from_deg: float,
                           mean_window_s: tuple[float, float] | None = None,
                           noise_ms: float = 0.0, temperature_noise_k: float = 0.0) -> ConstraintLatents:
    """The internal constraint of a measured record (the first ``period_s`` of it).

    Parameters
    ----------
    record : xarray.Dataset
        As ``constraint`` of :func:`simulate_wind` (L1 mast names, ``height_m``, optional
        ``x_m, y_m``).
    period_s : float
        Period of the field [s].
    fs_hz : float
        Highest sampling rate of the field [Hz].
    wind_from_deg : float
        Mean wind direction of the field [degree].
    mean_window_s : (float, float), optional
        Seconds from the record's start between which its means are taken (e.g. the hover
        window, so that the field's mean there is the model mean); the whole period by
        default. The record's mean over the period relative to that window becomes the
        ``offset`` of every point's mean.
    noise_ms, temperature_noise_k : float
        Standard deviations of the record's white measurement noise per wind component
        [m s-1] and in temperature [K] (removed from its spectra, :func:`_measured_spectra`).

    Returns
    -------
    ConstraintLatents
    """
    t_s = _constraint_times_s(record)
    series, n_grid, n_missing, offset = _constraint_series(record, t_s, period_s, wind_from_deg,
                                                           None if mean_window_s is None else
                                                           (t_s[0] + mean_window_s[0], t_s[0] + mean_window_s[1]))
    point = np.array([float(record.attrs.get("x_m", 0.0)), float(record.attrs.get("y_m", 0.0)),
                      float(record.attrs["height_m"])])
    coefficients = _constraint_coefficients(series, n_grid, period_s, fs_hz)
    noise = np.array([noise_ms**2, noise_ms**2, noise_ms**2, temperature_noise_k**2], float) / n_grid
    return ConstraintLatents(point=point, coefficients=coefficients, n_freq=coefficients.shape[1] + 1,
                             n_missing=n_missing, offset=offset, noise_power=noise)


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
