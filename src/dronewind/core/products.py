"""Reading stored dronewind products: NetCDF files with their groups, L4 files by flight and sensor.

The readers of the top layer (figures, tables, workflow steps): they open what
:func:`dronewind.core.cf.write_netcdf` wrote and hand back plain :class:`xarray.Dataset`
objects and stored scalars; nothing is computed here.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np
import xarray as xr

from dronewind.errors import InputError

__all__ = ["L4Products", "drone_usable", "load_l4_products", "open_by_flight", "open_product", "stored_scalar"]

PathLike = str | Path

#: L4 products of a campaign: ``{flight: {"drone": Dataset, "mast": Dataset}}``.
L4Products = dict[str, dict[str, xr.Dataset]]


def open_product(path: str | Path, variables: Sequence[str] | None = None, time: slice | None = None) -> xr.Dataset:
    """Open a dronewind NetCDF with all its groups merged into one dataset.

    Quantities without a CF standard name live in NetCDF-4 groups (see
    :mod:`dronewind.core.cf`); this reads the root group and every group listed in the
    global attribute ``groups`` and merges them (global attributes of the root kept).

    Parameters
    ----------
    path : str or Path
        A file written by :func:`dronewind.core.cf.write_netcdf`.
    variables : sequence of str, optional
        Read only these variables (those the file has; groups holding none are skipped);
        all by default.
    time : slice, optional
        Read only these times (a ``slice`` of datetime64 on the ``time`` axis) of the groups
        that have one; all by default. With ``variables``, only that window of those
        variables is loaded (the time axis is read whole to find it): an 8-day 20 Hz mast
        record cut to 2.5 h peaked at 537 MB instead of 735 MB loading everything.

    Returns
    -------
    xarray.Dataset
        Loaded into memory.

    Raises
    ------
    InputError
        The file exists but HDF5 cannot open it: what it holds (its size and whether it
        starts with the HDF5 signature) and the likely causes are named.
    """
    try:
        with xr.open_dataset(path, engine="netcdf4") as root:
            ds = _selected(root, variables, time).load()
            ds.attrs = dict(root.attrs)
    except OSError as exc:
        if not Path(path).is_file():
            raise
        raise InputError(path, f"not readable as a NetCDF-4 file ({exc}); {_file_condition(Path(path))}") from exc
    names = [g.strip() for g in str(ds.attrs.get("groups", "")).split(",") if g.strip()]
    parts = [ds]
    for name in names:
        with xr.open_dataset(path, group=name, engine="netcdf4") as group:
            if variables is None or any(v in group.variables for v in variables):
                parts.append(_selected(group, variables, time).load())
    merged = xr.merge(parts, compat="override", join="outer", combine_attrs="override")
    merged.attrs = dict(ds.attrs)
    for var in list(merged.variables):
        if not (isinstance(var, str) and var.endswith("_name")):
            continue
        dim = var[: -len("_name")]
        if dim and dim in merged.dims and merged[var].dims == (dim,):
            merged = merged.assign_coords({dim: merged[var].values.astype(str)}).drop_vars(var)
    return merged


def _selected(ds: xr.Dataset, variables: Sequence[str] | None, time: slice | None) -> xr.Dataset:
    """The lazily opened ``ds`` reduced to ``variables`` and ``time`` (:func:`open_product`), before loading."""
    if variables is not None:
        ds = ds[[v for v in variables if v in ds.data_vars]]
    if time is not None and "time" in ds.dims:
        ds = ds.sel(time=time)
    return ds


def _file_condition(path: Path) -> str:
    """What a file that HDF5 refused holds, and the usual causes, for the error message."""
    with path.open("rb") as fh:
        head = fh.read(8)
    size = path.stat().st_size
    if head == b"\x89HDF\r\n\x1a\n":
        return (f"it is an HDF5 file of {size} bytes: truncated or damaged, or locked by a process still "
                "writing it (HDF5 file locking; HDF5_USE_FILE_LOCKING=FALSE turns it off)")
    return f"{size} bytes without the HDF5 signature (expected a file written by dronewind.core.cf.write_netcdf)"


def open_by_flight(files: Iterable[PathLike]) -> dict[str, xr.Dataset]:
    """Open one product per flight (L2 drone or L3 files) and index them by flight.

    Parameters
    ----------
    files : iterable of path
        Product files; the flight is the global attribute ``flight``, else the file name
        up to its first underscore.

    Returns
    -------
    dict of str to xarray.Dataset
        Flight -> product, flights in sorted order (a later file of the same flight wins).
    """
    out = {}
    for path in files:
        ds = open_product(path)
        flight = str(ds.attrs.get("flight", Path(path).stem.split("_")[0]))
        out[flight] = ds
    return {k: out[k] for k in sorted(out)}


def load_l4_products(l4_files: Iterable[PathLike] | L4Products) -> L4Products:
    """Open L4 files and index them by flight and sensor.

    Parameters
    ----------
    l4_files : iterable of path, or L4Products
        L4 files (``<flight>_<sensor>.nc``) written by :func:`dronewind.steps.l4`; products
        already loaded by this function are returned as they are (a caller drawing several
        figures opens the files once).

    Returns
    -------
    dict
        ``{flight: {"drone": Dataset, "mast": Dataset}}`` (a sensor absent when its file is
        not given), flights in sorted order.

    Raises
    ------
    InputError
        A file without the global attributes ``flight`` and ``sensor``, or two files for
        the same flight and sensor.
    """
    if isinstance(l4_files, Mapping):
        return {flight: dict(sensors) for flight, sensors in l4_files.items()}
    out: L4Products = {}
    for path in l4_files:
        ds = open_product(path)
        flight, sensor = ds.attrs.get("flight"), ds.attrs.get("sensor")
        if flight is None or sensor is None:
            raise InputError(str(path), "expected global attributes 'flight' and 'sensor' (an L4 product)")
        slot = out.setdefault(str(flight), {})
        if str(sensor) in slot:
            raise InputError(str(path), f"second L4 file for flight {flight} sensor {sensor}")
        slot[str(sensor)] = ds
    return {k: out[k] for k in sorted(out)}


def stored_scalar(ds: xr.Dataset | None, name: str) -> float:
    """A stored scalar (the first element of the variable), NaN when the product or variable is missing.

    Parameters
    ----------
    ds : xarray.Dataset or None
        Product.
    name : str
        Variable name.

    Returns
    -------
    float
        The stored value [units of the variable].
    """
    if ds is None or name not in ds.variables:
        return math.nan
    return float(np.asarray(ds[name].values).reshape(-1)[0])


def drone_usable(products: Mapping[str, xr.Dataset]) -> tuple[bool, str]:
    """Whether a flight's drone record is usable, and the stored reason when it is not.

    Parameters
    ----------
    products : mapping
        One flight's L4 products (``{"drone": Dataset, "mast": Dataset}``).

    Returns
    -------
    usable : bool
        The drone L4 attribute ``drone_usable`` (true when absent); false without a drone product.
    reason : str
        The attribute ``drone_unusable_reason`` ("" when absent).
    """
    drone = products.get("drone")
    if drone is None:
        return False, "no drone L4 product"
    return bool(int(drone.attrs.get("drone_usable", 1))), str(drone.attrs.get("drone_unusable_reason", ""))
