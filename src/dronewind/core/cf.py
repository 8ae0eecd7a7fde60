"""The one place that writes NetCDF: CF-1.11 / ACDD-1.3 metadata, provenance, atomic write.

Every NetCDF file of the workflow goes through :func:`write_netcdf`. It

* declares ``Conventions = "CF-1.11, ACDD-1.3"`` (comma separated: the IOOS checker's
  ACDD suite splits on commas),
* adds the ACDD discovery attributes (title, summary, keywords, creator, time and
  geospatial coverage, processing level, licence),
* adds provenance: package version, a SHA-256 of the settings the product was computed
  with (``config_sha256``: for a workflow product, only the configuration keys its rule
  receives as ``params``, nested as in ``config.yaml``, so that changing a setting that
  a product does not use leaves its hash alone) and the SHA-256 of every input file, and
  a ``history`` line,
* encodes time as integer microseconds since 1970-01-01 UTC, without ``_FillValue`` and
  with ``units_metadata = "leap_seconds: none"``; temperatures get
  ``units_metadata = "temperature: on_scale"``,
* for ``featureType = "timeSeries"`` (CF Appendix H.4) adds the station identifier
  (``cf_role = "timeseries_id"``) and the nominal position as scalar coordinates; a moving
  platform's GNSS track goes in ``precise_lat(time)``/``precise_lon(time)`` (Appendix H.5),
* keeps quantities that have no CF standard name (streamwise spectra, fitted spectral
  parameters, normalised uncertainties, quadrant ratios, ...) in named NetCDF-4 groups
  (CF 1.8+ Sect. 2.7), each variable with ``long_name`` and ``units``, while the root group
  holds the standard-named variables. The IOOS checker examines the root group, where
  ACDD 1.3 asks every data variable for a ``standard_name``; the groups are documented in
  the global attribute ``groups`` so readers know where to look,
* writes to a temporary file in the destination folder and renames it into place, so an
  interrupted run never leaves a half-written file that Snakemake would take as done.

The renaming between the library's variable names and the CF names of the products, used
by every chain that reads a product back, is :mod:`dronewind.core.cf_names`.

Reproducibility: the data are bit-identical for identical inputs and configuration. The
only time-dependent attribute is ``date_created``; set the environment variable
``SOURCE_DATE_EPOCH`` (reproducible-builds convention) to fix it too.
"""

from __future__ import annotations

import datetime as _dt
import errno
import hashlib
import json
import os
import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from dronewind import __version__
from dronewind.core.attribution import ATTRIBUTION_KEYS

CONVENTIONS = "CF-1.11, ACDD-1.3"
STANDARD_NAME_VOCABULARY = "CF Standard Name Table v93"  # packaged with the checker: no download
TIME_UNITS = "microseconds since 1970-01-01 00:00:00"

#: Attributes set on every file (ACDD "recommended" group that does not vary).
_FIXED_GLOBAL_ATTRS: dict[str, str] = {
    "Conventions": CONVENTIONS,
    "standard_name_vocabulary": STANDARD_NAME_VOCABULARY,
    "naming_authority": "org.dronewind",
    "institution": "dronewind project",
    "project": "dronewind: validation of drone-borne wind and turbulence measurements",
    "creator_name": "dronewind workflow",
    "creator_type": "group",
    "creator_email": "dronewind@users.noreply.github.com",
    "creator_url": "https://github.com/dronewind/dronewind",
    "creator_institution": "dronewind project",
    "publisher_name": "dronewind workflow",
    "publisher_type": "group",
    "publisher_email": "dronewind@users.noreply.github.com",
    "publisher_url": "https://github.com/dronewind/dronewind",
    "publisher_institution": "dronewind project",
    "license": "CC-BY-4.0",
    "acknowledgment": "Methods after Ghirardelli et al. (SAMURAI-S) and Wetz et al. (SWUF-3D).",
    "platform_vocabulary": "https://vocab.nerc.ac.uk/collection/L06/current/",
    "instrument_vocabulary": "https://vocab.nerc.ac.uk/collection/L05/current/",
    "keywords_vocabulary": "GCMD Science Keywords",
    "product_version": __version__,
    "software_version": __version__,
}

#: ``source`` global attribute by origin of the raw data: a manifest without a ``simulation:``
#: section is measured data, one with it a virtual campaign (raw files written by the simulator).
DATA_SOURCES: dict[str, str] = {
    "measured": "measured: sonic anemometers (and INS or quadrotor logs) on drones and masts, raw files "
                "named by the campaign manifest",
    "virtual": "virtual campaign: raw files written by the dronewind simulator (dronewind.simulate), "
               "not measured",
    "unknown": "not recorded: written outside the dronewind workflow",
}


def data_source(simulated: bool) -> str:
    """The ``source`` attribute of a product: measured data or the virtual campaign.

    Parameters
    ----------
    simulated : bool
        True when the campaign manifest has a ``simulation:`` section.
    """
    return DATA_SOURCES["virtual" if simulated else "measured"]


def _inherited_source(inputs: Iterable[str | Path]) -> str | None:
    """The ``source`` of the NetCDF inputs a product is computed from (None if none has one)."""
    return _inherited(inputs).get("source")


def _inherited(inputs: Iterable[str | Path]) -> dict[str, str]:
    """``source`` and the attribution (:data:`ATTRIBUTION_KEYS`) of the NetCDF inputs, joined by `` + ``."""
    import netCDF4

    found: dict[str, list[str]] = {}
    for path in map(Path, inputs):
        if path.suffix != ".nc" or not path.is_file():
            continue
        with netCDF4.Dataset(path) as nc:
            for key in ("source", *ATTRIBUTION_KEYS):
                if key in nc.ncattrs():
                    found.setdefault(key, []).append(str(nc.getncattr(key)))
    return {k: " + ".join(dict.fromkeys(v)) for k, v in found.items()}


_KEYWORDS = (
    "EARTH SCIENCE > ATMOSPHERE > ATMOSPHERIC WINDS > TURBULENCE, "
    "EARTH SCIENCE > ATMOSPHERE > ATMOSPHERIC WINDS > SURFACE WINDS, "
    "EARTH SCIENCE > ATMOSPHERE > ATMOSPHERIC WINDS > WIND PROFILES"
)

_TEMPERATURE_UNITS = {"K", "degC", "degree_Celsius", "celsius"}


def variable_attrs(
    units: str, standard_name: str | None = None, long_name: str | None = None, **extra: Any
) -> dict[str, Any]:
    """CF attributes of one variable: the one builder every product uses.

    Parameters
    ----------
    units : str
        UDUNITS string (``"m s-1"``, ``"K"``, ``"1"`` for dimensionless).
    standard_name : str, optional
        CF standard name, where the quantity has one.
    long_name : str, optional
        Human-readable name (required by CF where there is no standard name).
    **extra
        Further attributes (``comment``, ``positive``, ``units_metadata``, ...), in order.

    Returns
    -------
    dict
        ``units`` [, ``standard_name``] [, ``long_name``], then ``extra``.
    """
    attrs: dict[str, Any] = {"units": units}
    if standard_name:
        attrs["standard_name"] = standard_name
    if long_name:
        attrs["long_name"] = long_name
    attrs.update(extra)
    return attrs


def variable(
    dims: tuple[str, ...], values: Any, units: str, standard_name: str | None = None,
    long_name: str | None = None, **extra: Any,
) -> xr.Variable:
    """An :class:`xarray.Variable` with attributes from :func:`variable_attrs`.

    Parameters
    ----------
    dims : tuple of str
        Dimension names.
    values : array_like
        Data.
    units, standard_name, long_name, **extra
        As in :func:`variable_attrs`.

    Returns
    -------
    xarray.Variable
    """
    return xr.Variable(dims, values, attrs=variable_attrs(units, standard_name, long_name, **extra))


def sha256_file(path: str | Path, chunk_bytes: int = 1 << 20) -> str:
    """SHA-256 hex digest of a file, read in chunks.

    Parameters
    ----------
    path : str or Path
        File to hash.
    chunk_bytes : int
        Read size [bytes].

    Returns
    -------
    str
        Hex digest.
    """
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while chunk := handle.read(chunk_bytes):
            digest.update(chunk)
    return digest.hexdigest()


def config_hash(config: Mapping[str, Any]) -> str:
    """SHA-256 of a configuration, independent of key order.

    Parameters
    ----------
    config : mapping
        JSON-serialisable configuration (non-serialisable values are stringified).

    Returns
    -------
    str
        Hex digest of the canonical JSON form.
    """
    canonical = json.dumps(config, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(canonical.encode("utf-8")).hexdigest()


def _creation_time() -> str:
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    if epoch is not None:
        stamp = _dt.datetime.fromtimestamp(int(epoch), tz=_dt.UTC)
    else:
        stamp = _dt.datetime.now(tz=_dt.UTC).replace(microsecond=0)
    return stamp.strftime("%Y-%m-%dT%H:%M:%SZ")


def _iso(value: Any) -> str:
    """A datetime64 as ISO 8601 UTC to the second, with a trailing Z."""
    return str(np.datetime_as_string(np.datetime64(value, "s"), unit="s")) + "Z"


def _label_dimensions(ds: xr.Dataset) -> xr.Dataset:
    """Store string dimension coordinates as character arrays, so that they stay selectable by name.

    A string-valued coordinate variable ``sensor(sensor)`` is not CF (a coordinate variable is
    numeric, CF 1.11 Sect. 1.2) and makes the IOOS checker fail. Stored as a character array
    ``sensor(sensor, sensor_strlen)`` with ``_Encoding = "utf-8"`` (CF 1.11 Sect. 2.2, a
    string as an array of characters) it is a label variable to CF and the checker, while
    ``xarray.open_dataset`` decodes it back into the string index of the dimension:
    ``ds.sel(sensor="drone")`` works on the file as stored.
    """
    out = ds
    for dim in [str(d) for d in ds.dims]:
        if dim in ds.coords and ds[dim].dtype.kind in "OUS":
            labels = np.asarray(ds[dim].values).astype(str)
            var = xr.Variable((dim,), labels, attrs={**ds[dim].attrs, "long_name": ds[dim].attrs.get(
                "long_name", f"{dim} name")})
            var.encoding = {"dtype": "S1", "char_dim_name": f"{dim}_strlen", "_Encoding": "utf-8"}
            out = out.assign_coords({dim: var})
    return out


def _prepare_variables(ds: xr.Dataset) -> xr.Dataset:
    """Variable-level CF fixes: time encoding, fill values, units metadata."""
    out = _label_dimensions(ds.copy())
    bounds = {str(v.attrs["bounds"]) for v in out.variables.values() if "bounds" in v.attrs}
    for name in bounds & set(out.variables):
        # CF 7.1: a boundary variable inherits its parent's metadata and should carry none
        # that could disagree; it is encoded exactly like its parent.
        out[name].attrs = {}
        encoding: dict[str, Any] = {"_FillValue": None}
        if np.issubdtype(out[name].dtype, np.datetime64):
            encoding.update({"units": TIME_UNITS, "calendar": "standard", "dtype": "int64"})
        out[name].encoding = encoding
    for name in [str(n) for n in out.variables]:
        if name in bounds:
            continue
        var = out[name]
        attrs = dict(var.attrs)
        encoding = dict(var.encoding)
        encoding.pop("coordinates", None)  # re-derived from attrs; both set is an xarray error
        if np.issubdtype(var.dtype, np.datetime64):
            attrs.setdefault("standard_name", "time")
            attrs.setdefault("long_name", "time (UTC)")
            attrs["units_metadata"] = "leap_seconds: none"
            if name == "time":
                attrs["axis"] = "T"
            encoding.update(
                {"units": TIME_UNITS, "calendar": "standard", "dtype": "int64", "_FillValue": None}
            )
            attrs.pop("units", None)
            attrs.pop("calendar", None)
        elif np.issubdtype(var.dtype, np.floating):
            encoding.setdefault("_FillValue", np.nan)
            if attrs.get("units") in _TEMPERATURE_UNITS:
                attrs.setdefault("units_metadata", "temperature: on_scale")
        elif var.dtype.kind in "OUS":
            encoding["_FillValue"] = None
        else:
            encoding.setdefault("_FillValue", None)
        if "long_name" not in attrs:
            attrs["long_name"] = str(attrs.get("standard_name", name)).replace("_", " ")
        if name not in out.dims and name not in out.coords and "coverage_content_type" not in attrs:
            is_qc = name.startswith("qc_") or attrs.get("standard_name") == "status_flag"
            attrs["coverage_content_type"] = "qualityInformation" if is_qc else "physicalMeasurement"
        if name in out.dims or name in ("lat", "lon", "alt", "station"):
            encoding["_FillValue"] = None
        out[name].attrs = attrs
        out[name].encoding = encoding
    return out


def _add_station(
    ds: xr.Dataset,
    station_id: str | None,
    latitude: float | None,
    longitude: float | None,
    height_m: float | None,
) -> xr.Dataset:
    """Add the CF timeSeries station identifier (CF H.4) and the nominal position."""
    out = ds
    coords = []
    if station_id:
        out = out.assign_coords(
            station=xr.DataArray(
                np.array(station_id, dtype=object),
                attrs={"cf_role": "timeseries_id", "long_name": "station or platform identifier"},
            )
        )
        coords.append("station")
    if latitude is not None:
        out = out.assign_coords(
            lat=xr.DataArray(
                float(latitude),
                attrs={"standard_name": "latitude", "units": "degrees_north", "axis": "Y",
                       "long_name": "nominal latitude"},
            )
        )
        coords.append("lat")
    if longitude is not None:
        out = out.assign_coords(
            lon=xr.DataArray(
                float(longitude),
                attrs={"standard_name": "longitude", "units": "degrees_east", "axis": "X",
                       "long_name": "nominal longitude"},
            )
        )
        coords.append("lon")
    if height_m is not None:
        out = out.assign_coords(
            alt=xr.DataArray(
                float(height_m),
                attrs={"standard_name": "height", "units": "m", "positive": "up", "axis": "Z",
                       "long_name": "nominal height of the sensor above ground"},
            )
        )
        coords.append("alt")
    for name, var in out.data_vars.items():
        if "time" in var.dims and not str(name).startswith(("qc_", "n_")):
            existing = var.attrs.get("coordinates", "")
            merged = " ".join(dict.fromkeys((existing.split() if existing else []) + coords))
            out[name].attrs["coordinates"] = merged
        elif "time" in var.dims:
            out[name].attrs.setdefault("coordinates", " ".join(coords))
    bounds = {str(v.attrs["bounds"]) for v in out.variables.values() if "bounds" in v.attrs}
    for name in bounds & set(out.variables):
        out[name].attrs.pop("coordinates", None)
    return out


def _coverage_attrs(ds: xr.Dataset) -> dict[str, Any]:
    attrs: dict[str, Any] = {}
    if "time" in ds.variables and ds["time"].size > 0:
        t = ds["time"].values
        bounds = ds["time"].attrs.get("bounds")
        if bounds in ds.variables:  # statistics over a period: the bounds give the coverage
            t = ds[bounds].values.ravel()
        t0, t1 = np.nanmin(t), np.nanmax(t)
        attrs["time_coverage_start"] = _iso(t0)
        attrs["time_coverage_end"] = _iso(t1)
        seconds = float((t1 - t0) / np.timedelta64(1, "s"))
        attrs["time_coverage_duration"] = f"PT{seconds:.3f}S"
        if ds["time"].size > 1:
            step = float(np.nanmedian(np.diff(t).astype("timedelta64[us]").astype(np.int64))) / 1e6
            attrs["time_coverage_resolution"] = f"PT{step:.6f}S"
        else:
            attrs["time_coverage_resolution"] = attrs["time_coverage_duration"]
    for name, key in (("lat", "lat"), ("lon", "lon")):
        if name in ds.variables:
            values = np.asarray(ds[name].values, dtype=float)
            if "precise_" + name in ds.variables:
                values = np.concatenate([values.ravel(), np.asarray(ds["precise_" + name].values, float)])
            finite = values[np.isfinite(values)]
            if finite.size:
                attrs[f"geospatial_{key}_min"] = float(finite.min())
                attrs[f"geospatial_{key}_max"] = float(finite.max())
                attrs[f"geospatial_{key}_units"] = "degrees_north" if key == "lat" else "degrees_east"
    if "geospatial_lat_min" in attrs and "geospatial_lon_min" in attrs:
        lat0, lat1 = attrs["geospatial_lat_min"], attrs["geospatial_lat_max"]
        lon0, lon1 = attrs["geospatial_lon_min"], attrs["geospatial_lon_max"]
        if lat0 == lat1 and lon0 == lon1:
            attrs["geospatial_bounds"] = f"POINT ({lat0:.6f} {lon0:.6f})"
        else:
            attrs["geospatial_bounds"] = (
                f"POLYGON (({lat0:.6f} {lon0:.6f}, {lat0:.6f} {lon1:.6f}, {lat1:.6f} {lon1:.6f}, "
                f"{lat1:.6f} {lon0:.6f}, {lat0:.6f} {lon0:.6f}))"
            )
        attrs["geospatial_bounds_crs"] = "EPSG:4326"
    if "alt" in ds.variables:
        # Heights are above the local ground; there is no EPSG code for that datum, so the
        # CRS is named in words (ACDD asks for the attribute, not for a registry code).
        attrs["geospatial_bounds_vertical_crs"] = "height above local ground level"
        z = float(ds["alt"].values)
        attrs.update(
            geospatial_vertical_min=z,
            geospatial_vertical_max=z,
            geospatial_vertical_units="m",
            geospatial_vertical_positive="up",
        )
    return attrs


def _netcdf_attrs(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """NetCDF attributes must be str, numbers or arrays of numbers: convert the rest."""
    out: dict[str, Any] = {}
    for key, value in attrs.items():
        if value is None:
            continue
        if isinstance(value, bool | np.bool_):
            out[key] = int(value)
        elif isinstance(value, str | int | float | np.number | np.ndarray | list | tuple):
            out[key] = value
        else:
            out[key] = str(value)
    return out


def _discovery_attrs(ds: xr.Dataset, title: str, summary: str, processing_level: str) -> dict[str, Any]:
    """The dataset's own global attributes, then the fixed and the discovery attributes of ACDD."""
    attrs: dict[str, Any] = {k: v for k, v in ds.attrs.items() if v is not None}
    attrs.update(_FIXED_GLOBAL_ATTRS)
    attrs.update(title=title, summary=summary, keywords=_KEYWORDS, processing_level=processing_level)
    return attrs


def _provenance_attrs(
    ds: xr.Dataset, path: Path, history: str, inputs: Iterable[str | Path], config: Mapping[str, Any] | None
) -> dict[str, Any]:
    """Provenance: creation stamps, history line, file id, settings hash and input checksums."""
    input_list = [Path(p) for p in inputs]
    checksums = {p.name: sha256_file(p) for p in input_list if p.is_file()}
    stamp = _creation_time()
    previous = str(ds.attrs.get("history", "")).strip()
    line = f"{stamp} dronewind {__version__}: {history}"
    return {
        "history": f"{previous}\n{line}" if previous else line,
        "date_created": stamp,
        "date_modified": stamp,
        "date_issued": stamp,
        "date_metadata_modified": stamp,
        "id": f"dronewind/{path.parent.name}/{path.stem}",
        "comment": "Produced by the dronewind workflow; see processing_log for every step.",
        "config_sha256": config_hash(config or {}),
        "input_files": ", ".join(p.name for p in input_list),
        "input_checksums": json.dumps(checksums, sort_keys=True),
    }


def _feature_type_attrs(attrs: dict[str, Any], feature_type: str | None) -> None:
    """Set (or, for ``None``, remove) the CF ``featureType`` and ACDD ``cdm_data_type`` in place."""
    if feature_type:
        attrs["featureType"] = feature_type
        attrs["cdm_data_type"] = "Station" if feature_type == "timeSeries" else feature_type
    else:
        attrs.pop("featureType", None)


def _reading_note(ds: xr.Dataset, groups: Mapping[str, xr.Dataset]) -> str:
    """The ``comment`` of a product: where its groups are and how to open it whole."""
    text = "Produced by the dronewind workflow; see processing_log for every step."
    labelled = {str(d): str(part[d].values[0]) for part in (ds, *groups.values()) for d in part.dims
                if d in part.coords and part[d].dtype.kind in "OUS" and part[d].size}
    if groups:
        names = ", ".join(f"'{g}'" for g in groups)
        text += (f" Quantities without a CF standard name are in the NetCDF-4 group(s) {names}: "
                 f"xarray.open_dataset(path, group={next(iter(groups))!r}) or xarray.open_datatree(path).")
    if labelled:
        text += " " + ", ".join(f"{d} is selectable by name (ds.sel({d}={first!r}))" for d, first in labelled.items()) \
            + "."
    if groups:
        text += " dronewind.open_product(path) opens the root and every group as one dataset; docs/outputs.md."
    return text


def _write_atomically(out: xr.Dataset, groups: Mapping[str, xr.Dataset], path: Path) -> None:
    """Write the root group and every sub-group to a temporary file, then rename it into place."""
    handle, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(handle)
    try:
        out.to_netcdf(tmp_name, format="NETCDF4", engine="netcdf4")
        for group_name, group_ds in groups.items():
            group_out = _prepare_variables(group_ds)
            group_out.attrs = _netcdf_attrs(dict(group_ds.attrs))
            group_out.to_netcdf(tmp_name, mode="a", group=group_name, format="NETCDF4", engine="netcdf4")
        os.chmod(tmp_name, 0o644)
        os.replace(tmp_name, path)
    except (OSError, RuntimeError) as exc:  # netCDF4 reports a full disk as RuntimeError("NetCDF: HDF error")
        Path(tmp_name).unlink(missing_ok=True)
        raise OSError(getattr(exc, "errno", None) or errno.EIO,
                      f"{path}: could not write the NetCDF file ({exc}); is the disk full or the folder not "
                      "writable? The previous file, if any, is unchanged") from exc
    except BaseException:
        Path(tmp_name).unlink(missing_ok=True)
        raise


def write_netcdf(
    ds: xr.Dataset,
    path: str | Path,
    *,
    title: str,
    summary: str,
    processing_level: str,
    history: str,
    inputs: Iterable[str | Path] = (),
    config: Mapping[str, Any] | None = None,
    feature_type: str | None = "timeSeries",
    station_id: str | None = None,
    latitude: float | None = None,
    longitude: float | None = None,
    height_m: float | None = None,
    extra_attrs: Mapping[str, Any] | None = None,
    groups: Mapping[str, xr.Dataset] | None = None,
    nonstandard_group: str | None = None,
) -> Path:
    """Write a dataset as CF-1.11 / ACDD-1.3 NetCDF-4, atomically, with provenance.

    Parameters
    ----------
    ds : xarray.Dataset
        Data; variables carry ``units`` and ``standard_name`` or ``long_name``.
    path : str or Path
        Destination file; its folder is created.
    title, summary, processing_level : str
        ACDD discovery text; data level (``"L1"`` ... ``"L4"``) with a few words.
    history : str
        What produced this file (one line), UTC-stamped and appended to ``ds``'s ``history``.
    inputs : iterable of path
        Files this output was computed from; their SHA-256 go into ``input_checksums``, and
        the ``source`` of NetCDF inputs (measured or virtual campaign, :func:`data_source`) is
        inherited when neither ``ds.attrs`` nor ``extra_attrs`` give one.
    config : mapping, optional
        Settings the product was computed with (workflow products: the configuration keys
        of their rule, nested as in ``config.yaml``); hashed into ``config_sha256``.
    feature_type : str or None
        CF ``featureType`` (``"timeSeries"`` for mast and hovering-drone records); ``None``
        for files that are not discrete sampling geometries (statistics, spectra).
    station_id : str, optional
        Identifier of the sensor/platform (``cf_role = timeseries_id``); required when
        ``feature_type`` is ``"timeSeries"``.
    latitude, longitude, height_m : float, optional
        Nominal position [degrees] and sensor height above ground [m].
    extra_attrs : mapping, optional
        More global attributes (flight id, lags).
    groups : mapping of str to xarray.Dataset, optional
        Sub-groups for quantities without a CF standard name (``open_dataset(path, group=name)``).
    nonstandard_group : str, optional
        Move every data variable without a ``standard_name`` (QC flags excepted) from
        ``ds`` into a group of this name (see :func:`split_standard`).

    Returns
    -------
    Path
        The written file.
    """
    (path := Path(path)).parent.mkdir(parents=True, exist_ok=True)
    if nonstandard_group:
        ds, split = split_standard(ds, nonstandard_group)
        groups = {**split, **(groups or {})}
    if feature_type == "timeSeries" and not station_id:
        raise ValueError(f"{path}: a timeSeries file needs a station_id")
    out = _prepare_variables(_add_station(ds, station_id, latitude, longitude, height_m))
    attrs = _discovery_attrs(ds, title, summary, processing_level)
    inputs = list(inputs)
    attrs.update(_provenance_attrs(ds, path, history, inputs, config))
    # measured or virtual, and who made the data under which licence: stated by the L1 step (the
    # manifest), inherited by every later level
    inherited = _inherited(inputs)
    attrs["source"] = (
        (extra_attrs or {}).get("source") or ds.attrs.get("source") or inherited.get("source")
        or DATA_SOURCES["unknown"]
    )
    for key in ATTRIBUTION_KEYS:
        attrs[key] = (extra_attrs or {}).get(key) or ds.attrs.get(key) or inherited.get(key) or attrs[key]
    _feature_type_attrs(attrs, feature_type)
    attrs.update(_coverage_attrs(out))
    attrs.update({k: v for k, v in (extra_attrs or {}).items() if v is not None})
    if groups:
        attrs["groups"] = ", ".join(groups)
    attrs["comment"] = _reading_note(ds, groups or {})
    out.attrs = _netcdf_attrs(attrs)
    _write_atomically(out, groups or {}, path)
    return path


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write a text file atomically (temporary file in the same folder, then rename).

    Parameters
    ----------
    path : str or Path
        Destination.
    text : str
        Content.

    Returns
    -------
    Path
        The written file.
    """
    def write(handle: int) -> None:
        with os.fdopen(handle, "w", encoding="utf-8") as stream:
            stream.write(text)

    return _atomic_write(path, write)


def atomic_write_arrays(path: str | Path, arrays: Mapping[str, np.ndarray]) -> Path:
    """Write named arrays to a NumPy ``.npz`` file atomically (:func:`numpy.savez`, no pickled objects).

    Parameters
    ----------
    path : str or Path
        Destination.
    arrays : mapping
        Name -> array.

    Returns
    -------
    Path
        The written file.
    """
    def write(handle: int) -> None:
        with os.fdopen(handle, "wb") as stream:
            np.savez(stream, allow_pickle=False, **arrays)

    return _atomic_write(path, write)


def _atomic_write(path: str | Path, write: Callable[[int], object]) -> Path:
    """Write through ``write`` (given the file descriptor of a temporary file in the same folder), then rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        write(handle)
        os.chmod(tmp_name, 0o644)  # mkstemp creates 0600; outputs are meant to be shared
        os.replace(tmp_name, path)
    except BaseException:
        Path(tmp_name).unlink(missing_ok=True)
        raise
    return path


#: The checker suites and criteria every product must pass.
COMPLIANCE_TESTS: tuple[str, ...] = ("cf:1.11", "acdd:1.3")
COMPLIANCE_CRITERIA = "normal"

def check_compliance(path: str | Path) -> tuple[bool, str]:
    """Run the IOOS compliance checker (CF-1.11 and ACDD-1.3, normal criteria) on one file.

    Parameters
    ----------
    path : str or Path
        NetCDF file.

    Returns
    -------
    passed : bool
        True when every check passes at the criteria and none raised (the
        ``compliance-checker`` command's exit code 0).
    report : str
        The checker's text report.
    """
    return check_compliance_files([path])[Path(path)]


def check_compliance_files(paths: Sequence[str | Path], remember: bool = True) -> dict[Path, tuple[bool, str]]:
    """Run the IOOS compliance checker on several files in one process.

    Each file is checked as ``compliance-checker --test=cf:1.11 --test=acdd:1.3
    --criteria=normal`` checks it alone (one ``ComplianceChecker.run_checker`` call per file,
    the checker's own API), so its verdict and report are its own
    (:mod:`dronewind.core.compliance`). One process for all files because starting the
    checker (its imports and its plugins) costs about 1.3 CPU-s and checking one product 0.3
    to 0.7: four L1 files took 2.5 CPU-s in one process, 5.1 in four.

    Parameters
    ----------
    paths : sequence of str or Path
        NetCDF files.
    remember : bool
        Remember the checker's whole-file metadata scans for each file
        (:func:`dronewind.core.compliance.remember_scans`; the same reports at about half the
        CPU time); False runs
        the checker as installed.

    Returns
    -------
    dict
        ``{path: (passed, report)}`` in the order given (as :func:`check_compliance`).

    Raises
    ------
    RuntimeError
        The checker's process failed before it reported (e.g. not installed).
    """
    import json
    import subprocess
    import sys

    files = [Path(p) for p in paths]
    if not files:
        return {}
    cmd = [sys.executable, "-m", "dronewind.core.compliance", *([] if remember else ["--plain"]),
           ",".join(COMPLIANCE_TESTS), COMPLIANCE_CRITERIA, *map(str, files)]
    # the checker orders some messages by iterating sets of names: a fixed hash seed makes its
    # reports the same in every run (the verdicts do not depend on it)
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False,
                          env={**os.environ, "PYTHONHASHSEED": "0"})
    if proc.returncode != 0:
        raise RuntimeError(f"compliance checker on {len(files)} file(s) failed (exit {proc.returncode}): "
                           f"{proc.stderr[-3000:]}")
    results = json.loads(proc.stdout)
    return {p: (bool(results[str(p)][0]), str(results[str(p)][1])) for p in files}


def split_standard(ds: xr.Dataset, group: str) -> tuple[xr.Dataset, dict[str, xr.Dataset]]:
    """Split a dataset into standard-named variables (root) and the rest (one group).

    Variables whose ``standard_name`` is missing go to the group named ``group``, with the
    coordinates they use; QC flags stay in the root group with the data they describe.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset to split.
    group : str
        Name of the group for variables without a CF standard name.

    Returns
    -------
    root : xarray.Dataset
        Standard-named variables and QC flags (global attributes kept).
    groups : dict
        ``{group: dataset}``, empty when every variable has a standard name.
    """
    bounds = {str(v.attrs["bounds"]) for v in ds.variables.values() if "bounds" in v.attrs}
    rest = [
        name
        for name, var in ds.data_vars.items()
        if "standard_name" not in var.attrs and not str(name).startswith("qc_") and name not in bounds
    ]
    if not rest:
        return ds, {}
    other = ds[rest]
    other.attrs = {"comment": "quantities without a CF standard name (long_name and units only)"}
    root = ds.drop_vars(rest)
    unused = [d for d in root.dims if not any(d in v.dims for v in root.data_vars.values())]
    root = root.drop_dims(unused) if unused else root
    return root, {group: other}


# ----------------------------------------------------------------------------- library names <-> CF names


