"""Sonic-to-INS lag of the payload: the lag that minimises the motion-corrected TKE.

The sonic and the INS are stamped by the same logger clock but sample with different
processing delays. The lag is found as that of minimum turbulent kinetic energy of the
motion-corrected wind over a grid of candidate lags (Ghirardelli et al. (2025), Sect. 3.3):
a wrong lag leaves part of the platform motion in the wind and adds variance.
:func:`tke_vs_lag` gives the TKE per candidate lag, :func:`find_sonic_ins_lag` the minimum;
:func:`lag_correlations` computes the lagged sums of all candidate lags at once from FFT
cross-correlations (:func:`fast_fft_length`).

Sign convention (``docs/data-contract.md``): ``lag_sonic_ins_s`` is the time ADDED to the
sonic's clock to align it with the INS: the sonic sample stamped ``t`` is combined with the
INS state at ``t + lag`` (:func:`interpolate_ins`).

Times are handled as float seconds since the first time stamp of the inputs (int64
nanoseconds are subtracted before conversion, so a flight keeps sub-microsecond
resolution).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from dronewind.core.angles import deg2rad, rad2deg, wrap_360
from dronewind.core.reuse import reused
from dronewind.core.timeseries import (
    NS_PER_S,
    unwrap_rad,
)
from dronewind.errors import InputError
from dronewind.payload import motion

__all__ = [
    "interpolate_ins",
    "tke_vs_lag",
    "find_sonic_ins_lag",
    "subgrid_minimum",
]


_NS = NS_PER_S


_INS_VARS = ("roll_deg", "pitch_deg", "yaw_deg", "vel_n_ms", "vel_e_ms", "vel_d_ms", "lat_deg", "lon_deg", "alt_m")


_SONIC_VARS = ("u_sensor_ms", "v_sensor_ms", "w_sensor_ms", "t_sonic_k")


def interpolate_ins(time_ins_s: np.ndarray, ins: dict[str, np.ndarray], time_target_s: np.ndarray,
                    ) -> dict[str, np.ndarray]:
    """Linear interpolation of INS series onto target times (yaw unwrapped, then wrapped).

    Parameters
    ----------
    time_ins_s : numpy.ndarray
        Strictly increasing INS times [s].
    ins : dict of numpy.ndarray
        Finite INS series on ``time_ins_s``; a key ``yaw_deg`` [degree] is unwrapped
        before and wrapped to [0, 360) after interpolation; other keys are interpolated as
        they are (angles other than yaw never approach +/-180 degree on a hovering payload).
    time_target_s : numpy.ndarray
        Target times [s]; must lie within ``[time_ins_s[0], time_ins_s[-1]]``.

    Returns
    -------
    dict of numpy.ndarray
        Series on ``time_target_s``.

    Notes
    -----
    Ghirardelli et al. (2025), Sect. 3.2: the 50 Hz EKF output is brought to the 32 Hz sonic times by linear
    interpolation.
    """
    tt = np.asarray(time_target_s, dtype=float)
    ti = np.asarray(time_ins_s, dtype=float)
    if tt.size and (tt.min() < ti[0] - 1e-9 or tt.max() > ti[-1] + 1e-9):
        raise InputError("ins:time", f"target times [{tt.min():.3f}, {tt.max():.3f}] s exceed the INS record "
                         f"[{ti[0]:.3f}, {ti[-1]:.3f}] s")
    out: dict[str, np.ndarray] = {}
    for key, val in ins.items():
        arr = np.asarray(val, dtype=float)
        if arr.ndim == 2:
            out[key] = np.stack([np.interp(tt, ti, arr[:, k]) for k in range(arr.shape[1])], axis=-1)
        elif key == "yaw_deg":
            unwrapped = rad2deg(unwrap_rad(deg2rad(arr)))
            out[key] = wrap_360(np.interp(tt, ti, unwrapped))
        else:
            out[key] = np.interp(tt, ti, arr)
    return out


def tke_vs_lag(
    time_sonic_s: np.ndarray, sonic_sensor_ms: np.ndarray, time_ins_s: np.ndarray, attitude_deg: np.ndarray,
    vel_ned_ms: np.ndarray, mount: str, lever_arm_m: Sequence[float] | None = None, max_lag_s: float = 2.0,
    lag_step_s: float = 1.0 / 32.0, misalignment_deg: Sequence[float] | None = None,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Mean TKE of the motion-corrected wind as a function of the sonic-INS lag.

    Parameters
    ----------
    time_sonic_s : numpy.ndarray
        Sonic sample times [s], strictly increasing, shape (n,).
    sonic_sensor_ms : numpy.ndarray
        (n, 3) finite sonic reading in the sensor frame [m s-1].
    time_ins_s : numpy.ndarray
        INS times [s], strictly increasing, shape (m,).
    attitude_deg : numpy.ndarray
        (m, 3) finite roll, pitch, yaw [degree].
    vel_ned_ms : numpy.ndarray
        (m, 3) finite INS velocity north, east, down [m s-1].
    mount : str
        Sonic mount, see :func:`dronewind.payload.motion.mount_matrix`.
    lever_arm_m : (x, y, z) [m], optional
        INS reference point relative to the sonic (body frame).
    max_lag_s : float
        Half-width of the search range [s]; default 2 s (Ghirardelli et al. (2025), Sect. 3.3).
    lag_step_s : float
        Step of the search [s]; default 1/32 s (Ghirardelli et al. (2025), Sect. 3.3).
    misalignment_deg : (roll, pitch, yaw) [degree], optional
        Mount misalignment, see :func:`dronewind.payload.motion.sensor_to_body_matrix`.

    Returns
    -------
    lag_s : numpy.ndarray
        The lags [s], ``-max_lag_s ... +max_lag_s`` (129 values by default); the sonic
        sample at ``t`` is combined with the INS state at ``t + lag``.
    tke_m2s2 : numpy.ndarray
        Mean TKE of the corrected wind at each lag [m2 s-2].
    n_samples : int
        Number of sonic grid samples the TKE is computed from (the same for all lags).

    Notes
    -----
    Ghirardelli et al. (2025), Sect. 3.3 and Eq. 3, :math:`TKE = \\tfrac12(\\sigma_u^2 + \\sigma_v^2 +
    \\sigma_w^2)` of the corrected wind at each lag, all lags at once by FFT correlations
    (:func:`_mean_tke_per_lag`) on a regular grid of step ``lag_step_s``
    (:func:`_lag_search_grid`, :func:`_ins_on_extended_grid`). Variances use the
    population normalisation (1/n).

    References
    ----------
    Ghirardelli et al. (2025) (Ghirardelli et al.), Sect. 3.3, Eq. 3 and Fig. 4.
    """
    lags, tke, n, _ = _tke_curves(time_sonic_s, sonic_sensor_ms, time_ins_s, attitude_deg, vel_ned_ms, mount,
                                  lever_arm_m, max_lag_s, lag_step_s, misalignment_deg)
    return lags, tke, n


def _tke_curves(
    time_sonic_s: np.ndarray, sonic_sensor_ms: np.ndarray, time_ins_s: np.ndarray, attitude_deg: np.ndarray,
    vel_ned_ms: np.ndarray, mount: str, lever_arm_m: Sequence[float] | None, max_lag_s: float, lag_step_s: float,
    misalignment_deg: Sequence[float] | None, split_s: float | None = None,
) -> tuple[np.ndarray, np.ndarray, int, list[np.ndarray | None]]:
    """:func:`tke_vs_lag`, and the same curve on the grid's parts before and after ``split_s``.

    The parts share the grid, the sonic on it and the INS on the extended grid with the whole
    (each part's lag j combines the same samples as the whole's), so they cost only their
    correlations. A part shorter than the search allows (:func:`_lag_search_grid`) gives None.

    Returns
    -------
    lag_s, tke_m2s2, n_samples
        As :func:`tke_vs_lag`.
    parts : list
        With ``split_s``: the TKE curves of the grid samples before and at or after it [m2 s-2].
    """
    ts = np.asarray(time_sonic_s, dtype=float)
    ti = np.asarray(time_ins_s, dtype=float)
    sonic, att, vel = (np.asarray(a, dtype=float) for a in (sonic_sensor_ms, attitude_deg, vel_ned_ms))
    n_half = _check_lag_search(ts, ti, sonic, att, vel, max_lag_s, lag_step_s)
    dt = float(lag_step_s)
    t0, n = _lag_search_grid(ts, ti, n_half, dt, max_lag_s)
    grid = t0 + dt * np.arange(n)
    # inside a forward flight's runs, an INS probe leaves the sonic on the grid unchanged (read-only)
    mis = None if misalignment_deg is None else tuple(float(x) for x in misalignment_deg)
    b = reused("sonic in the body frame on the lag-search grid", {"ts": ts, "sonic": sonic, "grid": grid},
               repr((mount, mis)), lambda: _sonic_body_on_grid(ts, sonic, grid, mount, mis))
    grid_ext = t0 + dt * np.arange(-n_half, n + n_half)
    lever = None if lever_arm_m is None else tuple(float(x) for x in lever_arm_m)
    rot, v_sonic = _ins_on_extended_grid(ti, att, vel, grid_ext, lever)
    lags = dt * np.arange(-n_half, n_half + 1)
    sums: list[_LagSums | None] = []
    if split_s is not None:
        k = int(np.clip(np.ceil((split_s - t0) / dt - 1e-9), 0, n))  # first grid sample at or after the split
        sums = [_lag_sums(rot[lo:hi + 2 * n_half], v_sonic[lo:hi + 2 * n_half], b[lo:hi], n_half)
                if hi - lo >= 8 * n_half + 16 else None for lo, hi in ((0, k), (k, n))]
    parts = [None if part is None else _tke_from_sums(part) for part in sums]
    if len(sums) == 2 and sums[0] is not None and sums[1] is not None:
        # the whole grid's sums are the halves' sums: its curve costs no correlation of its own
        return lags, _tke_from_sums(_joined(sums[0], sums[1])), n, parts
    return lags, _mean_tke_per_lag(rot, v_sonic, b, n, n_half), n, parts


def _check_lag_search(ts: np.ndarray, ti: np.ndarray, sonic: np.ndarray, att: np.ndarray, vel: np.ndarray,
                      max_lag_s: float, lag_step_s: float) -> int:
    """Check the inputs of :func:`tke_vs_lag`; return the half-width of the search [steps].

    Raises
    ------
    InputError
        Wrong shapes, non-finite values, or a range that is not a multiple of the step.
    """
    if sonic.shape != (ts.size, 3):
        raise InputError("sonic_sensor_ms", f"expected shape ({ts.size}, 3), got {sonic.shape}")
    if att.shape != (ti.size, 3) or vel.shape != (ti.size, 3):
        raise InputError("ins", f"attitude and velocity must have shape ({ti.size}, 3)")
    for name, arr in (("sonic_sensor_ms", sonic), ("attitude_deg", att), ("vel_ned_ms", vel)):
        if not np.all(np.isfinite(arr)):
            raise InputError(name, "non-finite values: fill gaps before the lag search")
    if not (lag_step_s > 0 and max_lag_s >= 0):
        raise InputError("max_lag_s/lag_step_s", "expected max_lag_s >= 0 and lag_step_s > 0")
    n_half = int(round(max_lag_s / lag_step_s))
    if abs(n_half * lag_step_s - max_lag_s) > 1e-6 * max(1.0, max_lag_s):
        raise InputError("max_lag_s", f"max_lag_s={max_lag_s} is not a multiple of lag_step_s={lag_step_s}")
    return n_half


def _lag_search_grid(ts: np.ndarray, ti: np.ndarray, n_half: int, dt: float, max_lag_s: float) -> tuple[float, int]:
    """Start and length of the regular sonic grid of the lag search.

    The grid starts at the first sonic sample whose whole lag range is inside the INS
    record and ends at the last sonic sample or INS end minus the range.

    Parameters
    ----------
    ts, ti : numpy.ndarray
        Sonic and INS times [s].
    n_half : int
        Half-width of the search [steps].
    dt : float
        Step [s].
    max_lag_s : float
        Half-width [s] (for the error message).

    Returns
    -------
    t0 : float
        First grid time [s].
    n : int
        Number of grid samples.
    """
    lo = ti[0] + n_half * dt
    hi = ti[-1] - n_half * dt
    inside = np.flatnonzero((ts >= lo - 1e-9) & (ts <= hi + 1e-9))
    if inside.size == 0:
        raise InputError("ins:time", "the INS record does not cover the sonic record +/- max_lag_s")
    t0 = ts[inside[0]]
    n = int(np.floor((min(ts[-1], hi) - t0) / dt + 1e-9)) + 1
    if n < 8 * n_half + 16:
        raise InputError("sonic:time", f"record too short for a +/-{max_lag_s} s lag search ({n} grid samples)")
    return t0, n


def _sonic_body_on_grid(ts: np.ndarray, sonic: np.ndarray, grid: np.ndarray, mount: str,
                        misalignment_deg: Sequence[float] | None) -> np.ndarray:
    """Sonic reading in the body frame, :math:`b = M V_{sensor}`, on the grid [m s-1].

    Exact for a regular sonic at the grid rate, else linear interpolation.
    """
    m_mount = motion.sensor_to_body_matrix(mount, misalignment_deg)
    return np.stack([np.interp(grid, ts, sonic[:, k]) for k in range(3)], axis=-1) @ m_mount.T


def _ins_on_extended_grid(ti: np.ndarray, att: np.ndarray, vel: np.ndarray, grid_ext: np.ndarray,
                          lever_arm_m: Sequence[float] | None) -> tuple[np.ndarray, np.ndarray]:
    """Body-to-NED rotation and sonic velocity on the grid extended by the search range.

    The INS (yaw unwrapped) is interpolated linearly onto the grid extended by
    ``max_lag_s`` on each side, so that lag ``j * lag_step_s`` is a shift by j samples.

    Parameters
    ----------
    ti : numpy.ndarray
        INS times [s].
    att, vel : numpy.ndarray
        (m, 3) roll, pitch, yaw [degree] and velocity north, east, down [m s-1].
    grid_ext : numpy.ndarray
        Extended grid [s].
    lever_arm_m : (x, y, z) [m], optional
        INS reference point relative to the sonic.

    Returns
    -------
    rot : numpy.ndarray
        (N, 3, 3) body-to-NED rotation R.
    v_sonic : numpy.ndarray
        (N, 3) velocity of the sonic, V = INS velocity minus the lever-arm term [m s-1].
    """
    target = np.clip(grid_ext, ti[0], ti[-1])
    # the attitude's part (rotations, body rates: most of the cost), which a sonic probe and a
    # probe of the INS's position and velocity (a lever arm) leave unchanged, is found made
    # inside a forward flight's runs (dronewind.core.reuse; read-only, only read)
    with_rates = lever_arm_m is not None
    rot, rates = reused("INS attitude on the lag-search grid", {"ti": ti, "att": att, "grid": grid_ext},
                        repr(with_rates), lambda: _attitude_on_grid(ti, att, target, with_rates))
    # the velocity likewise, which a sonic probe and an attitude probe leave unchanged (read-only)
    v_sonic = reused("INS velocity on the lag-search grid", {"ti": ti, "vel": vel, "grid": grid_ext}, "",
                     lambda: interpolate_ins(ti, {"vel": vel}, target)["vel"])
    if lever_arm_m is not None and rates is not None:
        v_sonic = v_sonic - motion.lever_arm_velocity_ned(rot, rates, lever_arm_m)
    return rot, v_sonic


def _attitude_on_grid(ti: np.ndarray, att: np.ndarray, target: np.ndarray, with_rates: bool
                      ) -> tuple[np.ndarray, np.ndarray | None]:
    """Body-to-NED rotation (and, ``with_rates``, the body rates) of the INS attitude at ``target``."""
    keys = {"roll_deg": att[:, 0], "pitch_deg": att[:, 1], "yaw_deg": att[:, 2]}
    if with_rates:
        keys["rates"] = motion.body_rates_from_euler(att[:, 0], att[:, 1], att[:, 2], ti)
    ins_g = interpolate_ins(ti, keys, target)
    rot = motion.rotation_matrix_body_to_ned(ins_g["roll_deg"], ins_g["pitch_deg"], ins_g["yaw_deg"])
    return rot, ins_g.get("rates")


def fast_fft_length(n: int) -> int:
    """Smallest length >= ``n`` whose only prime factors are 2, 3 and 5 (a fast FFT length).

    Parameters
    ----------
    n : int
        Least length.

    Returns
    -------
    int
        The 5-smooth length.

    Notes
    -----
    What :func:`scipy.fft.next_fast_len` returns for real transforms, written here because
    the lag search uses :mod:`numpy.fft` and importing :mod:`scipy.fft` costs a job 0.17 CPU-s.
    """
    if n <= 1:
        return 1
    best = 1 << (int(n) - 1).bit_length()  # the next power of two
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            # smallest p35 * 2^k >= n
            m = p35 if p35 >= n else p35 << (-(-int(n) // p35) - 1).bit_length()
            best = min(best, m)
            p35 *= 3
        p5 *= 5
    return best


def lag_correlations(long_series: np.ndarray, short_series: np.ndarray, n_lags: int) -> np.ndarray:
    """Summed cross-correlations :math:`c_g(j) = \\sum_l \\sum_k x_{gl}(k + j)\\, y_l(k)` for the first lags.

    Parameters
    ----------
    long_series : numpy.ndarray
        (n + n_lags - 1, G, q) series :math:`x_{gl}`: G groups of q series.
    short_series : numpy.ndarray
        (n, q) series :math:`y_l`.
    n_lags : int
        Number of lags j = 0 ... n_lags - 1.

    Returns
    -------
    numpy.ndarray
        (n_lags, G) correlations.

    Notes
    -----
    One real FFT per series, of a length L >= n + n_lags - 1 (:func:`fast_fft_length`): the
    circular correlation of length L has no wrap-around at the lags needed, so the series are
    not padded to the full correlation length. The sum over l is taken on the spectra, so
    that one inverse FFT per group is enough.
    """
    n_long, n = long_series.shape[0], short_series.shape[0]
    if n_long != n + n_lags - 1 or long_series.shape[2] != short_series.shape[1]:
        raise ValueError(f"expected long_series of shape ({n + n_lags - 1}, G, {short_series.shape[1]}), "
                         f"got {long_series.shape}")
    size = fast_fft_length(n_long)
    return _correlate_spectra(np.fft.rfft(long_series, size, axis=0), size, short_series, n_lags)


def _correlate_spectra(spectra: np.ndarray, size: int, short_series: np.ndarray, n_lags: int) -> np.ndarray:
    """:func:`lag_correlations` from the long series' real FFTs ``spectra`` (F, G, q) of length ``size``."""
    spec_y = np.conj(np.fft.rfft(short_series, size, axis=0))  # (F, q)
    return np.fft.irfft(np.einsum("fgl,fl->fg", spectra, spec_y), size, axis=0)[:n_lags]


class _LagSums(NamedTuple):
    """The lag-dependent sums of :func:`_mean_tke_per_lag` over n grid samples, for every lag j."""

    #: sum over k of R(k+j) b(k), shape (2J+1, 3)
    rb: np.ndarray
    #: sum over k of (R^T V)(k+j) . b(k), shape (2J+1,)
    cb: np.ndarray
    #: sum over k of V(k+j), shape (2J+1, 3)
    v: np.ndarray
    #: sum over k of |V(k+j)|^2, shape (2J+1,)
    v2: np.ndarray
    #: sum over k of |b(k)|^2
    b2: float
    #: number of grid samples n
    n: int


def _joined(a: _LagSums, b: _LagSums) -> _LagSums:
    """The sums over two disjoint sets of grid samples together."""
    return _LagSums(a.rb + b.rb, a.cb + b.cb, a.v + b.v, a.v2 + b.v2, a.b2 + b.b2, a.n + b.n)


class _InsLagTerms(NamedTuple):
    """What :func:`_lag_sums` takes from the INS alone, for n grid samples and lags 0 ... 2J."""

    #: real FFT (length ``size``) of the rows of R and of R^T V on the extended grid, (F, 4, 3)
    spectra: np.ndarray
    #: FFT length (:func:`fast_fft_length`)
    size: int
    #: sum over k of V(k+j), shape (2J+1, 3)
    v: np.ndarray
    #: sum over k of |V(k+j)|^2, shape (2J+1,)
    v2: np.ndarray


def _ins_lag_terms(rot: np.ndarray, v_sonic: np.ndarray, n: int, n_half: int) -> _InsLagTerms:
    """The INS's part of :func:`_lag_sums`: spectra of R and R^T V, sliding sums of V and |V|^2."""
    c_body = np.einsum("nji,nj->ni", rot, v_sonic)  # R^T V
    long_series = np.concatenate([rot, c_body[:, None, :]], axis=1)  # (N, 4, 3): rows of R, then R^T V
    size = fast_fft_length(long_series.shape[0])
    cs_v = np.concatenate([np.zeros((1, 3)), np.cumsum(v_sonic, axis=0)])
    cs_v2 = np.concatenate([[0.0], np.cumsum(np.sum(v_sonic ** 2, axis=1))])
    j = np.arange(2 * n_half + 1)
    return _InsLagTerms(np.fft.rfft(long_series, size, axis=0), size, cs_v[j + n] - cs_v[j], cs_v2[j + n] - cs_v2[j])


def _lag_sums(rot: np.ndarray, v_sonic: np.ndarray, b: np.ndarray, n_half: int) -> _LagSums:
    """The sums of :func:`_mean_tke_per_lag` over the grid samples of ``b`` (FFT correlations, cumulative sums).

    The correlations are :func:`lag_correlations` of the rows of R and of R^T V with b, with
    the INS's spectra and sliding sums (:func:`_ins_lag_terms`) made once per INS: inside a
    forward flight's runs a sonic probe, which leaves the INS on the grid unchanged, finds
    them (:mod:`dronewind.core.reuse`) and transforms only its own three series.
    """
    n = b.shape[0]
    if rot.shape[0] != n + 2 * n_half or v_sonic.shape[0] != rot.shape[0]:
        raise ValueError(f"expected R and V on {n + 2 * n_half} extended-grid samples, got {rot.shape[0]} and "
                         f"{v_sonic.shape[0]}")
    ins = reused("INS terms of the lag sums", {"rot": rot, "v_sonic": v_sonic}, repr((n, n_half)),
                 lambda: _ins_lag_terms(rot, v_sonic, n, n_half))
    corr = _correlate_spectra(ins.spectra, ins.size, b, 2 * n_half + 1)  # (2J+1, 4)
    return _LagSums(corr[:, :3], corr[:, 3], ins.v, ins.v2, float(np.sum(b * b)), n)


def _tke_from_sums(sums: _LagSums) -> np.ndarray:
    """Mean TKE per lag from its sums (:func:`_mean_tke_per_lag`, Notes) [m2 s-2]."""
    n = sums.n
    mean_w = (sums.rb + sums.v) / n
    return 0.5 * ((sums.b2 + sums.v2 + 2.0 * sums.cb) / n - np.sum(mean_w ** 2, axis=1))


def _mean_tke_per_lag(rot: np.ndarray, v_sonic: np.ndarray, b: np.ndarray, n: int, n_half: int) -> np.ndarray:
    """Mean TKE of :math:`W_j(t) = R(t + j\\Delta) b(t) + V(t + j\\Delta)` for every lag j.

    Parameters
    ----------
    rot, v_sonic : numpy.ndarray
        Rotation and sonic velocity on the extended grid (:func:`_ins_on_extended_grid`).
    b : numpy.ndarray
        (n, 3) sonic reading in the body frame on the grid [m s-1].
    n, n_half : int
        Grid length and half-width of the search [samples].

    Returns
    -------
    numpy.ndarray
        (2 n_half + 1,) mean TKE [m2 s-2].

    Notes
    -----
    Ghirardelli et al. (2025), Eq. 3, with :math:`b = M V_{sensor}` and :math:`V` the sonic velocity (INS
    velocity minus the lever-arm term). Because R is a rotation, :math:`|R b| = |b|`, so

    .. math::

        2\\,TKE_j = \\overline{|b|^2} + \\overline{|V_j|^2}
            + 2\\,\\overline{(R_j^T V_j)\\cdot b}
            - \\left|\\overline{R_j b} + \\overline{V_j}\\right|^2 ,

    and every lag-dependent mean is a cross-correlation of the rows of R and of
    :math:`R^T V` with b (:func:`lag_correlations`) or a sliding sum (:func:`_lag_sums`). All
    2J+1 lags are evaluated at once, O(n log n) instead of O(n J). The sums over disjoint
    sets of grid samples add up, so the curve of a grid split in two parts is that of the
    parts' sums added (:func:`_tke_curves`).
    """
    if b.shape[0] != n:
        raise ValueError(f"expected {n} grid samples of b, got {b.shape[0]}")
    return _tke_from_sums(_lag_sums(rot, v_sonic, b, n_half))


def find_sonic_ins_lag(lag_s: np.ndarray, tke_m2s2: np.ndarray) -> tuple[float, bool]:
    """Lag of minimum TKE (Ghirardelli et al. (2025), Sect. 3.3).

    Parameters
    ----------
    lag_s, tke_m2s2 : numpy.ndarray
        Output of :func:`tke_vs_lag`.

    Returns
    -------
    lag_sonic_ins_s : float
        The lag on the search grid with the smallest TKE [s] (time added to the sonic clock).
    at_edge : bool
        True if the minimum is at either end of the search range (search failed).
    """
    k = int(np.nanargmin(tke_m2s2))
    return float(lag_s[k]), bool(k == 0 or k == len(lag_s) - 1)


def subgrid_minimum(lag_s: np.ndarray, tke_m2s2: np.ndarray) -> float:
    """Lag of minimum TKE between the grid's lags: the vertex of the parabola through the minimum.

    Parameters
    ----------
    lag_s, tke_m2s2 : numpy.ndarray
        Output of :func:`tke_vs_lag` (an evenly spaced lag grid).

    Returns
    -------
    float
        Lag of minimum TKE [s]: the grid minimum moved to the vertex of the parabola through it
        and its two neighbours; the grid minimum itself where it lies at an end of the grid or
        the three points are not convex.

    Notes
    -----
    With :math:`k` the grid minimum, :math:`\\Delta` the grid step and
    :math:`E_j` the TKE at lag :math:`j`,

    .. math::

        \\tau = \\tau_k + \\frac{\\Delta}{2}\\,
        \\frac{E_{k-1} - E_{k+1}}{E_{k-1} - 2E_k + E_{k+1}} .

    Near its minimum the TKE grows with the square of the lag error (the motion left in the
    wind is proportional to it), so the parabola is its leading term. The applied lag stays
    on the grid (:func:`find_sonic_ins_lag`, as in Ghirardelli et al. (2025), Sect. 3.3);
    this estimate serves where the lag's change matters more than its value, e.g. the drift
    between the two halves of a hover: on the grid it moves in whole steps (1/32 s at
    32 Hz), a quantisation of the same order as a clock drift of a few hundred ppm over a
    ten-minute hover.
    """
    lag = np.asarray(lag_s, dtype=float)
    tke = np.asarray(tke_m2s2, dtype=float)
    k = int(np.nanargmin(tke))
    if k == 0 or k == len(lag) - 1:
        return float(lag[k])
    e0, e1, e2 = (float(x) for x in tke[k - 1:k + 2])
    curvature = e0 - 2.0 * e1 + e2
    if not (np.isfinite(curvature) and curvature > 0):
        return float(lag[k])
    # the vertex lies within half a step of the grid minimum (e1 is the smallest of the three)
    return float(lag[k] + 0.5 * (lag[k + 1] - lag[k]) * (e0 - e2) / curvature)
