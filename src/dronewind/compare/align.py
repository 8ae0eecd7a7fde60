"""Drone-to-mast alignment: the L3 builder.

:func:`align_drone_mast` takes the payload L2 (drone) and the mast sonic over the flight and
returns both sensors aligned, on a common 8 Hz base and in streamline coordinates
(Ghirardelli et al. (2025), Sect. 4.4). Its steps, each a function of this module:

1. :func:`drone_mast_lag` -- advection lag by maximum cross-correlation of the horizontal
   wind fluctuations on a common 32 Hz base over the overlap;
2. a common 32 Hz grid over the window shared by the mast and the lag-shifted drone;
3. FIR anti-alias filter (:func:`design_antialias_fir`) and decimation to 8 Hz
   (:func:`fir_decimate`);
4. wind direction and rotation into streamline coordinates per sensor
   (:mod:`dronewind.core.rotation`).

Sign convention (``docs/data-contract.md``): ``lag_drone_mast_s`` is the time ADDED to the drone's stamps
to align them with the mast; it is positive when the drone sees a structure first (drone
upwind of the mast).

Times are handled as float seconds since the first time stamp of the inputs (int64
nanoseconds are subtracted before conversion, so a flight keeps sub-microsecond
resolution).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.signal
import xarray as xr

from dronewind.core import rotation as rot
from dronewind.core import stats
from dronewind.core.angles import rad2deg
from dronewind.core.cf import variable
from dronewind.core.timeseries import NS_PER_S, require_variables, time_ns
from dronewind.errors import InputError, ProcessingError

__all__ = [
    "design_antialias_fir",
    "fir_response",
    "fir_decimate",
    "drone_mast_lag",
    "align_drone_mast",
    "input_rate_hz",
]

_NS = NS_PER_S
_ENU_VARS = ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k")


# ------------------------------------------------------------------------ FIR decimation


def default_passband_edge_hz(fs_out_hz: float) -> float:
    """End of the anti-alias filter's passband: 0.75 of the output Nyquist frequency [Hz] (3 Hz at 8 Hz).

    The one definition used by the filter design and stored in L3 (``fir_passband_edge_hz``),
    where the L4 spectral fits stop.
    """
    return float(0.75 * (fs_out_hz / 2.0))


def design_antialias_fir(
    fs_in_hz: float = 32.0,
    decimate: int = 4,
    passband_edge_hz: float | None = None,
    stopband_edge_hz: float | None = None,
    attenuation_db: float = 60.0,
) -> np.ndarray:
    """Linear-phase FIR low-pass used before decimation (Kaiser-window design).

    Parameters
    ----------
    fs_in_hz : float
        Input rate [Hz]; default 32 Hz.
    decimate : int
        Decimation factor; default 4 (Ghirardelli et al. (2025), Sect. 4.4: 32 Hz -> 8 Hz).
    passband_edge_hz : float, optional
        End of the passband [Hz]; default 0.75 x the output Nyquist (3 Hz at 8 Hz).
    stopband_edge_hz : float, optional
        Start of the stopband [Hz]; default the output Nyquist (4 Hz at 8 Hz).
    attenuation_db : float
        Stopband attenuation and passband ripple specification [dB]; default 60 dB.

    Returns
    -------
    numpy.ndarray
        Odd number of symmetric taps (123 for the defaults), unit DC gain.

    Notes
    -----
    Design (defaults): Kaiser window, beta = 5.65 from :func:`scipy.signal.kaiserord` for
    60 dB and the 1 Hz transition 3-4 Hz, cutoff at the transition centre (3.5 Hz, gain
    0.5 = -6 dB), :func:`scipy.signal.firwin`; the length from Kaiser's formula (119) is
    increased by 2 taps until the stopband maximum measured with
    :func:`scipy.signal.freqz` meets the specification: 123 taps (3.8 s). Measured:
    passband (0-3 Hz) deviation <= 0.094 %, stopband (4-16 Hz) attenuation >= 60.4 dB. Applied as a
    centred convolution (group delay removed), i.e. zero phase in a single pass. The band
    3-4 Hz of the 8 Hz output is the transition band: spectra there are attenuated
    (and 4-5 Hz partly aliases into it). Ghirardelli et al. (2025) mentions an "FIR filter of order 4";
    a 4th-order FIR cannot give a useful anti-alias stopband, so this design replaces it.

    References
    ----------
    Ghirardelli et al. (2025), Sect. 4.4; Kaiser (1974); scipy.signal.kaiserord / firwin.
    """
    return _antialias_taps(float(fs_in_hz), decimate, passband_edge_hz, stopband_edge_hz,
                           float(attenuation_db)).copy()


@functools.lru_cache(maxsize=16)
def _antialias_taps(fs_in_hz: float, decimate: int, passband_edge_hz: float | None, stopband_edge_hz: float | None,
                    attenuation_db: float) -> np.ndarray:
    """:func:`design_antialias_fir`'s design, made once per setting (read-only taps).

    Every L3 alignment needs the taps and a forward run makes one alignment per probe: a
    flight's 36 designs (firwin and three response checks) of the same taps are a noticeable
    part of its forward runs' time. The same arguments give the same taps.
    """
    if decimate < 1 or int(decimate) != decimate:
        raise InputError("decimate", f"expected a positive integer, got {decimate!r}")
    nyq_out = fs_in_hz / decimate / 2.0
    f_stop = nyq_out if stopband_edge_hz is None else float(stopband_edge_hz)
    f_pass = default_passband_edge_hz(2.0 * nyq_out) if passband_edge_hz is None else float(passband_edge_hz)
    if not (0 < f_pass < f_stop <= fs_in_hz / 2):
        raise InputError("design_antialias_fir", f"need 0 < passband edge {f_pass} < stopband edge {f_stop} <= "
                         f"{fs_in_hz / 2} Hz")
    numtaps, beta = scipy.signal.kaiserord(attenuation_db, (f_stop - f_pass) / (fs_in_hz / 2.0))
    numtaps |= 1  # odd length: integer group delay, type I linear phase
    f_check = np.linspace(f_stop, fs_in_hz / 2.0, 2049)
    limit = 10.0 ** (-attenuation_db / 20.0)
    for _ in range(50):  # Kaiser's formula is approximate: lengthen until the spec is met
        taps = scipy.signal.firwin(numtaps, 0.5 * (f_pass + f_stop), window=("kaiser", beta), fs=fs_in_hz)
        if fir_response(taps, fs_in_hz, f_check).max() <= limit:
            break
        numtaps += 2
    taps.setflags(write=False)
    return taps


def fir_response(taps: np.ndarray, fs_hz: float, freq_hz: np.ndarray) -> np.ndarray:
    """Amplitude response |H(f)| of an FIR filter at the given frequencies.

    Parameters
    ----------
    taps : numpy.ndarray
        Filter coefficients.
    fs_hz : float
        Sampling rate [Hz].
    freq_hz : numpy.ndarray
        Frequencies [Hz].

    Returns
    -------
    numpy.ndarray
        |H(f)| [-].
    """
    _, h = scipy.signal.freqz(taps, worN=np.asarray(freq_hz, dtype=float), fs=fs_hz)
    return np.abs(h)


def fir_decimate(x: np.ndarray, taps: np.ndarray, factor: int, phase: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Zero-phase FIR low-pass and decimation, without padding (edges trimmed).

    Parameters
    ----------
    x : numpy.ndarray
        (n, ...) regularly sampled, finite series (filtered along axis 0).
    taps : numpy.ndarray
        Odd-length symmetric FIR taps (:func:`design_antialias_fir`).
    factor : int
        Decimation factor.
    phase : int
        Output samples are the input indices ``k`` with ``k % factor == phase``.

    Returns
    -------
    y : numpy.ndarray
        Filtered, decimated series.
    index : numpy.ndarray
        Input indices of the output samples (all at least ``(len(taps) - 1) / 2`` from either
        end, so no output depends on padding).

    Notes
    -----
    .. math:: y_m = \\sum_{k=-K}^{K} h_k\\, x_{i_m - k}, \\qquad K = (N_{taps} - 1)/2 .
    """
    taps = np.asarray(taps, dtype=float)
    if taps.size % 2 != 1:
        raise InputError("taps", "expected an odd number of FIR taps")
    half = taps.size // 2
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    first = half + ((phase - half) % factor)
    index = np.arange(first, n - half, factor)
    if index.size == 0:
        raise InputError("x", f"series of {n} samples shorter than the FIR filter ({taps.size} taps)")
    kernel = taps.reshape((-1,) + (1,) * (x.ndim - 1))
    full = scipy.signal.fftconvolve(x, kernel, mode="valid", axes=0)  # full[i] centred on x[i + half]
    return full[index - half], index


def drone_mast_lag(
    drone_u_ms: np.ndarray,
    drone_v_ms: np.ndarray,
    mast_u_ms: np.ndarray,
    mast_v_ms: np.ndarray,
    fs_hz: float,
    max_lag_s: float = 6.0,
) -> tuple[float, np.ndarray, np.ndarray, bool]:
    """Advection lag between drone and mast from the horizontal wind fluctuations.

    Parameters
    ----------
    drone_u_ms, drone_v_ms, mast_u_ms, mast_v_ms : numpy.ndarray
        East and north wind of both sensors on the same regular time base [m s-1],
        finite, equal length n.
    fs_hz : float
        Sampling rate of the common base [Hz].
    max_lag_s : float
        Largest lag searched [s]; default 6 s (Ghirardelli et al. (2025), Sect. 4.4).

    Returns
    -------
    lag_drone_mast_s : float
        Time to add to the drone's stamps to align them with the mast [s], positive when
        the drone sees a structure first; parabolic refinement of the correlation peak,
        so it is not restricted to the grid.
    lag_grid_s : numpy.ndarray
        Lags of the search grid [s].
    xcorr : numpy.ndarray
        Normalised cross-correlation of the horizontal fluctuation vector at each lag [-].
    at_edge : bool
        True if the maximum is at the edge of the search range.

    Notes
    -----
    Fluctuations are linearly detrended per component. Both horizontal components
    enter (a vector correlation, independent of the wind direction and of the sign of
    the mean), with the drone's central part (ends of ``max_lag_s`` removed) held fixed
    so every lag uses the same drone samples:

    .. math::

        r(\\tau_j) = \\frac{\\sum_k u'_d(t_k) u'_m(t_k+\\tau_j) + v'_d(t_k) v'_m(t_k+\\tau_j)}
        {\\sqrt{\\sum_k (u'^2_d + v'^2_d)(t_k)\\; \\sum_k (u'^2_m + v'^2_m)(t_k + \\tau_j)}} .

    The peak is refined by a parabola through its two neighbours.

    References
    ----------
    Ghirardelli et al. (2025), Sect. 4.4 ("maximises the cross-correlation of the horizontal velocity
    fluctuations", up to 6 s).
    """
    arrays = [np.asarray(a, dtype=float) for a in (drone_u_ms, drone_v_ms, mast_u_ms, mast_v_ms)]
    n = arrays[0].size
    if any(a.shape != (n,) for a in arrays) or not all(np.isfinite(a).all() for a in arrays):
        raise InputError("drone_mast_lag", "expected four finite 1-D series of equal length on a common base")
    n_half = int(round(max_lag_s * fs_hz))
    if n <= 4 * n_half + 8:
        raise InputError("drone_mast_lag",
                         f"common record of {n / fs_hz:.1f} s too short for a +/-{max_lag_s} s search")
    xcorr = _horizontal_xcorr(arrays, n_half)
    lag_grid = (np.arange(2 * n_half + 1) - n_half) / fs_hz
    if not np.isfinite(xcorr).any():
        raise ProcessingError("drone-mast cross-correlation undefined (constant wind series)")
    kk, delta, at_edge = _refine_peak(xcorr)
    return float((kk - n_half + delta) / fs_hz), lag_grid, xcorr, bool(at_edge)


def _horizontal_xcorr(arrays: list[np.ndarray], n_half: int) -> np.ndarray:
    """Normalised vector cross-correlation of the detrended horizontal wind at lags -n_half..n_half.

    Parameters
    ----------
    arrays : list of numpy.ndarray
        Drone u, drone v, mast u, mast v [m s-1], finite, equal length n.
    n_half : int
        Half-width of the search [samples].

    Returns
    -------
    numpy.ndarray
        r at lag index k - n_half, k = 0 ... 2 n_half [-]; NaN where the denominator is 0.
        The drone's central part (``n_half`` samples dropped at either end) is held fixed.
    """
    n = arrays[0].size
    du, dv, mu, mv = (stats.detrend(a) for a in arrays)
    core = slice(n_half, n - n_half)
    d = np.stack([du[core], dv[core]], axis=-1)
    m = np.stack([mu, mv], axis=-1)
    num = scipy.signal.fftconvolve(m, d[::-1], mode="valid", axes=0).sum(axis=1)  # index k <-> lag k - n_half
    m2 = np.concatenate([[0.0], np.cumsum(np.sum(m * m, axis=1))])
    k = np.arange(2 * n_half + 1)
    den = np.sqrt(np.sum(d * d) * (m2[k + d.shape[0]] - m2[k]))
    return num / np.where(den > 0, den, np.nan)


def _refine_peak(xcorr: np.ndarray) -> tuple[int, float, bool]:
    """Index of the correlation maximum and its parabolic refinement.

    Parameters
    ----------
    xcorr : numpy.ndarray
        Correlation curve [-] with at least one finite value.

    Returns
    -------
    index : int
        Grid index of the maximum.
    delta : float
        Offset of the vertex of the parabola through the maximum and its two neighbours
        [samples], in [-0.5, 0.5]; 0 at the edge or where the curve is not concave.
    at_edge : bool
        True if the maximum is the first or last value.
    """
    kk = int(np.nanargmax(xcorr))
    at_edge = kk == 0 or kk == xcorr.size - 1
    delta = 0.0
    if not at_edge:
        y0, y1, y2 = xcorr[kk - 1], xcorr[kk], xcorr[kk + 1]
        curv = y0 - 2.0 * y1 + y2
        if curv < 0:
            delta = float(np.clip(0.5 * (y0 - y2) / curv, -0.5, 0.5))
    return kk, delta, at_edge


# ------------------------------------------------------------------ drone-mast alignment


@dataclass
class _Sensors:
    """East/north/up wind and sonic temperature of both sensors, times relative to ``t_ref_ns``."""

    t_ref_ns: int
    t_drone_s: np.ndarray
    drone: dict[str, np.ndarray]
    t_mast_s: np.ndarray
    mast: dict[str, np.ndarray]


@dataclass
class _Rotated:
    """Streamline components of both sensors and their rotation (step 4)."""

    u_ms: list[np.ndarray]
    v_ms: list[np.ndarray]
    w_ms: list[np.ndarray]
    wind_from_deg: list[float]
    angles_deg: dict[str, list[float]]
    methods: list[str]


def _sensor_arrays(ds: xr.Dataset, where: str) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Time [ns] and the east/north/up wind and temperature of one sensor's dataset."""
    require_variables(ds, _ENU_VARS, where)
    t = time_ns(ds, where)
    return t, {k: np.asarray(ds[k].values, dtype=float) for k in _ENU_VARS}


def _interp_finite(t_target: np.ndarray, t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, int]:
    """Linear interpolation using finite samples only; returns values and the number of
    target samples whose bracketing source interval contained a missing sample."""
    ok = np.isfinite(x)
    n_ok = int(ok.sum())
    if n_ok < 2:
        raise InputError("align_drone_mast", "fewer than 2 finite samples in a series")
    if n_ok == ok.size:  # nothing to select (the selection would copy both series)
        return np.interp(t_target, t, x), 0
    return np.interp(t_target, t[ok], x[ok]), _n_bridged(t_target, t, ok)


def _n_bridged(t_target: np.ndarray, t: np.ndarray, ok: np.ndarray) -> int:
    """Number of targets whose bracketing source interval has a missing end (they were bridged).

    Target j lies in source interval k = ``searchsorted(t, t_target[j])`` (clipped to
    1 ... n-1, the end intervals taking the targets outside), bridged if sample k or k-1 is
    missing. Only the intervals with a missing end are visited: the targets in interval k
    are counted by two searches among the targets, which must therefore be sorted (the
    alignment's grids are), so the cost follows the missing samples, not the record (a
    forward run aligns several series with a few gaps each).
    """
    if t_target.size > 1 and not bool(np.all(t_target[1:] >= t_target[:-1])):
        raise ValueError("_n_bridged: the targets must not decrease")
    k = np.flatnonzero(~ok[1:] | ~ok[:-1]) + 1  # intervals (t[k-1], t[k]] with a missing end
    lo = np.searchsorted(t_target, t[k - 1], side="right")
    hi = np.searchsorted(t_target, t[k], side="right")
    lo[k == 1] = 0  # targets at or before t[0] belong to the first interval
    hi[k == t.size - 1] = t_target.size  # targets after t[-1] to the last one
    return int((hi - lo).sum())


def _read_sensors(drone_l2: xr.Dataset, mast_l2: xr.Dataset, counts: dict[str, int]) -> _Sensors:
    """Both sensors on float seconds since the earlier first stamp; NaN wind samples counted.

    Parameters
    ----------
    drone_l2, mast_l2 : xarray.Dataset
        Inputs of :func:`align_drone_mast`.
    counts : dict
        Receives ``n_drone_nan`` and ``n_mast_nan`` (NaN samples of u, v and w).

    Returns
    -------
    _Sensors
    """
    td_ns, drone = _sensor_arrays(drone_l2, "drone_l2")
    tm_ns, mast = _sensor_arrays(mast_l2, "mast_l2")
    t_ref = int(min(td_ns[0], tm_ns[0]))
    td = (td_ns - t_ref) / _NS
    tm = (tm_ns - t_ref) / _NS
    for name, arrs in (("drone", drone), ("mast", mast)):
        counts[f"n_{name}_nan"] = int(sum((~np.isfinite(arrs[k])).sum() for k in _ENU_VARS[:3]))
    return _Sensors(t_ref, td, drone, tm, mast)


def _lag_on_overlap(s: _Sensors, fs_common_hz: float, max_lag_s: float, min_overlap_s: float,
                    log: list[str]) -> tuple[float, np.ndarray, np.ndarray, bool]:
    """Step 1: drone-mast lag on the overlap of both records (Ghirardelli et al. (2025), Sect. 4.4).

    Both sensors are linearly interpolated onto a grid of step 1/``fs_common_hz`` over
    their overlap (gaps bridged linearly) and the lag is found with :func:`drone_mast_lag`.

    Parameters
    ----------
    s : _Sensors
        Both sensors.
    fs_common_hz : float
        Rate of the common grid [Hz].
    max_lag_s : float
        Largest lag searched [s].
    min_overlap_s : float
        Shortest usable overlap beyond the search margins [s].
    log : list of str
        Receives the ``lag:`` line.

    Returns
    -------
    tuple
        As :func:`drone_mast_lag`: lag [s], lag grid [s], correlation [-], at-edge flag.
    """
    td, tm, drone, mast = s.t_drone_s, s.t_mast_s, s.drone, s.mast
    dt = 1.0 / fs_common_hz
    o0, o1 = max(td[0], tm[0]), min(td[-1], tm[-1])
    if o1 - o0 < 2 * max_lag_s + min_overlap_s:
        raise InputError("align_drone_mast", f"drone and mast overlap {max(o1 - o0, 0):.1f} s, need at least "
                         f"{2 * max_lag_s + min_overlap_s:.0f} s")
    g = o0 + dt * np.arange(int(np.floor((o1 - o0) / dt)) + 1)
    uv = [_interp_finite(g, t, src[k])[0] for t, src in ((td, drone), (tm, mast)) for k in ("u_east_ms", "v_north_ms")]
    lag, lag_grid, xcorr, at_edge = drone_mast_lag(uv[0], uv[1], uv[2], uv[3], fs_common_hz, max_lag_s)
    log.append(f"lag: lag_drone_mast_s = {lag:+.4f} s (max correlation {np.nanmax(xcorr):.3f}"
               f"{', AT SEARCH EDGE' if at_edge else ''})")
    return lag, lag_grid, xcorr, at_edge


def _common_grid(s: _Sensors, lag: float, fs_common_hz: float, decimate: int, counts: dict[str, int],
                 log: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Step 2: both sensors on a common grid over the window they share after the lag shift.

    The grid (step 1/``fs_common_hz``) is phase-locked to multiples of the output step
    ``decimate``/``fs_common_hz`` of UTC and spans the common window of the mast and the
    lag-shifted drone; the drone is interpolated at ``t - lag`` and the mast at ``t``
    (linear, as in Ghirardelli et al. (2025); gaps bridged and counted). Linear interpolation of a record
    sampled at :math:`f_s` acts on average as a low-pass with a power gain of
    :math:`(2 + \\cos 2\\pi f/f_s)/3` (mean over the interpolation phase): at 3 Hz 0.94 for
    the 32 Hz drone, 0.86 for a 20 Hz mast and 0.56 for a 10 Hz mast (whose own Nyquist is
    5 Hz); at 1 Hz 0.99, 0.98 and 0.94.

    Parameters
    ----------
    s : _Sensors
        Both sensors.
    lag : float
        Drone-mast lag [s] (added to the drone's stamps).
    fs_common_hz : float
        Rate of the common grid [Hz].
    decimate : int
        Later decimation factor (sets the phase lock).
    counts : dict
        Receives ``n_drone_bridged_32hz`` and ``n_mast_bridged_32hz``.
    log : list of str
        Receives the ``common:`` line.

    Returns
    -------
    grid_ns : numpy.ndarray
        Grid times [ns since 1970], int64.
    x32 : numpy.ndarray
        (n, 8): drone u, v, w [m s-1], T [K], then the same for the mast.
    """
    t_ref, dt = s.t_ref_ns, 1.0 / fs_common_hz
    step_ns = int(round(_NS / fs_common_hz))
    out_step_ns = step_ns * decimate
    c0 = max(s.t_drone_s[0] + lag, s.t_mast_s[0])
    c1 = min(s.t_drone_s[-1] + lag, s.t_mast_s[-1])
    c0_ns = int(np.ceil((t_ref + c0 * _NS) / out_step_ns)) * out_step_ns
    n_grid = int(np.floor(((t_ref + c1 * _NS) - c0_ns) / step_ns)) + 1
    grid_ns = c0_ns + step_ns * np.arange(n_grid, dtype=np.int64)
    grid = (grid_ns - t_ref) / _NS
    cols = []
    for name, t, src, shift in (("drone", s.t_drone_s, s.drone, lag), ("mast", s.t_mast_s, s.mast, 0.0)):
        n_bridged = 0
        for k in _ENU_VARS:
            y, nb = _interp_finite(grid - shift, t, src[k])
            cols.append(y)
            n_bridged = max(n_bridged, nb)
        counts[f"n_{name}_bridged_32hz"] = n_bridged
    log.append(f"common: {n_grid} samples at {fs_common_hz:g} Hz over {(n_grid - 1) * dt:.1f} s "
               f"(mast bridged {counts['n_mast_bridged_32hz']}, drone bridged {counts['n_drone_bridged_32hz']})")
    return grid_ns, np.stack(cols, axis=-1)


def _antialias_decimate(x32: np.ndarray, grid_ns: np.ndarray, fs_common_hz: float, decimate: int,
                        counts: dict[str, int], log: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step 3: FIR low-pass and decimation of the common record.

    :func:`design_antialias_fir` (123 taps, Kaiser, 3-4 Hz transition, 60 dB for the
    defaults) applied centred (zero phase), then every ``decimate``-th sample; the first
    and last 61 samples of the 32 Hz grid (1.9 s) are dropped instead of padded.

    Parameters
    ----------
    x32 : numpy.ndarray
        (n, 8) common record (:func:`_common_grid`).
    grid_ns : numpy.ndarray
        Its times [ns].
    fs_common_hz : float
        Its rate [Hz].
    decimate : int
        Decimation factor.
    counts : dict
        Receives ``n_fir_edge_dropped_32hz`` and ``n_fir_taps``.
    log : list of str
        Receives the ``decimate:`` line.

    Returns
    -------
    x8 : numpy.ndarray
        Filtered, decimated record.
    time8 : numpy.ndarray
        Its times (datetime64[ns]).
    taps : numpy.ndarray
        The FIR taps.
    """
    n_grid = grid_ns.size
    taps = design_antialias_fir(fs_common_hz, decimate)
    x8, idx = fir_decimate(x32, taps, decimate, phase=0)
    counts["n_fir_edge_dropped_32hz"] = int(n_grid - (idx[-1] - idx[0] + 1))
    counts["n_fir_taps"] = int(taps.size)
    time8 = grid_ns[idx].astype("datetime64[ns]")
    fs_out = fs_common_hz / decimate
    log.append(f"decimate: FIR {taps.size} taps (Kaiser, 3-4 Hz transition, 60 dB), x{decimate} -> {fs_out:g} Hz, "
               f"{time8.size} samples")
    return x8, time8, taps


def _rotate_sensors(x8: np.ndarray, rotation: str, planar_fit: dict[str, rot.PlanarFit] | None,
                    log: list[str]) -> _Rotated:
    """Step 4: wind-from direction and streamline rotation of each sensor.

    The direction is that of the mean (east, north) vector; then
    :func:`dronewind.core.rotation.rotate` per sensor. A planar fit is used only where one
    is given (a fixed mast sonic); a sensor without one (the drone, re-levelled every
    flight) gets the double rotation.

    Parameters
    ----------
    x8 : numpy.ndarray
        (n, 8) decimated record (drone u v w T, mast u v w T).
    rotation : str
        Requested method (:data:`dronewind.core.rotation.ROTATION_METHODS`).
    planar_fit : dict, optional
        ``{"drone": PlanarFit, "mast": PlanarFit}`` (either may be absent).
    log : list of str
        Receives the ``rotation:`` line.

    Returns
    -------
    _Rotated
    """
    out = _Rotated([], [], [], [], {"yaw_deg": [], "pitch_deg": [], "roll_deg": []}, [])
    for s, name in enumerate(("drone", "mast")):
        ue, vn, wu = x8[:, 4 * s], x8[:, 4 * s + 1], x8[:, 4 * s + 2]
        out.wind_from_deg.append(float(rad2deg(np.arctan2(-ue.mean(), -vn.mean())) % 360.0))
        pf = None if planar_fit is None else planar_fit.get(name)
        method = "double" if rotation == "planar_fit" and pf is None else rotation
        a, b, c, angles = rot.rotate(ue, vn, wu, method, planar_fit=pf)
        out.methods.append(method)
        out.u_ms.append(a)
        out.v_ms.append(b)
        out.w_ms.append(c)
        for key in out.angles_deg:
            out.angles_deg[key].append(angles[key])
    log.append(f"rotation: drone {out.methods[0]}, mast {out.methods[1]}; wind from drone "
               f"{out.wind_from_deg[0]:.1f} deg, mast {out.wind_from_deg[1]:.1f} deg")
    return out


def _l3_dataset(x8: np.ndarray, time8: np.ndarray, r: _Rotated, height_m: np.ndarray, lag_grid: np.ndarray,
                xcorr: np.ndarray) -> xr.Dataset:
    """The L3 variables and coordinates (see :func:`align_drone_mast`, Returns)."""
    dims = ("sensor", "time")
    ang = r.angles_deg
    ds = xr.Dataset(
        {
            "u_ms": variable(dims, np.stack(r.u_ms), "m s-1", long_name="streamwise wind component"),
            "v_ms": variable(dims, np.stack(r.v_ms), "m s-1",
                             long_name="cross-stream wind component (positive to the left)"),
            "w_ms": variable(dims, np.stack(r.w_ms), "m s-1",
                             long_name="vertical wind component in streamline coordinates"),
            "theta_v_k": variable(dims, np.stack([x8[:, 3], x8[:, 7]]), "K", "virtual_temperature",
                                  comment="sonic temperature used as (virtual potential) temperature; no g z/c_p term"),
            "wind_from_deg": variable(("sensor",), np.array(r.wind_from_deg), "degree", "wind_from_direction",
                                      comment="mean wind direction before rotation"),
            "height_m": variable(("sensor",), height_m, "m", "height", comment="above ground", positive="up"),
            "rotation_yaw_deg": variable(("sensor",), np.array(ang["yaw_deg"]), "degree",
                                         long_name="streamline rotation: yaw (counter-clockwise from east)"),
            "rotation_pitch_deg": variable(("sensor",), np.array(ang["pitch_deg"]), "degree",
                                           long_name="streamline rotation: pitch"),
            "rotation_roll_deg": variable(("sensor",), np.array(ang["roll_deg"]), "degree",
                                          long_name="streamline rotation: roll"),
            "lag_s": variable(("lag",), lag_grid, "s", long_name="drone-mast lag added to the drone time stamps"),
            "xcorr": variable(("lag",), xcorr, "1", long_name="cross-correlation of horizontal wind fluctuations"),
        },
        coords={"sensor": ("sensor", np.array(["drone", "mast"])), "time": ("time", time8),
                "lag": ("lag", lag_grid)},
    )
    ds["lag"].attrs.update({"units": "s", "long_name": "drone-mast lag added to the drone time stamps"})
    ds["time"].attrs.update({"standard_name": "time", "long_name": "time (UTC) on the mast clock"})
    return ds


def input_rate_hz(l2: xr.Dataset, t_s: np.ndarray) -> float:
    """Sampling rate of a record that enters the alignment [Hz].

    Its ``sampling_rate_hz`` attribute (the nominal rate the L1 readers record), else the
    inverse of its median sample step; NaN for fewer than two samples.
    """
    if "sampling_rate_hz" in l2.attrs:
        return float(l2.attrs["sampling_rate_hz"])
    if t_s.size < 2:
        return float("nan")
    return float(1.0 / np.median(np.diff(t_s)))


def _l3_attrs(lag: float, xcorr: np.ndarray, at_edge: bool, rotation: str, r: _Rotated, fs_out: float,
              taps: np.ndarray, n_samples: int, counts: dict[str, int], log: list[str],
              input_rates_hz: tuple[float, float]) -> dict[str, object]:
    """The L3 dataset attributes (see :func:`align_drone_mast`, Returns)."""
    return {
        "lag_drone_mast_s": float(lag),
        "lag_xcorr_max": float(np.nanmax(xcorr)),
        "lag_at_search_edge": int(at_edge),
        "rotation_method": rotation,
        "rotation_method_drone": r.methods[0],
        "rotation_method_mast": r.methods[1],
        "sampling_rate_hz": float(fs_out),
        # the rates of the records aligned: their linear interpolation to the common grid
        # damps the high frequencies of a slower record more (_common_grid)
        "drone_sampling_rate_hz": float(input_rates_hz[0]),
        "mast_sampling_rate_hz": float(input_rates_hz[1]),
        "fir_design": (f"Kaiser-window FIR, {taps.size} taps, cutoff {fs_out * 0.4375:g} Hz, transition "
                       f"{default_passband_edge_hz(fs_out):g}-{0.5 * fs_out:g} Hz, 60 dB, centred (zero phase)"),
        "fir_passband_edge_hz": default_passband_edge_hz(fs_out),
        "n_samples": int(n_samples),
        **{k: int(v) for k, v in counts.items()},
        "processing_log": "\n".join(log),
    }


def align_drone_mast(
    drone_l2: xr.Dataset, mast_l2: xr.Dataset, max_lag_s: float = 6.0, decimate: int = 4, rotation: str = "double",
    *, fs_common_hz: float = 32.0, drone_height_m: float | None = None,
    planar_fit: dict[str, rot.PlanarFit] | None = None, min_overlap_s: float = 60.0,
) -> xr.Dataset:
    """Build the L3 dataset: drone and mast aligned, decimated and in streamline coordinates.

    Parameters
    ----------
    drone_l2 : xarray.Dataset
        Payload L2 (:func:`dronewind.payload.l2.payload_l2`): ``u_east_ms``,
        ``v_north_ms``, ``w_up_ms`` [m s-1], ``t_sonic_k`` [K] on ``time`` (UTC).
    mast_l2 : xarray.Dataset
        Mast sonic in east/north/up with the same variable names, 10 or 20 Hz, NaN
        where flagged; attrs ``height_m``.
    max_lag_s : float
        Largest drone-mast lag searched [s]; default 6 s (Ghirardelli et al. (2025), Sect. 4.4).
    decimate : int
        Decimation factor from the common base; default 4 (32 Hz -> 8 Hz).
    rotation : {"none", "single", "double", "triple", "planar_fit"}
        Rotation into streamline coordinates, per sensor over the common window; default
        "double" (Ghirardelli et al. (2025), Sect. 4.4).
    fs_common_hz : float
        Common base rate before decimation [Hz]; default 32 Hz.
    drone_height_m : float, optional
        Drone height above ground [m]; default ``drone_l2.attrs["height_m"]`` (or
        ``target_height_m``), else NaN.
    planar_fit : dict, optional
        ``{"drone": PlanarFit, "mast": PlanarFit}`` for ``rotation="planar_fit"``.
    min_overlap_s : float
        Shortest usable overlap beyond the lag search margins [s].

    Returns
    -------
    xarray.Dataset
        Dims ``sensor`` = ["drone", "mast"] and ``time`` (8 Hz, common window, stamps on
        the mast clock at multiples of 1/8 s): ``u_ms``, ``v_ms``, ``w_ms`` [m s-1]
        (streamline; means kept, not detrended), ``theta_v_k`` [K], ``wind_from_deg(sensor)``
        (mean direction before rotation), ``height_m(sensor)``,
        ``rotation_yaw_deg/pitch_deg/roll_deg(sensor)``, and on ``lag``: ``lag_s``,
        ``xcorr`` (drone-mast correlation curve). attrs: ``lag_drone_mast_s``,
        ``lag_xcorr_max``, ``rotation_method``, ``sampling_rate_hz``,
        ``drone_sampling_rate_hz`` and ``mast_sampling_rate_hz`` (the rates of the records
        aligned, :func:`input_rate_hz`), FIR design, counts ``n_*`` and ``processing_log``.

    Notes
    -----
    Steps (module docstring): lag on the overlap (:func:`_lag_on_overlap`), common 32 Hz
    grid (:func:`_common_grid`), anti-alias FIR and decimation (:func:`_antialias_decimate`),
    direction and rotation per sensor (:func:`_rotate_sensors`). theta_v is the sonic
    temperature (the dry-adiabatic height correction g z / c_p is not applied).

    References
    ----------
    Ghirardelli et al. (2025), Sect. 4.4; McMillen (1988); Wilczak et al. (2001).
    """
    if rotation not in rot.ROTATION_METHODS:
        raise InputError("rotation", f"unknown rotation method {rotation!r}")
    log: list[str] = []
    counts: dict[str, int] = {}
    sensors = _read_sensors(drone_l2, mast_l2, counts)
    lag, lag_grid, xcorr, at_edge = _lag_on_overlap(sensors, fs_common_hz, max_lag_s, min_overlap_s, log)
    grid_ns, x32 = _common_grid(sensors, lag, fs_common_hz, decimate, counts, log)
    x8, time8, taps = _antialias_decimate(x32, grid_ns, fs_common_hz, decimate, counts, log)
    rotated = _rotate_sensors(x8, rotation, planar_fit, log)
    if drone_height_m is None:
        drone_height_m = drone_l2.attrs.get("height_m", drone_l2.attrs.get("target_height_m", np.nan))
    heights = np.array([float(drone_height_m), float(mast_l2.attrs.get("height_m", np.nan))])
    ds = _l3_dataset(x8, time8, rotated, heights, lag_grid, xcorr)
    rates = (input_rate_hz(drone_l2, sensors.t_drone_s), input_rate_hz(mast_l2, sensors.t_mast_s))
    ds.attrs.update(_l3_attrs(lag, xcorr, at_edge, rotation, rotated, fs_common_hz / decimate, taps,
                              time8.size, counts, log, rates))
    return ds
