r"""Random (sampling) uncertainty of variances and fluxes (Ghirardelli et al. (2025), Sect. 4.2, Eqs 10-13).

Two forms are provided.

* :func:`paper_uncertainty` is the published normalised metric: the integral time scale
  of the product series is replaced by the surface-layer scale :math:`z/\bar u`
  (Wyngaard 1973; Stiperski and Rotach 2016), with a factor 4 for variances (Eq. 13).
  Ghirardelli et al. (2025) (Sect. 5.3, Fig. 16) calls values below 0.5 "low statistical uncertainty".
* :func:`relative_random_error` is the general ergodic estimate it comes from
  (Lumley and Panofsky 1964): the relative standard error of the time mean of a product
  series :math:`\phi` (:math:`\phi = \xi'^2` for a variance, :math:`a'b'` for a flux)
  with its *measured* integral time scale :math:`T_\phi` (from
  :func:`dronewind.core.scales.integral_time_scale`). This one can be checked by Monte Carlo.

The extracted text of Eqs 10-12 is garbled (overbars lost). We read the numerator as the
mean of the squared product (the only reading that gives a non-negative quantity), i.e.
:math:`\overline{(a'b')^2}/N^2 - 1` with normaliser :math:`N = u_*^2` (Eqs 10-11) or
:math:`\overline{w'\theta_v'}` (Eq. 12), and implement it as the product-series variance
:math:`(\overline{\phi^2} - \bar\phi^2)/N^2`. This equals the printed form for Eqs 10 (when
:math:`\overline{v'w'} = 0`, so that :math:`u_*^2 = |\overline{u'w'}|`), 12 and 13.

Eq. 11 (:math:`a_{vw}`) is the exception. Printed, it reads
:math:`a_{vw}^2 = \frac{z}{\tau\bar u}\left(\overline{(v'w')^2}/u_*^4 - 1\right)`: the "-1" is
:math:`\overline{u'w'}^2/u_*^4` of Eq. 10 carried over, and for the cross-wind flux it is not
the squared mean of the product series, so the printed quantity is no variance (it is even
negative when :math:`\overline{(v'w')^2} < u_*^4`, i.e. a weak cross-wind component under a
strong momentum flux). The code
computes the variance of the :math:`v'w'` series,
:math:`a_{vw}^2 = \frac{z}{\tau\bar u}\,\left(\overline{(v'w')^2} - \overline{v'w'}^2\right)/u_*^4`,
which exceeds the printed form by :math:`1 - \overline{v'w'}^2/u_*^4` (between 0 and 1 in the
bracket). The two agree only when :math:`\overline{v'w'}^2 = u_*^4`.

References
----------
.. [1] Ghirardelli et al. (2025), Sect. 4.2, Eqs 10-13; Sect. 5.3.
.. [2] Lumley, J. L. and Panofsky, H. A.: The Structure of Atmospheric Turbulence, 1964.
.. [3] Stiperski, I. and Rotach, M. W.: Boundary-Layer Meteorol. 159, 97-121, 2016.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dronewind.core.scales import integral_time_scale
from dronewind.core.stats import Detrend, fluctuation
from dronewind.errors import InputError

__all__ = [
    "QUALITY_THRESHOLD",
    "RandomError",
    "paper_uncertainty",
    "product_series",
    "relative_random_error",
]

#: Ghirardelli et al. (2025), Sect. 4.2: normalised uncertainties below this indicate high quality.
QUALITY_THRESHOLD: float = 0.5


@dataclass(frozen=True)
class RandomError:
    """A random-error estimate with its quality flag.

    Attributes
    ----------
    value : float
        The normalised uncertainty (``a`` of Eqs 10-13, or relative standard error) [1].
    below_threshold : bool
        ``value < QUALITY_THRESHOLD`` (False when NaN).
    time_scale_s : float
        Integral time scale of the product series used [s] (z/U for the paper form).
    reason : str
        Empty when defined, else why the value is NaN.
    """

    value: float
    below_threshold: bool
    time_scale_s: float
    reason: str = ""


def product_series(
    a: np.ndarray, b: np.ndarray | None = None, method: Detrend = "linear"
) -> np.ndarray:
    r"""Product series :math:`\phi = a'b'` whose time mean is the flux (or variance).

    Parameters
    ----------
    a : array-like
        First series [unit a].
    b : array-like, optional
        Second series [unit b]; ``None`` gives :math:`\phi = a'^2` (variance).
    method : {"linear", "constant", "none"}
        Detrending of ``a`` and ``b`` (see :func:`dronewind.core.stats.fluctuation`).

    Returns
    -------
    numpy.ndarray
        :math:`\phi(t)` [unit a × unit b].
    """
    ap = fluctuation(np.asarray(a, dtype=float), method)
    if b is None:
        return ap * ap
    bb = np.asarray(b, dtype=float)
    if bb.shape != ap.shape:
        raise InputError("product_series(a, b)", f"shapes differ: {ap.shape} vs {bb.shape}")
    return ap * fluctuation(bb, method)


def _flag(value: float, time_scale_s: float, reason: str = "") -> RandomError:
    ok = bool(np.isfinite(value) and value < QUALITY_THRESHOLD)
    return RandomError(float(value), ok, float(time_scale_s), reason)


def relative_random_error(
    phi: np.ndarray,
    duration_s: float,
    time_scale_s: float | None = None,
    fs_hz: float | None = None,
    normaliser: float | None = None,
) -> RandomError:
    r"""Relative random error of the time mean of a product series (ergodic estimate).

    Parameters
    ----------
    phi : array-like
        Product series, e.g. from :func:`product_series` [any unit].
    duration_s : float
        Averaging time :math:`\tau` [s].
    time_scale_s : float, optional
        Integral time scale :math:`T_\phi` of ``phi`` [s]. If omitted it is estimated
        with :func:`dronewind.core.scales.integral_time_scale` (needs ``fs_hz``).
    fs_hz : float, optional
        Sampling rate [Hz], needed when ``time_scale_s`` is omitted.
    normaliser : float, optional
        Scale the error is relative to [unit of ``phi``]; default the mean of ``phi``.
        Use :math:`u_*^2` for momentum fluxes (as Eqs 10-11 do), so that a near-zero
        :math:`\overline{v'w'}` does not blow the ratio up.

    Returns
    -------
    RandomError
        :math:`\epsilon` [1] with the 0.5 quality flag; NaN with a reason if the mean of
        ``phi`` is 0 or the time scale is undefined.

    Notes
    -----
    Lumley and Panofsky (1964), the basis of Ghirardelli et al. (2025), Eqs 10-13:

    .. math:: \epsilon^2 = \frac{2 T_\phi}{\tau}\,
              \frac{\overline{\phi^2} - \bar\phi^2}{N^2}, \quad N = \bar\phi
              \ \text{(default)}

    For a variance of a Gaussian process (:math:`\phi = \xi'^2`, kurtosis 3) this is
    :math:`(2T_\phi/\tau)\cdot 2`; with :math:`T_\phi` replaced by :math:`2z/\bar u`
    it becomes Eq. 13.
    """
    p = np.asarray(phi, dtype=float)
    if p.ndim != 1 or p.size < 8 or not np.all(np.isfinite(p)):
        return _flag(np.nan, np.nan, "product series shorter than 8 finite samples or has NaN")
    if not duration_s > 0:
        raise InputError("relative_random_error(duration_s)", f"expected a positive duration, got {duration_s}")
    if time_scale_s is None:
        if fs_hz is None:
            raise InputError("relative_random_error(fs_hz)", "needed when time_scale_s is not given")
        its = integral_time_scale(p, fs_hz, method="constant")
        if not its.converged:
            return _flag(np.nan, np.nan, f"integral time scale of product series: {its.reason}")
        time_scale_s = its.time_scale_s
    mean = float(np.mean(p))
    var = float(np.mean(p * p) - mean * mean)
    norm = mean if normaliser is None else float(normaliser)
    # a mean below 1e-12 of the rms of phi is zero up to rounding (hand-written guard)
    if not (np.isfinite(norm) and abs(norm) > 1e-12 * np.sqrt(np.mean(p * p))):
        return _flag(np.nan, time_scale_s, "normaliser (mean of product series by default) is zero or NaN")
    eps2 = 2.0 * time_scale_s / duration_s * var / norm**2
    return _flag(float(np.sqrt(max(eps2, 0.0))), time_scale_s)


def paper_uncertainty(
    phi: np.ndarray,
    height_m: float,
    duration_s: float,
    speed_ms: float,
    normaliser: float,
    variance: bool = False,
) -> RandomError:
    r"""Normalised uncertainty metric of Ghirardelli et al. (2025), Eqs 10-13.

    Parameters
    ----------
    phi : array-like
        Product series :math:`\phi` (:math:`u'w'`, :math:`v'w'`, :math:`w'\theta_v'` or
        :math:`\xi'^2`) [any unit].
    height_m : float
        Measurement height :math:`z` [m].
    duration_s : float
        Averaging time :math:`\tau` [s].
    speed_ms : float
        Mean wind speed :math:`\bar u` [m s-1].
    normaliser : float
        :math:`u_*^2` for Eqs 10-11 [m2 s-2], :math:`\overline{w'\theta_v'}` for Eq. 12
        [K m s-1], :math:`\overline{\xi'^2}` for Eq. 13.
    variance : bool, optional
        True for Eq. 13 (factor 4).

    Returns
    -------
    RandomError
        ``a`` [1] (the square root of :math:`a^2`), flag ``a < 0.5``; ``time_scale_s``
        holds :math:`z/\bar u`. NaN with a reason for :math:`\bar u \le 0` or a zero
        normaliser.

    Notes
    -----
    .. math::
       a_{uw}^2 = \frac{z}{\tau\bar u}\,\frac{\overline{\phi^2}-\bar\phi^2}{u_*^4},\quad
       a_{vw}^2 = \frac{z}{\tau\bar u}\,\frac{\overline{(v'w')^2}-\overline{v'w'}^2}{u_*^4},\quad
       a_{\theta_v w}^2 = \frac{z}{\tau\bar u}
            \left(\frac{\overline{(w'\theta_v')^2}}{\overline{w'\theta_v'}^2} - 1\right),\quad
       a_{\xi^2}^2 = \frac{4z}{\tau\bar u}
            \left(\frac{\overline{\xi'^4}}{\overline{\xi'^2}^2} - 1\right)

    (Eqs 10-13; see the module note on the garbled numerators.) For Eq. 11 this is the variance
    of the :math:`v'w'` product series; the printed Eq. 11 subtracts 1 instead of
    :math:`\overline{v'w'}^2/u_*^4` and is not a variance (module note).
    """
    p = np.asarray(phi, dtype=float)
    if p.ndim != 1 or p.size < 2 or not np.all(np.isfinite(p)):
        return _flag(np.nan, np.nan, "product series shorter than 2 finite samples or has NaN")
    if not (np.isfinite(speed_ms) and speed_ms > 0):
        return _flag(np.nan, np.nan, f"mean speed {speed_ms} m/s not positive: z/U undefined")
    if not (np.isfinite(normaliser) and normaliser != 0):
        return _flag(np.nan, height_m / speed_ms, "normaliser is zero or NaN")
    if not (height_m > 0 and duration_s > 0):
        raise InputError("paper_uncertainty(height_m, duration_s)", "expected positive height and duration")
    mean = float(np.mean(p))
    var = float(np.mean(p * p) - mean * mean)
    factor = 4.0 if variance else 1.0
    a2 = factor * height_m / (duration_s * speed_ms) * var / normaliser**2
    return _flag(float(np.sqrt(max(a2, 0.0))), height_m / speed_ms)
