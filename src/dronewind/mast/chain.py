"""The mast chain, datasets in and datasets out: raw files (by their declared format) to L1, L1 to a flight's L2.

The workflow steps (:mod:`dronewind.steps.payload`) wrap these functions in file input and
output; the diagnosis runs them in-process on forward-model flights
(:mod:`dronewind.diagnose.forward`). Settings come in explicitly, as the sub-mappings of
the workflow configuration; their defaults live once, in the configuration schema
(:func:`dronewind.manifest.default_config`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core import rotation as rot
from dronewind.core.raw import RawRecord
from dronewind.errors import DronewindError, InputError
from dronewind.manifest import record_format
from dronewind.mast import ameriflux, delimited, level1, toa5

__all__ = ["record_planar_fit", "compute_mast_l1", "window_coverage", "compute_mast_l2", "flight_reference",
           "unreadable_mast_l1", "unusable_mast_l2"]


def record_planar_fit(ds: xr.Dataset) -> dict[str, float | int | str]:
    """Planar fit of a mast sonic over all its 30-min blocks, as NetCDF attributes.

    Used when ``processing.rotation`` is ``planar_fit`` (Wilczak et al. 2001): the tilt of a
    fixed instrument is a property of the whole record, not of one flight.

    Parameters
    ----------
    ds : xarray.Dataset
        Mast L1 (``u_east_ms``, ``v_north_ms``, ``w_up_ms`` [m s-1], attr ``sampling_rate_hz``).

    Returns
    -------
    dict
        :func:`dronewind.core.rotation.planar_fit_attrs` of the fit, or the reason there is none.
    """
    u, v, w = rot.block_means(ds["time"].values, ds["u_east_ms"].values, ds["v_north_ms"].values,
                              ds["w_up_ms"].values, fs_hz=float(ds.attrs["sampling_rate_hz"]))
    try:
        fit, note = rot.planar_fit_tilt(u, v, w), ""
    except DronewindError as exc:
        fit, note = None, f"no planar fit: {exc}"
    return rot.planar_fit_attrs(fit, note)


def compute_mast_l1(files: Sequence[str | Path | RawRecord], sonic: Mapping[str, Any],
                    despike: Mapping[str, Any]) -> xr.Dataset:
    """Mast sonic L1 dataset from the sonic's files in their declared format, with the planar fit of the record.

    The reader is chosen by the sonic's ``format`` (absent: ``toa5``, the contract format):
    ``toa5`` -> :func:`dronewind.mast.level1.mast_l1`, ``gill_raw`` ->
    :func:`dronewind.mast.ameriflux.mast_l1_gill`, ``delimited`` ->
    :func:`dronewind.mast.delimited.mast_l1_delimited`. All three give the same variables
    (``u_east_ms``, ``v_north_ms``, ``w_up_ms``, ``t_sonic_k``, ``qc_mast``) on a regular
    grid and the attributes the later steps read (``sampling_rate_hz``, ``height_m``,
    ``sensor_id``, ``processing_log``).

    Parameters
    ----------
    files : sequence of path or RawRecord
        The sonic's files (concatenated in time order), or the simulator's in-memory TOA5
        records (:mod:`dronewind.core.raw`; format ``toa5`` only).
    sonic : mapping
        Manifest entry of the sonic (``id``, ``height_m`` [m], ``azimuth_deg`` [degree],
        optional ``model`` and ``format``).
    despike : mapping
        ``processing.despike``: ``window_s`` [s] and ``n_mad`` of the moving-MAD despiking.

    Returns
    -------
    xarray.Dataset
        Mast L1 in east/north/up with QC flags, attr ``input_format`` and the planar-fit
        attributes.

    Raises
    ------
    InputError
        A format no reader knows, or what the reader raises (file and line named).
    """
    fmt = record_format(sonic, "mast_sonic")
    name = fmt["name"]
    window_s, n_mad = float(despike["window_s"]), float(despike["n_mad"])
    if name == "toa5":
        ds = level1.mast_l1(files, azimuth_deg=float(sonic["azimuth_deg"]), height_m=float(sonic["height_m"]),
                          sensor_id=str(sonic["id"]), despike_window_s=window_s, despike_n_mad=n_mad)
    elif name in ("gill_raw", "delimited"):
        paths = [f for f in files if not isinstance(f, RawRecord)]
        if len(paths) != len(files):
            raise InputError(f"mast sonic {sonic['id']} format", f"{name!r} reads files only; in-memory records "
                             "are TOA5 (the simulator's format)")
        if name == "gill_raw":
            ds = ameriflux.mast_l1_gill(paths, fmt, sonic, despike_window_s=window_s, despike_n_mad=n_mad)
        else:
            ds = delimited.mast_l1_delimited(paths, fmt, sonic, despike_window_s=window_s, despike_n_mad=n_mad,
                                             where=f"mast sonic {sonic['id']} format")
    else:
        raise InputError(f"mast sonic {sonic['id']} format", f"{name!r}; expected toa5, gill_raw or delimited")
    ds.attrs["input_format"] = name
    ds.attrs.update(record_planar_fit(ds))
    return ds


def window_coverage(mast: xr.Dataset, cut: xr.Dataset, t0: np.datetime64, t1: np.datetime64) -> float:
    """Fraction of a time window covered by valid mast data [1].

    Parameters
    ----------
    mast : xarray.Dataset
        Whole mast record (attr ``sampling_rate_hz``, 10 Hz when absent).
    cut : xarray.Dataset
        The record cut around the window.
    t0, t1 : numpy.datetime64
        The window.

    Returns
    -------
    float
        Valid samples times the sampling interval over the window length, at most 1.
    """
    inside = cut.sel(time=slice(t0, t1))
    span_s = float((t1 - t0) / np.timedelta64(1, "s"))
    covered_s = 0.0
    if inside.sizes["time"] > 1:
        covered_s = np.isfinite(inside["u_east_ms"].values).sum() / float(mast.attrs.get("sampling_rate_hz", 10.0))
    return min(covered_s / span_s, 1.0) if span_s > 0 else 0.0


def compute_mast_l2(
    mast: xr.Dataset, drone_l2: xr.Dataset, flight_id: str, drone_mast: Mapping[str, Any],
    source: str | Path = "mast L1", margin_s: float = 30.0, min_coverage: float = 0.9,
) -> xr.Dataset:
    """The reference mast sonic over a flight's hover window.

    The window is the drone's L2 span widened by the drone-mast lag search range and a
    margin, so that alignment can shift the drone by up to ``max_lag_s`` either way.

    Parameters
    ----------
    mast : xarray.Dataset
        Mast L1 of the flight's reference sonic.
    drone_l2 : xarray.Dataset
        The drone's L2 (its time span is the hover window).
    flight_id : str
        Payload flight id (for messages and the processing log).
    drone_mast : mapping
        ``processing.drone_mast``: ``max_lag_s`` [s] of the drone-mast lag search.
    source : str or Path
        Name of the mast record in error messages.
    margin_s : float
        Extra margin on each side [s].
    min_coverage : float
        Least fraction of the hover window that valid mast data must cover [1].

    Returns
    -------
    xarray.Dataset
        The cut record, attrs ``flight_coverage_fraction`` and an extended ``processing_log``.

    Raises
    ------
    InputError
        When the valid mast data cover less than ``min_coverage`` of the hover window.
    """
    max_lag_s = float(drone_mast["max_lag_s"])
    t0, t1 = drone_l2["time"].values[0], drone_l2["time"].values[-1]
    pad = np.timedelta64(int((max_lag_s + margin_s) * 1e6), "us")
    cut = mast.sel(time=slice(t0 - pad, t1 + pad))
    coverage = window_coverage(mast, cut, t0, t1)
    if coverage < min_coverage:
        raise InputError(
            source,
            f"mast sonic covers {100 * coverage:.0f} % of flight {flight_id}'s hover window "
            f"{np.datetime_as_string(t0, 's')}Z to {np.datetime_as_string(t1, 's')}Z; expected at least "
            f"{100 * min_coverage:.0f} % (check the mast files and the flight times)",
        )
    cut.attrs.update(mast.attrs)
    cut.attrs["flight_coverage_fraction"] = round(float(coverage), 4)
    cut.attrs["processing_log"] = (
        str(mast.attrs.get("processing_log", "")) + f"\nmast_l2: cut to flight {flight_id} hover window "
        f"+/- {max_lag_s + margin_s:g} s; valid data cover {100 * coverage:.1f} % of the window"
    ).strip()
    return cut


def flight_reference(
    mast: xr.Dataset | InputError, drone_l2: xr.Dataset, flight_id: str, drone_mast: Mapping[str, Any],
    source: str | Path = "mast L1",
) -> tuple[xr.Dataset | None, str]:
    """A flight's reference mast over its hover window, or None and why it cannot be used.

    A mast record that cannot be read, or whose valid data do not cover the flight's
    window, does not stop the flight: the flight goes on as one without a reference
    (drone-only L3 and L4, :func:`dronewind.compare.chain.reference_unusable_l3`) with ``usable = 0`` and this
    reason, and the campaign's other flights are unaffected.

    Parameters
    ----------
    mast : xarray.Dataset or InputError
        Mast L1 of the flight's reference sonic (:func:`compute_mast_l1`; or
        :func:`unreadable_mast_l1`), or the error that reading it raised.
    drone_l2, flight_id, drone_mast, source
        As :func:`compute_mast_l2`.

    Returns
    -------
    mast_l2 : xarray.Dataset or None
        :func:`compute_mast_l2`, or None.
    reason : str
        Empty, or why the reference cannot be used (the file, line and error).
    """
    if isinstance(mast, InputError):
        return None, f"reference mast record cannot be read ({mast})"
    if "unreadable_reason" in mast.attrs:  # written by unreadable_mast_l1
        return None, f"reference mast record cannot be read ({mast.attrs['unreadable_reason']})"
    try:
        return compute_mast_l2(mast, drone_l2, flight_id, drone_mast, source=source), ""
    except InputError as exc:
        left_out = toa5.unreadable_files(mast)
        reason = f"reference mast record not usable over the flight's window ({exc})"
        if left_out:
            reason += f"; file(s) of the record left out as unreadable: {'; '.join(left_out)}"
        return None, reason


def unreadable_mast_l1(error: InputError, sonic: Mapping[str, Any]) -> xr.Dataset:
    """The mast L1 of a record that cannot be read: no samples, the error in ``unreadable_reason``.

    Written by the workflow's mast step in place of the L1, so that the flights referencing
    the sonic go on without it (:func:`flight_reference`) instead of the campaign stopping.

    Parameters
    ----------
    error : InputError
        What reading the record raised (file, line, what was expected).
    sonic : mapping
        Manifest entry of the sonic (``id``, ``height_m``).

    Returns
    -------
    xarray.Dataset
        The L1 variables with zero samples; attrs ``unreadable_reason``, ``sensor_id``,
        ``height_m``, ``processing_log``.
    """
    from dronewind.core.cf import variable_attrs

    empty = np.zeros(0)
    ds = xr.Dataset(
        {"u_east_ms": ("time", empty, variable_attrs("m s-1", "eastward_wind")),
         "v_north_ms": ("time", empty, variable_attrs("m s-1", "northward_wind")),
         "w_up_ms": ("time", empty, variable_attrs("m s-1", "upward_air_velocity")),
         "t_sonic_k": ("time", empty, variable_attrs("K", "virtual_temperature",
                                                     units_metadata="temperature: on_scale"))},
        coords={"time": ("time", np.zeros(0, dtype="datetime64[ns]"), {"long_name": "time (UTC)"})},
    )
    ds.attrs.update(unreadable_reason=str(error), sensor_id=str(sonic["id"]), height_m=float(sonic["height_m"]),
                    processing_log=f"read: the record cannot be read: {error}")
    return ds


def unusable_mast_l2(reason: str) -> xr.Dataset:
    """The mast L2 of a flight whose reference cannot be used: no samples, ``reference_unusable_reason``.

    Parameters
    ----------
    reason : str
        :func:`flight_reference`'s reason.

    Returns
    -------
    xarray.Dataset
    """
    ds = unreadable_mast_l1(InputError("mast L2", reason), {"id": "", "height_m": float("nan")})
    ds.attrs = {"reference_unusable_reason": reason, "flight_coverage_fraction": 0.0,
                "processing_log": f"mast_l2: {reason}"}
    return ds
