"""The comparison chain, datasets in and datasets out: drone and mast L2 to L3, L3 to L4.

The workflow steps (:mod:`dronewind.steps.payload`) wrap these functions in file input and
output; the diagnosis runs :func:`compute_l3` in-process on forward-model flights
(:mod:`dronewind.diagnose.forward`). Settings come in explicitly, as the sub-mappings of
the workflow configuration; their defaults live once, in the configuration schema
(:func:`dronewind.manifest.default_config`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from dronewind.compare.align import align_drone_mast
from dronewind.compare.l4 import flight_l4
from dronewind.core import rotation as rot
from dronewind.core.angles import rad2deg
from dronewind.errors import ProcessingError

__all__ = ["planar_fits", "compute_l3", "compute_drone_l3", "compute_l4", "period_time", "reference_unusable_l3"]

#: Global attributes of the L3 that each L4 keeps.
_L4_ATTRS = ("lag_sonic_ins_s", "lag_drone_mast_s", "drone_usable", "drone_unusable_reason", "reference")


def planar_fits(mast_l2: xr.Dataset, rotation: str) -> dict[str, rot.PlanarFit] | None:
    """The mast's stored planar fit when ``rotation == "planar_fit"``, else ``None``.

    Parameters
    ----------
    mast_l2 : xarray.Dataset
        Mast L2 with the attributes of :func:`dronewind.mast.chain.record_planar_fit`.
    rotation : str
        ``processing.rotation``.

    Returns
    -------
    dict or None
        ``{"mast": fit}``.

    Raises
    ------
    ProcessingError
        ``planar_fit`` requested but the mast record has no planar fit.
    """
    if rotation != "planar_fit":
        return None
    fit = rot.planar_fit_from_attrs(dict(mast_l2.attrs))
    if fit is None:
        raise ProcessingError(
            f"rotation 'planar_fit' requested but mast sonic {mast_l2.attrs.get('sensor_id', '?')} has no planar fit: "
            f"{mast_l2.attrs.get('planar_fit_note', 'not computed')} (choose rotation: double, or provide a longer "
            "mast record with at least 3 half-hours from several directions)")
    return {"mast": fit}


def _streamline_attrs(ds: xr.Dataset) -> None:
    """CF names of the streamline components (in place).

    CF ``x_wind``/``y_wind`` are components along the axes of the coordinate system in
    use; here x points along the mean wind of each sensor.
    """
    ds["u_ms"].attrs.update(standard_name="x_wind", comment="x axis along the mean wind (streamline coordinates)")
    ds["v_ms"].attrs.update(standard_name="y_wind", comment="y axis 90 degrees counter-clockwise from x")
    ds["w_ms"].attrs.update(standard_name="upward_air_velocity", comment="normal to the mean streamline plane")


def compute_l3(
    drone_l2: xr.Dataset, mast_l2: xr.Dataset, flight: Mapping[str, Any], drone_mast: Mapping[str, Any], rotation: str
) -> xr.Dataset:
    """L3: drone-mast lag, common 8 Hz base, streamline rotation (see :func:`dronewind.compare.align.align_drone_mast`).

    Parameters
    ----------
    drone_l2, mast_l2 : xarray.Dataset
        L2 of the drone and of its reference mast sonic over the flight.
    flight : mapping
        Payload flight entry of the manifest (``target_height_m`` when the L2 has no height).
    drone_mast : mapping
        ``processing.drone_mast``: ``max_lag_s`` [s] and ``decimation`` (Ghirardelli et al. (2025), Sect. 4.4).
    rotation : str
        ``processing.rotation``: ``single``, ``double``, ``triple`` or ``planar_fit`` (the
        mast's whole-record fit; the drone is double-rotated).

    Returns
    -------
    xarray.Dataset
        Both sensors aligned, decimated, in streamline coordinates, with the drone's lag and
        usability attributes.
    """
    ds = align_drone_mast(
        drone_l2, mast_l2, max_lag_s=float(drone_mast["max_lag_s"]), decimate=int(drone_mast["decimation"]),
        rotation=rotation, planar_fit=planar_fits(mast_l2, rotation),
        drone_height_m=float(drone_l2.attrs.get("height_m", flight.get("target_height_m", float("nan")))),
    )
    ds.attrs["lag_sonic_ins_s"] = float(drone_l2.attrs.get("lag_sonic_ins_s", float("nan")))
    ds.attrs["drone_usable"] = int(drone_l2.attrs.get("usable", 1))
    ds.attrs["drone_unusable_reason"] = str(drone_l2.attrs.get("unusable_reason", ""))
    if rotation == "planar_fit":
        ds.attrs["rotation_note"] = ("planar fit (Wilczak et al. 2001) for the mast sonic, from its whole record; "
                                     "double rotation for the drone, whose frame is re-levelled every flight")
    _streamline_attrs(ds)
    return ds


def compute_drone_l3(drone_l2: xr.Dataset, flight: Mapping[str, Any], rotation: str) -> xr.Dataset:
    """Drone-only L3 of a flight without a reference mast: the L2 in streamline coordinates.

    No alignment and no decimation (there is no second sensor): the record stays at its L2
    rate, rotated by ``rotation`` (``planar_fit`` needs a mast's whole-record fit, so the
    drone is double-rotated, as it is beside a mast). The layout is that of
    :func:`compute_l3` with the one sensor ``drone``, so :func:`compute_l4` reads both.

    Parameters
    ----------
    drone_l2 : xarray.Dataset
        L2 of the drone (regular time axis).
    flight : mapping
        Payload flight entry of the manifest (``target_height_m`` when the L2 has no height).
    rotation : str
        ``processing.rotation``.

    Returns
    -------
    xarray.Dataset
        ``u_ms``, ``v_ms``, ``w_ms``, ``theta_v_k`` on (sensor, time), ``height_m`` and
        ``wind_from_deg`` on sensor; attrs ``sampling_rate_hz``, ``rotation_method``,
        ``lag_sonic_ins_s``, ``drone_usable``, ``drone_unusable_reason``.
    """
    u_e, v_n, w_u = (np.asarray(drone_l2[k].values, dtype=float) for k in ("u_east_ms", "v_north_ms", "w_up_ms"))
    method = "double" if rotation == "planar_fit" else rotation
    u, v, w, angles = rot.rotate(u_e, v_n, w_u, method)
    height = float(drone_l2.attrs.get("height_m", flight.get("target_height_m", float("nan"))))
    wind_from = float(rad2deg(np.arctan2(-np.mean(u_e), -np.mean(v_n))) % 360.0)
    fs = float(drone_l2.attrs["sampling_rate_hz"])
    two = ("sensor", "time")

    def one(x: np.ndarray, units: str, **attrs: Any) -> xr.DataArray:
        return xr.DataArray(np.asarray(x)[None, :], dims=two, attrs={"units": units, **attrs})

    ds = xr.Dataset(
        {"u_ms": one(u, "m s-1", long_name="streamwise wind"), "v_ms": one(v, "m s-1", long_name="cross wind"),
         "w_ms": one(w, "m s-1", long_name="vertical wind"),
         "theta_v_k": one(drone_l2["t_sonic_k"].values, "K", standard_name="virtual_temperature",
                          units_metadata="temperature: on_scale"),
         "height_m": xr.DataArray([height], dims=("sensor",), attrs={"units": "m", "long_name": "height above ground"}),
         "wind_from_deg": xr.DataArray([wind_from], dims=("sensor",), attrs={
             "units": "degree", "standard_name": "wind_from_direction"})},
        coords={"sensor": ("sensor", ["drone"]), "time": ("time", drone_l2["time"].values)},
    )
    ds.attrs.update({
        "sampling_rate_hz": fs, "rotation_method": method,
        **{f"rotation_{k}": float(a) for k, a in angles.items()},
        "lag_sonic_ins_s": float(drone_l2.attrs.get("lag_sonic_ins_s", float("nan"))),
        "drone_usable": int(drone_l2.attrs.get("usable", 1)),
        "drone_unusable_reason": str(drone_l2.attrs.get("unusable_reason", "")),
        "processing_log": f"l3 drone only (no reference mast): {method} rotation at {fs:g} Hz, no decimation",
    })
    _streamline_attrs(ds)
    return ds


def period_time(ds: xr.Dataset, times: np.ndarray) -> xr.Dataset:
    """Scalar time coordinate (mid-period) with bounds for statistics over a record (CF 7.1).

    Parameters
    ----------
    ds : xarray.Dataset
        Statistics of a record.
    times : numpy.ndarray
        Time stamps of the record (datetime64).

    Returns
    -------
    xarray.Dataset
        With ``time`` (one value, the middle of the record, ``bounds = "time_bnds"``) and
        ``time_bnds(time, nv)``.
    """
    t0, t1 = times.min(), times.max()
    out = ds.assign_coords(time=xr.DataArray([t0 + (t1 - t0) / 2], dims=("time",), attrs={"bounds": "time_bnds"}))
    out["time_bnds"] = xr.DataArray(np.array([[t0, t1]]), dims=("time", "nv"))
    return out


def compute_l4(l3: xr.Dataset, sensor: str, spectra: Mapping[str, Any], quadrant: Mapping[str, Any],
               detrending: str) -> xr.Dataset:
    """L4 of one sensor (see :func:`dronewind.compare.l4.flight_l4`) with a period time coordinate.

    Parameters
    ----------
    l3 : xarray.Dataset
        L3 of the flight.
    sensor : str
        ``"drone"`` or ``"mast"``.
    spectra : mapping
        ``processing.spectra``: Welch ``segments``, ``overlap`` [1] and smoothing ``bins``.
    quadrant : mapping
        ``processing.quadrant``: ``fr_min``, ``fr_max`` (reduced-frequency band) and
        ``min_speed_ms`` [m s-1] of the quadrant ratios.
    detrending : {"linear", "block_mean"}
        ``processing.detrending``: fluctuations about a line or the block mean.

    Returns
    -------
    xarray.Dataset
        Statistics, spectra, fits, uncertainties and scales, with the L3's lag and
        usability attributes (Ghirardelli et al. (2025), Sects. 4.1-4.3).
    """
    ds = flight_l4(
        l3, sensor, n_segments=int(spectra["segments"]), overlap=float(spectra["overlap"]),
        n_bins=int(spectra["bins"]), fr_band=(float(quadrant["fr_min"]), float(quadrant["fr_max"])),
        quadrant_min_speed_ms=float(quadrant["min_speed_ms"]), detrending=str(detrending),
    )
    for key in _L4_ATTRS:
        if key in l3.attrs:
            ds.attrs[key] = l3.attrs[key]
    return period_time(ds, l3["time"].values)


def reference_unusable_l3(drone_l2: xr.Dataset, flight: Mapping[str, Any], rotation: str,
                          reason: str) -> xr.Dataset:
    """The drone-only L3 of a flight whose reference mast cannot be used, marked ``usable = 0``.

    The same L3 as a flight without a reference (:func:`dronewind.compare.chain.compute_drone_l3`:
    the drone in streamline coordinates at its L2 rate), so its L4 is the drone's; attrs
    ``drone_usable`` = 0 and ``drone_unusable_reason`` (the drone's own reason, if any, then
    ``reason``), ``reference_unusable_reason`` = ``reason``.

    Parameters
    ----------
    drone_l2 : xarray.Dataset
        L2 of the drone.
    flight : mapping
        Payload flight entry of the manifest.
    rotation : str
        ``processing.rotation``.
    reason : str
        Why the reference cannot be used (:func:`flight_reference`).

    Returns
    -------
    xarray.Dataset
    """
    ds = compute_drone_l3(drone_l2, flight, rotation)
    own = str(ds.attrs.get("drone_unusable_reason", ""))
    ds.attrs["drone_usable"] = 0
    ds.attrs["drone_unusable_reason"] = f"{own}; {reason}" if own else reason
    ds.attrs["reference_unusable_reason"] = reason
    ds.attrs["processing_log"] = (str(ds.attrs.get("processing_log", "")) + f"\nl3: drone only: {reason}").strip()
    return ds
