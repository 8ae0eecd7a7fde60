r"""Monin-Obukhov surface-layer similarity: stability functions, mean profiles, standard deviations.

Shared by the simulator's turbulent field (:mod:`dronewind.simulate.atmosphere`) and the
diagnosis' forward model (:mod:`dronewind.diagnose.forward`):

* stability corrections :math:`\psi_m(\zeta)`, :math:`\psi_h(\zeta)` (Paulson 1970 / Dyer 1974
  unstable, Beljaars and Holtslag 1991 stable) and the mean speed and potential-temperature
  profiles they give, fixed by the mean speed at a reference height;
* standard deviations of u, v, w and temperature from surface-layer similarity (Panofsky et
  al. 1977; Panofsky and Dutton 1984; Kaimal and Finnigan 1994) and the dimensionless
  dissipation rate :math:`\phi_\epsilon(\zeta)` (Kaimal and Finnigan 1994, Ch. 1, after
  Kaimal et al. 1972).

The Obukhov length follows Ghirardelli et al. (2025), Eq. 9:
:math:`L = -u_*^3 \theta / (\kappa g \overline{w'\theta'})`.

References
----------
Beljaars, A. C. M. and Holtslag, A. A. M. (1991), J. Appl. Meteor. 30, 327-341.
Dyer, A. J. (1974), Bound.-Layer Meteor. 7, 363-372.
Kaimal, J. C., Wyngaard, J. C., Izumi, Y. and Coté, O. R. (1972), QJRMS 98, 563-589.
Kaimal, J. C. and Finnigan, J. J. (1994), Atmospheric Boundary Layer Flows, OUP, Ch. 1-2.
Panofsky, H. A., Tennekes, H., Lenschow, D. H. and Wyngaard, J. C. (1977), BLM 11, 355-361.
Panofsky, H. A. and Dutton, J. A. (1984), Atmospheric Turbulence, Wiley, Ch. 7.
Paulson, C. A. (1970), J. Appl. Meteor. 9, 857-861.
Ghirardelli et al. (2025): SAMURAI-S (sling-load sonic), Eq. 9 (Obukhov length).
"""

from __future__ import annotations

import numpy as np

from dronewind.core.constants import CP_DRY_JKGK, GRAVITY_MS2, KARMAN

__all__ = [
    "psi_m",
    "psi_h",
    "friction_velocity",
    "mean_speed_profile",
    "theta_profile",
    "turbulence_sigmas",
    "dissipation_phi",
]


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
