"""Spectral model of the simulated surface-layer field: point spectra, cross-spectra, spatial coherence.

* Kaimal-type spectral shapes (Kaimal et al. 1972) whose length parameter is solved so that
  each spectrum integrates to its sigma^2 and has the inertial-subrange level set by the
  dissipation rate: S_u -> 0.3 u*^2 phi_eps^(2/3) (z/U)^(-2/3) f^(-5/3), S_v = S_w -> 4/3 S_u
  (local isotropy); the spectral peak thus moves with stability (up in stable, down in
  unstable air);
* coherencies between u and w and between w and theta with Kaimal-type cospectral shape
  (-7/3 inertial slope), scaled so that u'w' = -u*^2 and w'theta' = -u*^3 theta/(kappa g L)
  (Ghirardelli et al. 2025, Eq. 9 inverted), u'theta' = rho_uw rho_wtheta (u and theta
  conditionally independent given w);
* spatial coherence of each component decaying exponentially with separation and frequency
  (IEC 61400-1 Ed. 3 Annex B exponential model, with pyconturb's "iec3d" component length
  scales); the along-wind part of a separation enters the coherence with weight 0.5
  (longitudinal coherence decays about half as fast as lateral, Pielke and Panofsky 1970)
  and, through Taylor's frozen turbulence, as a delay s/U.

Frames: the wind frame has u along the mean wind, v to its left, w up; the mean wind blows
*from* ``wind_from_deg`` (clockwise from north), so its ENU direction unit vector is
(-sin(from), -cos(from)).

References
----------
IEC 61400-1 Ed. 3 (2005), Annex B.
Kaimal, J. C., Wyngaard, J. C., Izumi, Y. and Coté, O. R. (1972), QJRMS 98, 563-589.
Pielke, R. A. and Panofsky, H. A. (1970), Bound.-Layer Meteor. 1, 115-130.
Rinker, J. M. (2018), PyConTurb, J. Phys.: Conf. Ser. 1037, 062032.
Ghirardelli et al. (2025): SAMURAI-S (sling-load sonic), Eq. 9 (Obukhov length).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import TypedDict

import numpy as np

from dronewind.core.angles import deg2rad
from dronewind.core.raw import content_digest
from dronewind.core.surface_layer import (
    dissipation_phi,
    turbulence_sigmas,
)

__all__ = [
    "spectral_parameters",
    "component_spectra",
    "coherence",
    "wind_frame_unit_vectors",
]


#: IEC 61400-1 exponential coherence: decay constant a, b and component length factors
#: (pyconturb "iec3d": L_c scaled by 1, 2.7/8.1, 0.66/8.1 for u, v, w; theta as w).
_COH_A = 12.0


_COH_B = 0.12


_COH_LC_FACTOR = {"u": 1.0, "v": 2.7 / 8.1, "w": 0.66 / 8.1, "theta": 0.66 / 8.1}


_ALONG_WIND_COH_WEIGHT = 0.5


_MAX_COHERENCY = 0.95


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
    share the points and the wind, so their fields use the same factors: of a flight's 40
    fields, half are made and half reused.
    Equal arguments give the same factor, so the draws do not change.
    """
    n_p = key.separation_m.shape[0]
    coh = coherence(key.freq_hz, key.separation_m, key.speed_ms, key.height_m, key.component)  # (nf, n_p, n_p)
    coh += 1e-12 * np.eye(n_p)[None]
    chol = np.linalg.cholesky(coh)
    chol.setflags(write=False)
    return chol


_COMPONENTS = ("u", "v", "w", "theta")


class FieldDiagnostics(TypedDict, total=False):
    """Targets of a field per point: similarity sigmas and fluxes, spectral parameters, z/L."""

    sigmas: list[dict[str, float]]
    spectral_parameters: list[dict[str, float]]
    zeta: list[float]
    advection_speed_ms: float
