r"""Predicted random uncertainty of a hover's statistics before it is flown.

The expected turbulence at the hover point is the forward simulation's own: the
Monin-Obukhov profile, the similarity sigmas and the Kaimal spectra of
:mod:`dronewind.simulate.atmosphere` (:func:`~dronewind.simulate.atmosphere.simulate_wind`
at one point, for a long record). From that record the planner takes, per quantity, the
product series :math:`\phi` (:func:`dronewind.core.uncertainty.product_series`), its
integral time scale :math:`T_\phi` (:func:`dronewind.core.scales.integral_time_scale`, the
exponential fit of Ghirardelli et al. 2025, Eqs 14-15) and its normalised variance, and
gives the relative random error of a hover of duration :math:`\tau` by
:func:`dronewind.core.uncertainty.relative_random_error` (Lumley and Panofsky 1964, the
basis of Ghirardelli et al. 2025, Eqs 10-13):

.. math:: \epsilon_\phi^2(\tau) = \frac{2T_\phi}{\tau}\,
          \frac{\overline{\phi^2} - \bar\phi^2}{N^2}

with :math:`N = \bar\phi` (variances, :math:`w'\theta'`) or :math:`u_*^2` (momentum flux).
The statistics a campaign reports are square roots of two of these:
:math:`\epsilon(\sigma_w) = \epsilon_{w'^2}/2` and :math:`\epsilon(u_*) = \epsilon_{u'w'}/2`
(first order); :math:`\epsilon(\overline{w'\theta'}) = \epsilon_{w'\theta'}`. The needed hover
follows from :math:`\epsilon \propto \tau^{-1/2}`.

The published metric (Ghirardelli et al. 2025, Eqs 10-13, :math:`T_\phi` replaced by
:math:`z/\bar u`) is :func:`PointUncertainty.paper`, from
:func:`dronewind.core.uncertainty.paper_uncertainty` on the same record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dronewind.core.scales import integral_time_scale
from dronewind.core.uncertainty import paper_uncertainty, product_series, relative_random_error
from dronewind.errors import InputError

__all__ = ["PointUncertainty", "point_uncertainty", "RECORD_S", "RECORD_FS_HZ", "DURATION_STEP_S"]

#: Length of the model record the time scales are taken from [s]: 4 h, about 1000 integral
#: time scales of w'^2 at 30 m and 2 m/s, so the exponential fit's own scatter stays a few %.
RECORD_S = 14400.0
#: Its sampling rate [Hz]: the rate of the compared L3 series (:mod:`dronewind.compare.chain`).
RECORD_FS_HZ = 8.0
#: Hover durations are rounded up to whole multiples of this [s].
DURATION_STEP_S = 30.0


@dataclass(frozen=True)
class PointUncertainty:
    """Time scales and normalised variances of the product series at one hover point.

    Attributes
    ----------
    height_m, speed_ms : float
        Hover height [m] and mean speed there [m s-1].
    time_scale_s : dict
        Quantity -> integral time scale of its product series :math:`T_\\phi` [s].
    normalised_variance : dict
        Quantity -> :math:`(\\overline{\\phi^2} - \\bar\\phi^2)/N^2` [1].
    paper_a : dict
        Ghirardelli et al. (2025) metric per product (``uw, vw, wtheta, u2, v2, w2``) for a
        hover of :attr:`paper_duration_s` (Eqs 10-13).
    paper_duration_s : float
        Duration of :attr:`paper_a` [s].
    """

    height_m: float
    speed_ms: float
    time_scale_s: dict[str, float]
    normalised_variance: dict[str, float]
    paper_a: dict[str, float]
    paper_duration_s: float

    def relative(self, duration_s: float) -> dict[str, float]:
        """Relative random error of each statistic for a hover of ``duration_s`` [1].

        Returns
        -------
        dict
            ``sigma_u, sigma_w, u_star, w_theta`` (module docstring).
        """
        if not duration_s > 0:
            raise InputError("duration_s", f"expected a positive hover duration, got {duration_s}")
        eps = {q: math.sqrt(2.0 * self.time_scale_s[q] / duration_s * self.normalised_variance[q])
               for q in self.time_scale_s}
        return {"sigma_u": eps["u2"] / 2.0, "sigma_w": eps["w2"] / 2.0, "u_star": eps["uw"] / 2.0,
                "w_theta": eps["wtheta"]}

    def duration_for(self, targets: dict[str, float]) -> float:
        """Shortest hover meeting every target [s], rounded up to :data:`DURATION_STEP_S`.

        Parameters
        ----------
        targets : dict
            Quantity -> largest relative uncertainty [1].

        Returns
        -------
        float
            Duration [s]; at least one step.
        """
        ref = self.relative(1.0)  # epsilon at 1 s; epsilon(tau) = epsilon(1 s) / sqrt(tau)
        need = max([(ref[q] / t) ** 2 for q, t in targets.items()] or [DURATION_STEP_S])
        return DURATION_STEP_S * max(1.0, math.ceil(need / DURATION_STEP_S - 1e-9))

    def paper(self, duration_s: float) -> dict[str, float]:
        """Ghirardelli et al. (2025) metric a (Eqs 10-13) for a hover of ``duration_s``.

        The metric scales as :math:`\\tau^{-1/2}` (Eqs 10-13), so it is rescaled from
        :attr:`paper_a`.
        """
        return {k: v * math.sqrt(self.paper_duration_s / duration_s) for k, v in self.paper_a.items()}


def point_uncertainty(height_m: float, speed_ms: float, wind_from_deg: float, obukhov_length_m: float,
                      roughness_length_m: float, boundary_layer_height_m: float = 1000.0,
                      theta_mean_k: float = 288.15, seed: int = 0) -> PointUncertainty:
    """Time scales and normalised variances at a hover point, from the simulator's turbulence.

    Parameters
    ----------
    height_m : float
        Hover height [m].
    speed_ms : float
        Mean wind speed at the hover height [m s-1].
    wind_from_deg : float
        Wind direction [degree from north].
    obukhov_length_m : float
        Obukhov length L [m].
    roughness_length_m : float
        z0 [m].
    boundary_layer_height_m : float
        Convective boundary-layer depth [m] (unstable sigmas).
    theta_mean_k : float
        Mean temperature [K].
    seed : int
        Seed of the model record.

    Returns
    -------
    PointUncertainty

    Notes
    -----
    Ghirardelli et al. (2025), Eqs 10-15; Lumley and Panofsky (1964). The record is a single
    point of :func:`dronewind.simulate.atmosphere.simulate_wind` (Kaimal et al. 1972 spectra,
    similarity sigmas), RECORD_S long at RECORD_FS_HZ.
    """
    from dronewind.simulate.atmosphere import simulate_wind
    from dronewind.simulate.spectral_model import wind_frame_unit_vectors

    ds = simulate_wind(np.array([[0.0, 0.0, float(height_m)]]), RECORD_S, RECORD_FS_HZ, float(speed_ms),
                       float(wind_from_deg), float(height_m), float(obukhov_length_m), float(roughness_length_m),
                       seed=int(seed), theta_mean_k=float(theta_mean_k),
                       boundary_layer_height_m=float(boundary_layer_height_m))
    e_u, e_v = wind_frame_unit_vectors(float(wind_from_deg))
    east, north = ds["u_east_ms"].values[0], ds["v_north_ms"].values[0]
    u = east * e_u[0] + north * e_u[1]
    v = east * e_v[0] + north * e_v[1]
    w, theta = ds["w_up_ms"].values[0], ds["theta_v_k"].values[0]
    phi = {"u2": product_series(u), "w2": product_series(w), "uw": product_series(u, w),
           "vw": product_series(v, w), "wtheta": product_series(w, theta)}
    ustar2 = math.hypot(float(np.mean(phi["uw"])), float(np.mean(phi["vw"])))
    norm = {"u2": None, "w2": None, "uw": ustar2, "wtheta": None}
    scales, nvar = {}, {}
    for q in ("u2", "w2", "uw", "wtheta"):
        its = integral_time_scale(phi[q], RECORD_FS_HZ, method="constant")
        if not its.converged:
            raise InputError(f"point_uncertainty({q})", f"integral time scale of the model record: {its.reason}")
        # relative_random_error at tau = 2 T gives sqrt(var)/N: the normalised variance's root
        ref = relative_random_error(phi[q], 2.0 * its.time_scale_s, its.time_scale_s, normaliser=norm[q])
        scales[q] = float(its.time_scale_s)
        nvar[q] = float(ref.value) ** 2
    paper = {
        "uw": paper_uncertainty(phi["uw"], height_m, RECORD_S, speed_ms, ustar2).value,
        "vw": paper_uncertainty(phi["vw"], height_m, RECORD_S, speed_ms, ustar2).value,
        "wtheta": paper_uncertainty(phi["wtheta"], height_m, RECORD_S, speed_ms,
                                    float(np.mean(phi["wtheta"]))).value,
        "u2": paper_uncertainty(phi["u2"], height_m, RECORD_S, speed_ms, float(np.mean(phi["u2"])), True).value,
        "v2": paper_uncertainty(product_series(v), height_m, RECORD_S, speed_ms, float(np.var(v)), True).value,
        "w2": paper_uncertainty(phi["w2"], height_m, RECORD_S, speed_ms, float(np.mean(phi["w2"])), True).value,
    }
    return PointUncertainty(float(height_m), float(speed_ms), scales, nvar, {k: float(v) for k, v in paper.items()},
                            RECORD_S)
