r"""Hover selection of a quadrotor flight and its position accuracy (Wetz et al. (2021), Sect. 4.3).

A "drone tower" flight climbs to its height, holds its position and descends; only the
hover measures the wind. :func:`hover_segment` finds the longest run of samples that stay
still and inside a box around the median hover position (short excursions are bridged);
a UAV that never hovers raises :class:`dronewind.errors.InputError` naming it.

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (SWUF-3D), Wetz et al. (2021)
  , Sect. 4.3.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from dronewind.core.geo import local_tangent_plane_m
from dronewind.errors import InputError

__all__ = ["hover_segment", "hover_accuracy"]

#: Mean earth radius of the local east/north approximation [m].


def _longest_run(mask: np.ndarray) -> tuple[int, int]:
    """Start and stop (exclusive) of the longest run of True values (0, 0 if none)."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    starts = np.flatnonzero(d == 1)
    stops = np.flatnonzero(d == -1)
    if starts.size == 0:
        return 0, 0
    k = int(np.argmax(stops - starts))
    return int(starts[k]), int(stops[k])


def _close_gaps(mask: np.ndarray, max_gap: int) -> np.ndarray:
    """Fill False gaps of at most ``max_gap`` samples between True samples."""
    if max_gap <= 0 or not mask.any():
        return mask
    m = mask.copy()
    idx = np.flatnonzero(mask)
    gaps = np.diff(idx) - 1
    for i in np.flatnonzero((gaps > 0) & (gaps <= max_gap)):
        m[idx[i] + 1: idx[i + 1]] = True
    return m


def _local_en_m(lat_deg: np.ndarray, lon_deg: np.ndarray, lat0: float,
                lon0: float) -> tuple[np.ndarray, np.ndarray]:
    """East and north of (lat0, lon0) [m] on the WGS84 tangent plane (:mod:`dronewind.core.geo`)."""
    return local_tangent_plane_m(lat_deg, lon_deg, lat0, lon0)


def hover_segment(ds: xr.Dataset, horiz_tol_m: float = 4.0, alt_tol_m: float = 3.0,
                  max_speed_ms: float = 1.5, max_gap_s: float = 2.0,
                  min_duration_s: float = 60.0, where: str = "quadrotor log") -> tuple[np.ndarray, dict]:
    r"""Select the hover state of a quadrotor flight (Wetz et al. (2021), Sect. 4.3).

    Parameters
    ----------
    ds : xarray.Dataset
        Quadrotor log (:func:`dronewind.quadrotor.io.read_quadrotor`).
    horiz_tol_m, alt_tol_m : float
        Largest horizontal / vertical distance from the hover position [m].
    max_speed_ms : float
        Largest horizontal and vertical GNSS speed while hovering [m s-1].
    max_gap_s : float
        Excursions shorter than this inside the hover are kept [s].
    min_duration_s : float
        Shortest acceptable hover [s].
    where : str
        Name used in error messages (file or UAV id).

    Returns
    -------
    mask : numpy.ndarray of bool
        True inside the hover segment (the longest contiguous run).
    info : dict
        ``start``, ``end`` (datetime64), ``duration_s``, ``lat_deg``, ``lon_deg``,
        ``alt_m`` (median hover position), ``sigma_h_m``, ``sigma_v_m`` (see
        :func:`hover_accuracy`), ``n_hover``, ``n_excluded`` (samples outside the hover).

    Raises
    ------
    InputError
        If the vehicle never hovers (no still sample, or the longest hover is shorter than
        ``min_duration_s``).
    """
    t = ds["time"].to_numpy()
    n = t.size
    vn, ve, vd = (ds[k].to_numpy() for k in ("vel_n_ms", "vel_e_ms", "vel_d_ms"))
    lat, lon, alt = (ds[k].to_numpy() for k in ("lat_deg", "lon_deg", "alt_m"))
    still = (np.hypot(vn, ve) < max_speed_ms) & (np.abs(vd) < max_speed_ms) & np.isfinite(lat) \
        & np.isfinite(alt)
    if not still.any():
        raise InputError(where, "the UAV never hovers: no sample with GNSS speed below "
                                f"{max_speed_ms} m/s and a valid position")
    lat0, lon0, alt0 = (float(np.median(x[still])) for x in (lat, lon, alt))
    east, north = _local_en_m(lat, lon, lat0, lon0)
    inbox = still & (np.hypot(east, north) <= horiz_tol_m) & (np.abs(alt - alt0) <= alt_tol_m)
    fs = float(ds.attrs.get("sampling_rate_hz") or (1e9 / np.median(np.diff(t.astype("int64")))))
    inbox = _close_gaps(inbox, int(round(max_gap_s * fs)))
    i0, i1 = _longest_run(inbox)
    duration = (t[i1 - 1] - t[i0]).astype("int64") / 1e9 if i1 > i0 else 0.0
    if duration < min_duration_s:
        raise InputError(where, f"the UAV never hovers: longest hover {duration:.0f} s within "
                                f"{horiz_tol_m} m horizontally and {alt_tol_m} m vertically; "
                                f"at least {min_duration_s:.0f} s expected")
    mask = np.zeros(n, dtype=bool)
    mask[i0:i1] = True
    acc = hover_accuracy(ds, mask)
    info = {"start": t[i0], "end": t[i1 - 1], "duration_s": float(duration),
            "lat_deg": float(np.nanmedian(lat[mask])), "lon_deg": float(np.nanmedian(lon[mask])),
            "alt_m": float(np.nanmedian(alt[mask])), "n_hover": int(mask.sum()),
            "n_excluded": int(n - mask.sum()), **acc}
    return mask, info


def hover_accuracy(ds: xr.Dataset, mask: np.ndarray) -> dict[str, float]:
    r"""Position standard deviations during hover (Wetz et al. (2021), Sect. 4.3).

    Parameters
    ----------
    ds : xarray.Dataset
        Quadrotor log with ``lat_deg``, ``lon_deg``, ``alt_m``.
    mask : numpy.ndarray of bool
        Hover samples.

    Returns
    -------
    dict
        ``sigma_h_m``: horizontal standard deviation per axis,
        :math:`\sqrt{(\sigma_E^2+\sigma_N^2)/2}` [m] (Wetz et al. (2021) reports 0.19 m);
        ``sigma_v_m``: vertical standard deviation [m] (Wetz et al. (2021): 0.85 m).
    """
    lat = ds["lat_deg"].to_numpy()[mask]
    lon = ds["lon_deg"].to_numpy()[mask]
    alt = ds["alt_m"].to_numpy()[mask]
    e, nn = _local_en_m(lat, lon, np.nanmedian(lat), np.nanmedian(lon))
    return {"sigma_h_m": float(np.sqrt(0.5 * (np.nanvar(e) + np.nanvar(nn)))),
            "sigma_v_m": float(np.nanstd(alt))}

