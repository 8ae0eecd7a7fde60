"""Library names and CF names of the products: the GNSS track and the station coordinates.

The chain works with the library's names (``lat_deg``, ``lon_deg``, ``alt_m``); the products
carry the CF conventions' names of a moving platform's track (CF 1.8, Appendix H.5:
``precise_lat``, ``precise_lon``, ``altitude``; :func:`track_to_cf`, :func:`track_from_cf`)
and the scalar station coordinates added by :func:`dronewind.core.cf.write_netcdf`, which
:func:`strip_cf` drops again so that a product read back can be processed and re-written.
"""

from __future__ import annotations

import xarray as xr

#: GNSS track of a moving platform: library name -> CF H.5 name.
_TRACK_NAMES = (("lat_deg", "precise_lat"), ("lon_deg", "precise_lon"), ("alt_m", "altitude"))


#: Scalar station coordinates added by :func:`write_netcdf` (removed by :func:`strip_cf`).
_STATION_COORDS = ("station", "lat", "lon", "alt")


def track_to_cf(ds: xr.Dataset) -> xr.Dataset:
    """GNSS track of a hovering platform as CF H.5 ``precise_lat/precise_lon(time)`` and ``altitude``.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset with the library's ``lat_deg``, ``lon_deg``, ``alt_m`` (any of them).

    Returns
    -------
    xarray.Dataset
        Renamed, with CF attributes added to the existing ones.
    """
    out = ds.rename({k: v for k, v in _TRACK_NAMES if k in ds.variables})
    if "precise_lat" in out:
        out["precise_lat"].attrs.update(standard_name="latitude", units="degrees_north",
                                        long_name="GNSS latitude of the platform")
    if "precise_lon" in out:
        out["precise_lon"].attrs.update(standard_name="longitude", units="degrees_east",
                                        long_name="GNSS longitude of the platform")
    if "altitude" in out:
        out["altitude"].attrs.update(standard_name="altitude", units="m", positive="up",
                                     long_name="GNSS altitude above mean sea level")
    return out


def track_from_cf(ds: xr.Dataset) -> xr.Dataset:
    """Inverse of :func:`track_to_cf`: the GNSS track back under the library's names.

    Parameters
    ----------
    ds : xarray.Dataset
        A product read back (``precise_lat``, ``precise_lon``, ``altitude``).

    Returns
    -------
    xarray.Dataset
        With ``lat_deg``, ``lon_deg``, ``alt_m``.
    """
    return ds.rename({cf: lib for lib, cf in _TRACK_NAMES if cf in ds.variables})


def strip_cf(ds: xr.Dataset) -> xr.Dataset:
    """Drop the writer's station coordinates so that a product read back can be processed and re-written.

    Parameters
    ----------
    ds : xarray.Dataset
        A product read back (see :func:`dronewind.core.products.open_product`).

    Returns
    -------
    xarray.Dataset
        Without ``station``, ``lat``, ``lon``, ``alt`` and without ``coordinates`` attributes
        or encodings (they are re-derived on writing).
    """
    out = ds.drop_vars([c for c in _STATION_COORDS if c in ds.variables])
    for var in out.variables.values():
        var.attrs.pop("coordinates", None)
        var.encoding.pop("coordinates", None)
    return out
