"""Filtering of raw sonic and INS series: range limits, despiking, gap filling, hover window.

The four public filters implement the data-filtering stage of Ghirardelli et al. (2025), Sect. 3.2:

1. range check against the manufacturer's measurement ranges (:data:`INSTRUMENT_LIMITS`,
   :func:`range_mask`);
2. moving-MAD despiking after Mauder et al. (2013), 10 s window, +/- 7 MAD about the
   moving median (:func:`despike_moving_mad`);
3. linear gap filling when missing + flagged samples are at most 2 % of a record
   (:func:`gap_fill_linear`);
4. the hover window: median altitude +/- 3 m, then +/- 4 m horizontally about the median
   position (:func:`hover_window_mask`).

All functions are pure: they take numpy arrays and return new arrays.
"""

from __future__ import annotations

from typing import Any

import bottleneck as bn
import numpy as np
import numpy.typing as npt

from dronewind.core.geo import local_tangent_plane_m
from dronewind.core.reuse import reused

__all__ = [
    "INSTRUMENT_LIMITS",
    "MAD_TO_SIGMA",
    "despike_moving_mad",
    "gap_fill_linear",
    "hover_window_mask",
    "range_mask",
]

#: Consistency constant of the median absolute deviation for Gaussian data:
#: sigma = MAD / 0.6745 (i.e. 1.4826 MAD). Mauder et al. (2013, Eq. 1) scale the MAD by it.
MAD_TO_SIGMA: float = 1.0 / 0.6745

#: Measurement ranges used as hard limits (Ghirardelli et al. (2025), Sect. 3.2: "filtering thresholds were
#: determined based on the sensor specifications provided by the manufacturers").
#: Each entry maps a quantity to (lower, upper) in the units of its key suffix.
#:
#: * ``rmyoung_81000`` -- RM Young 81000 (Ghirardelli et al. (2025), Table 2): wind speed 0-40 m/s (applied to
#:   the speed |V| and hence to each component), sonic temperature -50..+50 degC, wind
#:   elevation range +/-60 deg (documented; only applied on request because at low speed the
#:   elevation of a swinging payload legitimately exceeds it).
#: * ``sbg_ellipse_d`` -- SBG Ellipse-D. Ghirardelli et al. (2025), Table 3 lists accuracies only, no ranges, so
#:   the limits are the physical domains of the EKF outputs (angles, latitude, longitude) and the
#:   GNSS receiver's operating limits (COCOM: 515 m/s, 18 km altitude); they catch corrupt values,
#:   not a drone's flight envelope.
#: * ``csat3`` -- Campbell CSAT3 manual: +/-65 m/s horizontal (ux, uy), +/-8 m/s vertical (uz),
#:   sonic temperature -30..+50 degC.
#: * ``gill_windmaster_pro`` -- Gill WindMaster Pro (AmeriFlux gold files): 0-65 m/s,
#:   -40..+70 degC.
INSTRUMENT_LIMITS: dict[str, dict[str, Any]] = {
    "rmyoung_81000": {
        "speed_ms": (0.0, 40.0),
        "t_sonic_c": (-50.0, 50.0),
        "elevation_deg": (-60.0, 60.0),
        "source": "Ghirardelli et al. (2025), Table 2 (RM Young 81000 specifications)",
    },
    "sbg_ellipse_d": {
        "roll_deg": (-180.0, 180.0),
        "pitch_deg": (-90.0, 90.0),
        "yaw_deg": (-180.0, 360.0),  # (-180, 180] or [0, 360) conventions both accepted
        "lat_deg": (-90.0, 90.0),
        "lon_deg": (-180.0, 360.0),
        "alt_m": (-500.0, 18000.0),
        "vel_ms": (-515.0, 515.0),
        "source": "Ghirardelli et al. (2025), Table 3 gives accuracies only; physical domains and GNSS (COCOM) "
        "operating limits",
    },
    "csat3": {
        "ux_ms": (-65.0, 65.0),
        "uy_ms": (-65.0, 65.0),
        "uz_ms": (-8.0, 8.0),
        "t_sonic_c": (-30.0, 50.0),
        "source": "Campbell Scientific CSAT3 manual, measurement ranges",
    },
    "trisonica_mini": {
        "speed_ms": (0.0, 50.0),
        "t_sonic_c": (-25.0, 80.0),
        "source": "Anemoment TriSonica Mini specification: wind speed 0-50 m/s, operating temperature -25..+80 degC",
    },
    "gill_windmaster_pro": {
        "speed_ms": (0.0, 65.0),
        "t_sonic_c": (-40.0, 70.0),
        "source": "Gill WindMaster Pro specification: wind speed 0-65 m/s, operating "
        "temperature -40..+70 degC",
    },
}



def range_mask(x: npt.ArrayLike, lower: float, upper: float) -> np.ndarray:
    """Flag values outside an instrument's measurement range.

    Parameters
    ----------
    x : array_like
        Samples [any unit].
    lower, upper : float
        Inclusive range limits [same unit as `x`].

    Returns
    -------
    numpy.ndarray of bool
        True where ``x < lower`` or ``x > upper``. NaN samples are *missing*, not out of
        range, and give False.

    References
    ----------
    Ghirardelli et al. (2025), Sect. 3.2 (range filter from manufacturer specifications).
    """
    arr = np.asarray(x, dtype=float)
    if lower > upper:
        raise ValueError(f"range_mask: lower ({lower}) > upper ({upper})")
    with np.errstate(invalid="ignore"):
        return (arr < lower) | (arr > upper)


def _centred_move_median(x: np.ndarray, half: int, min_count: int) -> np.ndarray:
    """Median over the centred window [i-half, i+half] (NaN ignored, shrinks at the ends).

    bottleneck's move_median is trailing; padding with `half` NaNs on each side and taking
    the trailing window that ends at i+half centres it.
    """
    window = 2 * half + 1
    padded = np.concatenate([np.full(half, np.nan), x, np.full(half, np.nan)])
    med = bn.move_median(padded, window=window, min_count=min_count)
    return med[2 * half :]


def despike_moving_mad(
    x: np.ndarray, fs_hz: float, window_s: float = 10.0, n_mad: float = 7.0
) -> np.ndarray:
    """Detect spikes with a centred moving median and moving median absolute deviation.

    Parameters
    ----------
    x : numpy.ndarray
        Evenly sampled series [any unit]; NaN marks missing samples.
    fs_hz : float
        Sampling rate [Hz].
    window_s : float, optional
        Length of the centred moving window [s]; default 10 s (Ghirardelli et al. (2025), Sect. 3.2). The
        window holds ``2*round(window_s*fs_hz/2) + 1`` samples (odd, so it is centred).
    n_mad : float, optional
        Threshold in units of the *scaled* MAD (MAD/0.6745, the Gaussian-consistent
        standard deviation); default 7 (Mauder et al., 2013).

    Returns
    -------
    numpy.ndarray of bool
        True where ``x`` is a spike. NaN samples are never spikes (they are missing).

    Notes
    -----
    With :math:`m_i` the median of the window centred on sample :math:`i` and
    :math:`\\mathrm{MAD}_i` the moving median (same window) of :math:`|x_j - m_j|`, a
    sample is a spike when

    .. math::

        |x_i - m_i| > q \\, \\frac{\\mathrm{MAD}_i}{0.6745}, \\qquad q = 7 .

    Ghirardelli et al. (2025) (Sect. 3.2) says "a distance of +/-7 MAD from the median" and adopts the method
    of Mauder et al. (2013), whose Eq. 1 bounds the deviation by ``q MAD / 0.6745`` with
    ``q = 7``; we follow Mauder et al. and use the scaled MAD. For Gaussian noise the
    false-positive rate is then P(|z| > 7) = 2.6e-12 per sample. Deviations are taken from
    each sample's own centred median, so MAD_i equals the exact window MAD up to the
    variation of the median inside one window (the usual moving-MAD approximation; it keeps
    the cost O(n log w) with bottleneck's move_median). Where MAD_i is 0 (a stuck or
    constant signal) no sample is flagged: a scale of zero cannot separate spikes from
    quantisation steps. At least half a window of valid samples is required for a median;
    samples without one are not flagged.

    References
    ----------
    Ghirardelli et al. (2025), Sect. 3.2. Mauder, M., et al. (2013): A strategy for quality and uncertainty
    assessment of long-term eddy-covariance measurements, Agric. For. Meteorol. 169,
    122-135, Eq. 1.
    """
    arr = np.asarray(x, dtype=float)
    if arr.ndim != 1:
        raise ValueError(f"despike_moving_mad: x must be 1-D, got shape {arr.shape}")
    if not (fs_hz > 0 and window_s > 0 and n_mad > 0):
        raise ValueError("despike_moving_mad: fs_hz, window_s and n_mad must be positive")
    if arr.size == 0:
        return np.zeros(0, dtype=bool)
    # inside a forward flight's runs, a channel a probe left unchanged is not despiked again
    # (dronewind.core.reuse; the same flags, handed out as a copy)
    flags = reused("despike_moving_mad", {"x": arr}, repr((float(fs_hz), float(window_s), float(n_mad))),
                   lambda: _moving_mad_spikes(arr, fs_hz, window_s, n_mad))
    return flags.copy()


def _moving_mad_spikes(arr: np.ndarray, fs_hz: float, window_s: float, n_mad: float) -> np.ndarray:
    """The spike flags of :func:`despike_moving_mad` for a non-empty, checked 1-D ``arr``."""
    half = max(1, int(round(window_s * fs_hz / 2.0)))
    min_count = half + 1
    med = _centred_move_median(arr, half, min_count)
    dev = np.abs(arr - med)
    mad = _centred_move_median(dev, half, min_count)
    scale = mad * MAD_TO_SIGMA
    with np.errstate(invalid="ignore"):
        spikes = (dev > n_mad * scale) & (scale > 0)
    return np.asarray(spikes & np.isfinite(dev), dtype=bool)


def gap_fill_linear(
    x: np.ndarray, max_missing_fraction: float = 0.02
) -> tuple[np.ndarray, int, bool]:
    """Fill missing (NaN) samples by linear interpolation if few enough are missing.

    Parameters
    ----------
    x : numpy.ndarray
        Evenly sampled series [any unit] in which missing and flagged samples are NaN.
    max_missing_fraction : float, optional
        Largest fraction of NaN samples for which the record is filled and usable;
        default 0.02 (Ghirardelli et al. (2025), Sect. 3.2: "did not exceed 2 %").

    Returns
    -------
    filled : numpy.ndarray
        Copy of `x`, interior NaNs replaced by linear interpolation between the nearest valid
        neighbours and leading/trailing NaNs by the nearest valid value. When the record is
        not usable, an unmodified copy is returned.
    n_filled : int
        Number of samples filled (0 when not usable).
    usable : bool
        False when the NaN fraction exceeds `max_missing_fraction` or no sample is valid.

    Notes
    -----
    For a NaN run between valid samples at indices :math:`a < b`,

    .. math:: x_i = x_a + (x_b - x_a) \\frac{i - a}{b - a}, \\qquad a < i < b .

    References
    ----------
    Ghirardelli et al. (2025), Sect. 3.2.
    """
    arr = np.array(x, dtype=float, copy=True)
    if arr.ndim != 1:
        raise ValueError(f"gap_fill_linear: x must be 1-D, got shape {arr.shape}")
    n = arr.size
    missing = ~np.isfinite(arr)
    n_missing = int(missing.sum())
    if n == 0 or n_missing == n:
        return arr, 0, False
    if n_missing / n > max_missing_fraction:
        return arr, 0, False
    if n_missing == 0:
        return arr, 0, True
    idx = np.arange(n)
    valid = ~missing
    arr[missing] = np.interp(idx[missing], idx[valid], arr[valid])
    return arr, n_missing, True



def hover_window_mask(
    alt_m: npt.ArrayLike,
    lat_deg: npt.ArrayLike,
    lon_deg: npt.ArrayLike,
    alt_tol_m: float = 3.0,
    horiz_tol_m: float = 4.0,
) -> np.ndarray:
    """Samples belonging to the hover: median altitude +/- 3 m, then +/- 4 m horizontally.

    Parameters
    ----------
    alt_m : array_like
        Altitude [m].
    lat_deg, lon_deg : array_like
        Position [degrees_north, degrees_east].
    alt_tol_m : float, optional
        Half-width of the altitude band about the median altitude [m]; default 3 m.
    horiz_tol_m : float, optional
        Half-width of the horizontal box about the median position, applied separately to the
        east and north offsets [m]; default 4 m.

    Returns
    -------
    numpy.ndarray of bool
        True for samples inside the hover window; NaN positions give False.

    Notes
    -----
    Two steps (Ghirardelli et al. (2025), Sect. 3.2). Step 1 keeps :math:`|z_i - \\tilde z| \\le 3` m with
    :math:`\\tilde z` the median altitude of all valid samples. Step 2 takes the median
    latitude and longitude of the samples kept in step 1, converts positions to east/north
    offsets (:func:`local_tangent_plane_m`) and keeps
    :math:`|\\Delta e_i| \\le 4` m and :math:`|\\Delta n_i| \\le 4` m (the "+/-4 m" of the
    paper read as a box on each horizontal axis).

    References
    ----------
    Ghirardelli et al. (2025), Sect. 3.2.
    """
    alt = np.asarray(alt_m, dtype=float)
    lat = np.asarray(lat_deg, dtype=float)
    lon = np.asarray(lon_deg, dtype=float)
    if not (alt.shape == lat.shape == lon.shape) or alt.ndim != 1:
        raise ValueError(
            f"hover_window_mask: alt_m, lat_deg, lon_deg must be 1-D of equal length, got "
            f"{alt.shape}, {lat.shape}, {lon.shape}"
        )
    valid = np.isfinite(alt) & np.isfinite(lat) & np.isfinite(lon)
    mask = np.zeros(alt.shape, dtype=bool)
    if not valid.any():
        return mask
    alt_med = float(np.median(alt[valid]))
    step1 = valid & (np.abs(alt - alt_med) <= alt_tol_m)
    if not step1.any():
        return mask
    lat0 = float(np.median(lat[step1]))
    lon0 = float(np.median(lon[step1]))
    east_m, north_m = local_tangent_plane_m(lat, lon, lat0, lon0)
    with np.errstate(invalid="ignore"):
        step2 = (np.abs(east_m) <= horiz_tol_m) & (np.abs(north_m) <= horiz_tol_m)
    return step1 & step2
