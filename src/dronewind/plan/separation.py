r"""How far from the mast the drone may hover: the separation limit from the simulator's coherence.

The drone's series is put on the mast's clock by the peak of the cross-correlation of the
horizontal wind fluctuations (:func:`dronewind.compare.align.align_drone_mast`, Ghirardelli
et al. 2025, Sect. 4.4), so the two points must see correlated turbulence. The forward
simulation's spatial coherence (:func:`dronewind.simulate.spectral_model.coherence`, IEC 61400-1
Ed. 3 Annex B exponential model, effective separation
:math:`\Delta = \sqrt{\Delta_{lat}^2 + \Delta_z^2 + (0.5\Delta_{along})^2}`, Pielke and
Panofsky 1970) and its spectra (:func:`~dronewind.simulate.spectral_model.component_spectra`,
Kaimal et al. 1972) give the largest correlation the two series reach over lags (the Taylor
delay :math:`\Delta_{along}/U` is only a phase):

.. math:: \rho_u(\Delta) = \frac{\int S_u(f)\,\gamma_u(f, \Delta)\, df}{\int S_u(f)\, df}

The limit is the largest cross-wind distance with :math:`\rho_u \ge \rho_{min}`
(``min_correlation`` of the plan, default 0.3: over a 10-min hover the cross-correlation of
about 30 independent integral time scales has a noise of about 0.18, so a peak of 0.3 or more
stands out; the simulator's default position, 36 m from the mast, gives 0.41, and a simulated
flight's alignment found 0.38). Along the wind the coherence weight is 0.5, so twice the
distance is allowed, but the Taylor delay must also stay inside the lag search
(``processing.drone_mast.max_lag_s``, 6 s by default): :math:`\Delta_{along} \le U\,
t_{max}` at the lowest planned speed.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.optimize

__all__ = ["series_correlation", "separation_limit_m", "along_wind_limit_m", "MAX_SEPARATION_M",
           "ALONG_WIND_WEIGHT"]

#: Largest separation searched [m]; a limit beyond it is reported as this.
MAX_SEPARATION_M = 1000.0
#: Weight of the along-wind part of a separation in the coherence (the simulator's, Pielke and
#: Panofsky 1970).
ALONG_WIND_WEIGHT = 0.5


def series_correlation(separation_m: float, height_m: float, speed_ms: float, obukhov_length_m: float,
                       roughness_length_m: float, boundary_layer_height_m: float = 1000.0,
                       component: str = "u") -> float:
    """Correlation of two points' series at an effective separation (module docstring).

    Parameters
    ----------
    separation_m : float
        Effective separation :math:`\\Delta` [m].
    height_m : float
        Height of the pair [m].
    speed_ms : float
        Mean speed at that height [m s-1].
    obukhov_length_m, roughness_length_m, boundary_layer_height_m : float
        Surface-layer parameters [m].
    component : {"u", "v", "w", "theta"}
        Component.

    Returns
    -------
    float
        :math:`\\rho` in [0, 1].
    """
    from dronewind.core.surface_layer import friction_velocity, turbulence_sigmas
    from dronewind.simulate.spectral_model import coherence, component_spectra, spectral_parameters

    ustar = friction_velocity(speed_ms, height_m, roughness_length_m, obukhov_length_m)
    sig = turbulence_sigmas(ustar, height_m, obukhov_length_m, boundary_layer_height_m)
    params = spectral_parameters(sig, ustar, height_m / obukhov_length_m)
    f = np.logspace(-5, math.log10(50.0), 2000)
    s = component_spectra(f, height_m, speed_ms, sig, params)[f"S_{component}"]
    gamma = coherence(f, np.array([float(separation_m)]), speed_ms, height_m, component)[:, 0]
    return float(np.trapezoid(s * gamma, f) / np.trapezoid(s, f))


def separation_limit_m(height_m: float, speed_ms: float, obukhov_length_m: float, roughness_length_m: float,
                       min_correlation: float = 0.3, boundary_layer_height_m: float = 1000.0,
                       vertical_offset_m: float = 0.0) -> float:
    """Largest horizontal cross-wind drone-mast distance with :math:`\\rho_u \\ge` ``min_correlation``.

    Parameters
    ----------
    height_m, speed_ms : float
        Hover height [m] and mean speed there [m s-1].
    obukhov_length_m, roughness_length_m : float
        Surface-layer parameters [m].
    min_correlation : float
        :math:`\\rho_{min}`.
    boundary_layer_height_m : float
        Convective boundary-layer depth [m].
    vertical_offset_m : float
        Height difference between the hover and the mast sonic [m] (it uses up part of the
        effective separation).

    Returns
    -------
    float
        Cross-wind distance [m]; 0 when the vertical offset alone breaks the limit,
        :data:`MAX_SEPARATION_M` when the limit lies beyond it.
    """
    def excess(d_eff: float) -> float:
        return series_correlation(d_eff, height_m, speed_ms, obukhov_length_m, roughness_length_m,
                                  boundary_layer_height_m) - min_correlation

    reach = math.hypot(MAX_SEPARATION_M, vertical_offset_m)
    if excess(reach) >= 0:
        return MAX_SEPARATION_M
    if excess(abs(vertical_offset_m)) < 0:
        return 0.0
    d_eff = scipy.optimize.brentq(excess, abs(vertical_offset_m), reach, xtol=0.05)
    return float(math.sqrt(max(d_eff**2 - vertical_offset_m**2, 0.0)))


def along_wind_limit_m(cross_wind_limit_m: float, lowest_speed_ms: float, max_lag_s: float) -> float:
    """Largest along-wind distance: twice the cross-wind limit, and the Taylor delay inside the lag search.

    Parameters
    ----------
    cross_wind_limit_m : float
        Output of :func:`separation_limit_m` [m].
    lowest_speed_ms : float
        Lowest planned mean speed [m s-1].
    max_lag_s : float
        Half-width of the drone-mast lag search [s].

    Returns
    -------
    float
        Distance [m].
    """
    return float(min(cross_wind_limit_m / ALONG_WIND_WEIGHT, lowest_speed_ms * max_lag_s))
