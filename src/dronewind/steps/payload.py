"""The payload chain, step by step: from raw flight and mast files to L4 and flight_stats.

Each step is a file wrapper over a chain function (:mod:`dronewind.payload.chain`,
:mod:`dronewind.mast.chain`, :mod:`dronewind.compare.chain`): it reads its inputs, calls
the chain with the settings it is given and writes one product through
:func:`write_product`, which describes every kind of product from one table
(:data:`PRODUCTS`: title, summary, processing level, NetCDF group, station id, global
attributes). A step receives exactly what it uses as arguments: the manifest entries of its
flight or sonic and the configuration keys of its rule, which the Snakemake rule passes as
``params`` (so that changing a setting reruns exactly the jobs that use it). The NetCDF
``config_sha256`` of a product is the hash of those configuration keys, nested as in
``config.yaml`` (e.g. ``{"processing": {"despike": {...}}}`` for L1).

The Snakemake scripts in ``workflow/scripts/`` call these functions, so a step can be rerun and
debugged by hand without Snakemake.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import xarray as xr

from dronewind.core.cf import atomic_write_text, data_source, write_netcdf
from dronewind.core.cf_names import strip_cf, track_from_cf, track_to_cf
from dronewind.core.products import open_product
from dronewind.errors import InputError
from dronewind.manifest import confined_path, record_format
from dronewind.mast.chain import (
    compute_mast_l1,
    flight_reference,
    unreadable_mast_l1,
    unusable_mast_l2,
)
from dronewind.payload import rigid
from dronewind.payload.chain import compute_payload_l1, compute_payload_l2
from dronewind.payload.delimited import payload_source
from dronewind.simulate.settings import simulation_manifest
from dronewind.steps.common import LOG

__all__ = ["ProductSpec", "PRODUCTS", "Position", "write_product", "source_name", "simulation_manifest",
           "simulate_payload",
           "payload_l1", "mast_l1", "payload_l2", "mast_l2", "l3", "l4", "rigid_l1", "rigid_l2", "drone_l3",
           "FLIGHT_STATS_COLUMNS", "flight_stats"]


# ----------------------------------------------------------------------------- one product writer


@dataclass(frozen=True)
class ProductSpec:
    """How one kind of product is described in its NetCDF file.

    Text fields are :meth:`str.format` templates over the product's fields (``campaign``,
    ``flight``, ``sonic``, ``sensor``, ``reference``, ...).

    Attributes
    ----------
    title, summary : str
        ACDD discovery text.
    processing_level : str
        Data level with a few words.
    history : str
        The history line of the step.
    group : str
        NetCDF-4 group for the variables without a CF standard name.
    station : str or None
        Station identifier of a CF timeSeries (Appendix H.4); ``None`` for a product that is
        not a discrete sampling geometry (statistics, spectra).
    attrs : tuple of str
        Fields stored as global attributes.
    """

    title: str
    summary: str
    processing_level: str
    history: str
    group: str
    station: str | None
    attrs: tuple[str, ...] = ("campaign", "flight")


#: Every product of the payload chain, by kind.
PRODUCTS: dict[str, ProductSpec] = {
    "payload_sonic_l1": ProductSpec(
        "{campaign} flight {flight}: payload sonic, L1",
        "RM Young 81000 sonic on the SAMURAI-S sling load, sensor frame, logger clock converted to UTC "
        "through the INS; range, spike and missing-data flags.",
        "L1: UTC time, QC flags, flagged values set to NaN", "payload_l1 flight {flight}", "sensor_frame",
        "{flight}_payload_sonic"),
    "payload_ins_l1": ProductSpec(
        "{campaign} flight {flight}: INS, L1",
        "SBG Ellipse-D EKF output on the SAMURAI-S payload from the first stable valid GNSS time.",
        "L1: UTC time, QC flags", "payload_l1 flight {flight}", "ins_raw", "{flight}_payload_ins"),
    "mast_l1": ProductSpec(
        "{campaign} mast sonic {sonic}, L1",
        "{model} sonic at {height_m} m on mast {mast}, rotated from the sensor frame to east/north/up; range, "
        "spike and diagnostic flags.",
        "L1: UTC time, east/north/up, QC flags", "mast_l1 {sonic}", "sensor_frame", "{sonic}", ("campaign", "mast")),
    "payload_l2": ProductSpec(
        "{campaign} flight {flight}: drone wind, L2",
        "Synchronised (sonic-INS lag of minimum TKE) and motion-corrected wind from the SAMURAI-S payload in "
        "east/north/up at the sonic rate, hover window only.",
        "L2: synchronised, motion-corrected, east/north/up", "payload_l2 {flight}", "synchronisation",
        "{flight}_drone"),
    "rigid_l1": ProductSpec(
        "{campaign} flight {flight}: rigid-mount sonic and platform, L1",
        "{model} sonic fixed to a multicopter and the vehicle's velocity, attitude and position from its own log, "
        "on one regular UTC time axis; sonic in the sensor frame; missing, range and spike flags.",
        "L1: UTC time, QC flags, flagged values set to NaN", "rigid_l1 flight {flight}", "sensor_frame",
        "{flight}_rigid_mount"),
    "rigid_l2": ProductSpec(
        "{campaign} flight {flight}: drone wind, L2",
        "Motion-corrected wind (V = R M V_sensor + V_platform) from a sonic rigidly mounted on a multicopter, in "
        "east/north/up at the record's rate, over the longest steady segment (altitude band, horizontal speed "
        "limit), sonic-platform lag of minimum TKE.",
        "L2: synchronised, motion-corrected, east/north/up", "rigid_l2 {flight}", "synchronisation",
        "{flight}_drone"),
    "l3_drone": ProductSpec(
        "{campaign} flight {flight}: drone in streamline coordinates, L3",
        "Drone wind of a flight without a reference mast, rotated into streamline coordinates at its L2 rate.",
        "L3: streamline coordinates (drone only)", "l3 {flight} drone only", "alignment", "{flight}_drone",
        ("campaign", "flight")),
    "mast_l2": ProductSpec(
        "{campaign} flight {flight}: reference mast sonic, L2",
        "Mast sonic {reference} in east/north/up over the hover window of flight {flight}.",
        "L2: east/north/up, flight window", "mast_l2 {flight}", "sensor_frame", "{reference}"),
    "l3": ProductSpec(
        "{campaign} flight {flight}: drone and mast aligned, L3",
        "Drone and reference mast sonic aligned by the advection lag, decimated to a common rate with an FIR "
        "anti-alias filter and rotated into streamline coordinates.",
        "L3: aligned, decimated, streamline coordinates", "l3 {flight}", "alignment", "{flight}_drone_and_mast",
        ("campaign", "flight", "reference")),
    "l4": ProductSpec(
        "{campaign} flight {flight}: {sensor} statistics and spectra, L4",
        "Mean wind, standard deviations, skewness, kurtosis, fluxes, friction velocity, TKE, Obukhov length, "
        "spectra with blunt/pointed model fits, isotropy ratios, random-error estimates and integral scales "
        "(Ghirardelli et al. (2025), Sects. 4.1-4.3).",
        "L4: statistics, spectra, uncertainties, scales", "l4 {flight} {sensor}", "analysis", "{flight}_{sensor}",
        ("campaign", "flight", "sensor")),
}


@dataclass(frozen=True)
class Position:
    """Nominal position of a product's sensor: latitude, longitude [degree], height above ground [m]."""

    latitude: float | None
    longitude: float | None
    height_m: float | None


def write_product(
    ds: xr.Dataset, output: str | Path, kind: str, fields: Mapping[str, Any], position: Position,
    inputs: Sequence[str | Path], settings: Mapping[str, Any],
) -> Path:
    """Write one product of the payload chain as described by its :data:`PRODUCTS` entry.

    Parameters
    ----------
    ds : xarray.Dataset
        The product (CF names).
    output : str or Path
        NetCDF file to write.
    kind : str
        Key of :data:`PRODUCTS`.
    fields : mapping
        Values of the spec's templates and global attributes (``campaign``, ``flight``, ...).
    position : Position
        Nominal position of the sensor.
    inputs : sequence of path
        Files the product was computed from (checksummed).
    settings : mapping
        Configuration keys the product was computed with, nested as in ``config.yaml``
        (hashed into ``config_sha256``).

    Returns
    -------
    Path
        The written file.
    """
    spec = PRODUCTS[kind]
    return write_netcdf(
        ds, output, title=spec.title.format(**fields), summary=spec.summary.format(**fields),
        processing_level=spec.processing_level, history=spec.history.format(**fields), inputs=inputs,
        config=settings, feature_type="timeSeries" if spec.station else None,
        station_id=spec.station.format(**fields) if spec.station else None, latitude=position.latitude,
        longitude=position.longitude, height_m=position.height_m,
        extra_attrs={key: fields[key] for key in spec.attrs}, nonstandard_group=spec.group,
    )


def source_name(path: str | Path, data_root: str | Path | None) -> str:
    """A data file as recorded in a product: relative to the campaign's data folder if inside it.

    Parameters
    ----------
    path : str or Path
        The file read.
    data_root : str or Path or None
        Folder the manifest's data paths refer to; None: the path as given.

    Returns
    -------
    str
        POSIX path relative to ``data_root`` (e.g. ``flights/s01/sonic.csv``), or the absolute
        path of a file outside it (a measured file elsewhere does not move with the results).
    """
    if data_root is None:
        return str(path)
    full, root = Path(path).resolve(), Path(data_root).resolve()
    return full.relative_to(root).as_posix() if full.is_relative_to(root) else str(full)


def _at_sonic(sonic: Mapping[str, Any], height_m: float | None = None) -> Position:
    """Position of a mast sonic (its own height unless another is given)."""
    return Position(sonic["latitude"], sonic["longitude"], float(sonic["height_m"]) if height_m is None else height_m)


# ----------------------------------------------------------------------------- simulation


def _check_l0_paths(campaign: Mapping[str, Any], flight_id: str, out_dir: Path) -> None:
    """Every file the simulator writes for a flight stays below the L0 folder (else ManifestError).

    The manifest validation rejects such paths already; this guards a caller that passes a
    manifest it did not validate.
    """
    flight = next(f for f in campaign.get("payload_flights") or [] if f["id"] == flight_id)
    for part in ("sonic", "ins"):
        confined_path(out_dir, str(flight[part]["file"]), f"payload flight {flight_id} {part}.file")
    for mast in campaign.get("masts") or []:
        for sonic in mast["sonics"]:
            for pattern in sonic["files"]:
                confined_path(out_dir, str(pattern).replace("*", flight_id), f"mast sonic {sonic['id']} files")


def simulate_payload(campaign: Mapping[str, Any], flight_id: str, manifest_dir: str | Path,
                     out_dir: str | Path) -> list[Path]:
    """Write the raw files of one simulated payload flight (sonic, INS, mast TOA5).

    Parameters
    ----------
    campaign : mapping
        Manifest content with a ``simulation:`` section (e.g. :func:`simulation_manifest`).
    flight_id : str
        Payload flight id.
    manifest_dir : str or Path
        Folder of the manifest.
    out_dir : str or Path
        L0 folder of the campaign (``results/<name>/L0``); files go to the manifest's
        relative paths below it.

    Returns
    -------
    list of Path
        The written files.
    """
    from dronewind.simulate.payload import simulate_payload_flight

    _check_l0_paths(campaign, flight_id, Path(out_dir))
    paths = simulate_payload_flight(dict(campaign), Path(manifest_dir), flight_id, Path(out_dir))
    for path in paths:
        LOG.info("wrote %s", path)
    return paths


# ----------------------------------------------------------------------------- L0 -> L1 -> L2 -> L3 -> L4


def payload_l1(
    sonic_file: str | Path, ins_file: str | Path, out_sonic: str | Path, out_ins: str | Path, *, campaign: str,
    flight_id: str, site: Mapping[str, Any], target_height_m: float | None, despike: Mapping[str, Any],
    simulated: bool,
    data_root: str | Path | None = None, sonic_format: Mapping[str, Any] | None = None,
    ins_format: Mapping[str, Any] | None = None, attribution: Mapping[str, str] | None = None,
) -> tuple[Path, Path]:
    """L0 -> L1 files for one payload flight: sonic and INS to UTC with range/spike/gap QC.

    Parameters
    ----------
    sonic_file, ins_file : str or Path
        Raw payload sonic and INS files: the contract CSVs, or in the layouts
        ``sonic_format`` and ``ins_format`` declare.
    out_sonic, out_ins : str or Path
        L1 NetCDF files to write.
    campaign, flight_id : str
        Campaign name and payload flight id.
    site : mapping
        Manifest ``site`` (``latitude``, ``longitude`` [degree]).
    target_height_m : float or None
        The flight's nominal height above ground [m], if the manifest gives one.
    despike : mapping
        ``processing.despike``.
    simulated : bool
        The campaign is virtual (its manifest has ``simulation:``): stated in ``source``.
    data_root : str or Path, optional
        Folder the manifest's data paths refer to (the manifest's folder, or
        ``results/<name>/L0`` of a virtual campaign): the ``source_file`` attributes are
        stored relative to it, so the products do not depend on where the results lie.
    sonic_format, ins_format : mapping, optional
        The manifest's ``sonic.format`` and ``ins.format`` when they are ``delimited``
        mappings (:mod:`dronewind.payload.delimited`); ``None``: the contract CSV.
    attribution : mapping, optional
        Creator and licence from the manifest (:func:`dronewind.core.attribution.attribution`),
        inherited by every later level.

    Returns
    -------
    tuple of Path
        The written files.
    """
    LOG.info("flight %s: reading %s and %s", flight_id, sonic_file, ins_file)
    sonic, ins = compute_payload_l1(payload_source(sonic_file, sonic_format, "sonic", "sonic.format"),
                                    payload_source(ins_file, ins_format, "ins", "ins.format"), despike)
    sonic.attrs.update(source_file=source_name(sonic_file, data_root), ins_source_file=source_name(ins_file, data_root))
    ins.attrs["source_file"] = source_name(ins_file, data_root)
    LOG.info("sonic L1: %d samples; %s", sonic.sizes["time"], sonic.attrs.get("processing_log", ""))
    LOG.info("INS L1: %d samples; %s", ins.sizes["time"], ins.attrs.get("processing_log", ""))
    fields = {"campaign": campaign, "flight": flight_id}
    sonic.attrs["source"] = ins.attrs["source"] = data_source(simulated)
    sonic.attrs.update(attribution or {})
    ins.attrs.update(attribution or {})
    where = Position(site["latitude"], site["longitude"], float(target_height_m or 0.0) or None)
    settings = {"processing": {"despike": despike}}
    return (write_product(sonic, out_sonic, "payload_sonic_l1", fields, where, [sonic_file, ins_file], settings),
            write_product(track_to_cf(ins), out_ins, "payload_ins_l1", fields, where, [ins_file], settings))


def mast_l1(files: Sequence[str | Path], output: str | Path, *, campaign: str, sonic: Mapping[str, Any],
            despike: Mapping[str, Any], simulated: bool, data_root: str | Path | None = None,
            attribution: Mapping[str, str] | None = None) -> Path:
    """L0 -> L1 file for one mast sonic: its files, read in their declared format, to east/north/up with QC flags.

    Parameters
    ----------
    files : sequence of path
        Files of the sonic (concatenated in time order), in the format its manifest entry
        declares (``format``; default TOA5): :func:`dronewind.mast.chain.compute_mast_l1`.
    output : str or Path
        L1 NetCDF file.
    campaign : str
        Campaign name.
    sonic : mapping
        The sonic's manifest entry with its mast's id and position
        (:meth:`dronewind.manifest.Campaign.mast_sonics`).
    despike : mapping
        ``processing.despike``.
    simulated : bool
        The campaign is virtual (its manifest has ``simulation:``): stated in ``source``.
    data_root : str or Path, optional
        As :func:`payload_l1` (``source_files`` relative to it).
    attribution : mapping, optional
        As :func:`payload_l1`.

    Returns
    -------
    Path
        The written file.
    """
    try:
        ds = compute_mast_l1(files, sonic, despike)
    except InputError as exc:  # the flights referencing the sonic go on without it (mast.chain.flight_reference)
        LOG.warning("mast %s cannot be read: %s; its flights go on without their reference", sonic["id"], exc)
        ds = unreadable_mast_l1(exc, sonic)
    ds.attrs["source"] = data_source(simulated)
    ds.attrs.update(attribution or {})
    ds.attrs["source_files"] = ", ".join(source_name(f, data_root) for f in files)
    LOG.info("mast %s L1: %d samples from %d file(s); %s", sonic["id"], ds.sizes["time"], len(files),
             ds.attrs.get("processing_log", ""))
    fields = {"campaign": campaign, "sonic": sonic["id"], "mast": sonic["mast_id"],
              "model": sonic.get("model", "CSAT3"), "height_m": sonic["height_m"]}
    return write_product(ds, output, "mast_l1", fields, _at_sonic(sonic), files,
                         {"processing": {"despike": despike}})


def payload_l2(
    sonic_l1: str | Path, ins_l1: str | Path, output: str | Path, *, campaign: str, flight_id: str,
    flight: Mapping[str, Any], site: Mapping[str, Any], sonic_ins_lag: Mapping[str, Any],
    hover: Mapping[str, Any], max_missing_fraction: float,
) -> Path:
    """L1 -> L2 file for one payload flight: hover window, sonic-INS lag, motion correction.

    Parameters
    ----------
    sonic_l1, ins_l1 : str or Path
        L1 files of the flight.
    output : str or Path
        L2 NetCDF file.
    campaign, flight_id : str
        Campaign name and payload flight id.
    flight : mapping
        The flight's manifest entry.
    site : mapping
        Manifest ``site`` (``altitude_m`` [m]; ``latitude``, ``longitude`` [degree] when the
        L2 has no GNSS track).
    sonic_ins_lag, hover, max_missing_fraction
        ``processing.sonic_ins_lag``, ``processing.hover``, ``processing.max_missing_fraction``.

    Returns
    -------
    Path
        The written file.
    """
    sonic = strip_cf(open_product(sonic_l1))
    ins = track_from_cf(strip_cf(open_product(ins_l1)))
    ds = compute_payload_l2(sonic, ins, flight, float(site["altitude_m"]), sonic_ins_lag=sonic_ins_lag,
                            hover=hover, max_missing_fraction=max_missing_fraction)
    LOG.info("flight %s L2: lag_sonic_ins_s = %.4f, usable = %s %s", flight_id, ds.attrs["lag_sonic_ins_s"],
             ds.attrs["usable"], ds.attrs.get("unusable_reason", ""))
    ds = track_to_cf(ds)
    lat = float(ds["precise_lat"].median()) if "precise_lat" in ds else site["latitude"]
    lon = float(ds["precise_lon"].median()) if "precise_lon" in ds else site["longitude"]
    where = Position(lat, lon, float(ds.attrs.get("height_m", ds.attrs["target_height_m"])))
    settings = {"processing": {"sonic_ins_lag": sonic_ins_lag, "hover": hover,
                               "max_missing_fraction": max_missing_fraction}}
    return write_product(ds, output, "payload_l2", {"campaign": campaign, "flight": flight_id}, where,
                         [sonic_l1, ins_l1], settings)


def mast_l2(mast_l1_file: str | Path, drone_l2_file: str | Path, output: str | Path, *, campaign: str,
            flight_id: str, reference: Mapping[str, Any], drone_mast: Mapping[str, Any]) -> Path:
    """Mast L1 -> L2 file for one flight: the reference sonic over the flight's hover window.

    Parameters
    ----------
    mast_l1_file : str or Path
        L1 file of the reference mast sonic.
    drone_l2_file : str or Path
        L2 file of the drone (gives the hover window).
    output : str or Path
        L2 mast file to write.
    campaign, flight_id : str
        Campaign name and payload flight id.
    reference : mapping
        Manifest entry of the flight's reference sonic, with its mast's position.
    drone_mast : mapping
        ``processing.drone_mast``.

    Returns
    -------
    Path
        The written file.
    """
    cut, reason = flight_reference(strip_cf(open_product(mast_l1_file)), open_product(drone_l2_file), flight_id,
                                   drone_mast, source=mast_l1_file)
    if cut is None:
        LOG.warning("flight %s: %s; processed without its reference (usable = 0)", flight_id, reason)
        cut = unusable_mast_l2(reason)
    LOG.info("flight %s mast L2: %d samples, coverage %.1f %%", flight_id, cut.sizes["time"],
             100 * cut.attrs["flight_coverage_fraction"])
    fields = {"campaign": campaign, "flight": flight_id, "reference": reference["id"]}
    return write_product(cut, output, "mast_l2", fields, _at_sonic(reference), [mast_l1_file, drone_l2_file],
                         {"processing": {"drone_mast": drone_mast}})


def l3(drone_l2_file: str | Path, mast_l2_file: str | Path, output: str | Path, *, campaign: str, flight_id: str,
       flight: Mapping[str, Any], reference: Mapping[str, Any], drone_mast: Mapping[str, Any], rotation: str) -> Path:
    """L2 -> L3 file for one flight: drone-mast lag, common 8 Hz base, streamline rotation.

    Parameters
    ----------
    drone_l2_file, mast_l2_file : str or Path
        L2 files of the flight.
    output : str or Path
        L3 NetCDF file.
    campaign, flight_id : str
        Campaign name and payload flight id.
    flight : mapping
        The flight's manifest entry.
    reference : mapping
        Manifest entry of the flight's reference sonic, with its mast's position.
    drone_mast, rotation
        ``processing.drone_mast`` and ``processing.rotation``.

    Returns
    -------
    Path
        The written file.
    """
    drone = track_from_cf(strip_cf(open_product(drone_l2_file)))
    mast = strip_cf(open_product(mast_l2_file))
    from dronewind.compare.chain import (  # scipy.signal and scipy.stats: only the L3 and L4 jobs
        compute_l3,
        reference_unusable_l3,
    )

    reason = mast.attrs.get("reference_unusable_reason")
    if reason is not None:  # the reference cannot be used: the drone-only L3, as for a flight without one
        ds = reference_unusable_l3(drone, flight, rotation, str(reason))
        LOG.info("flight %s L3: drone only (%s)", flight_id, reason)
        return write_product(ds, output, "l3_drone", {"campaign": campaign, "flight": flight_id}, _at_sonic(reference),
                             [drone_l2_file, mast_l2_file], {"processing": {"rotation": rotation}})
    ds = compute_l3(drone, mast, flight, drone_mast, rotation)
    LOG.info("flight %s L3: lag_drone_mast_s = %.3f, %d samples at %g Hz", flight_id, ds.attrs["lag_drone_mast_s"],
             ds.sizes["time"], ds.attrs["sampling_rate_hz"])
    fields = {"campaign": campaign, "flight": flight_id, "reference": flight["reference"]}
    return write_product(ds, output, "l3", fields, _at_sonic(reference), [drone_l2_file, mast_l2_file],
                         {"processing": {"drone_mast": drone_mast, "rotation": rotation}})


def l4(l3_file: str | Path, output: str | Path, *, campaign: str, flight_id: str, sensor: str,
       reference: Mapping[str, Any] | None, spectra: Mapping[str, Any], quadrant: Mapping[str, Any],
       detrending: str, site: Mapping[str, Any] | None = None) -> Path:
    """L3 -> L4 file for one flight and sensor: statistics, spectra, fits, uncertainties, scales.

    Parameters
    ----------
    l3_file : str or Path
        L3 file of the flight.
    output : str or Path
        L4 NetCDF file.
    campaign, flight_id : str
        Campaign name and payload flight id.
    sensor : str
        ``"drone"`` or ``"mast"``.
    reference : mapping or None
        Manifest entry of the flight's reference sonic, with its mast's position; None for a
        drone-only flight (the position is then the site's).
    spectra, quadrant : mapping
        ``processing.spectra`` and ``processing.quadrant``.
    detrending : str
        ``processing.detrending`` (``linear`` or ``block_mean``).
    site : mapping, optional
        Manifest ``site``: the position of a drone-only flight's L4.

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.compare.chain import compute_l4

    l3_ds = strip_cf(open_product(l3_file))
    reason = l3_ds.attrs.get("reference_unusable_reason")
    if reason is not None and sensor == "mast":  # no mast record: the drone's layout, every number NaN
        ds = compute_l4(l3_ds, "drone", spectra, quadrant, detrending)
        ds = ds.map(lambda v: v * math.nan if v.dtype.kind == "f" else v, keep_attrs=True)
        ds.attrs.update(mast_usable=0, mast_unusable_reason=str(reason))
    else:
        ds = compute_l4(l3_ds, sensor, spectra, quadrant, detrending)
    LOG.info("flight %s %s L4: U = %.2f m/s, sigma_w = %.3f m/s", flight_id, sensor,
             float(ds["U_ms"]), float(ds["sigma_w_ms"]))
    fields = {"campaign": campaign, "flight": flight_id, "sensor": sensor}
    if reference is None:
        site = site or {}
        where = Position(site.get("latitude"), site.get("longitude"), float(ds["height_m"]))
    else:
        where = _at_sonic(reference, float(ds["height_m"]))
    return write_product(ds, output, "l4", fields, where, [l3_file],
                         {"processing": {"spectra": spectra, "quadrant": quadrant}})


# ----------------------------------------------------------------------------- rigid-mount flights


def rigid_l1(record_file: str | Path, output: str | Path, *, campaign: str, flight_id: str, flight: Mapping[str, Any],
             site: Mapping[str, Any], despike: Mapping[str, Any], data_root: str | Path | None = None,
             attribution: Mapping[str, str] | None = None, platform_log: str | Path | None = None) -> Path:
    """L0 -> L1 file for a rigid-mount flight: sonic and platform on one time axis with QC.

    Parameters
    ----------
    record_file : str or Path
        The flight's record (``record.file``), read by its ``record.format`` mapping.
    output : str or Path
        L1 NetCDF file.
    campaign, flight_id : str
        Campaign name and flight id.
    flight : mapping
        The flight's manifest entry (``record``, ``sonic``, optional ``platform_log``).
    site : mapping
        Manifest ``site``.
    despike : mapping
        ``processing.despike``.
    data_root : str or Path, optional
        Folder the manifest's data paths refer to (``source_file`` relative to it).
    attribution : mapping, optional
        As :func:`payload_l1`.
    platform_log : str or Path, optional
        The file of the flight's ``platform_log`` (the vehicle's own log), read in its
        ``format`` (default ``ardupilot_bin``): the platform variables the record lacks.

    Returns
    -------
    Path
        The written file.
    """
    sonic = flight.get("sonic") or {}
    state = None
    if platform_log is not None:
        state = rigid.read_platform_state(platform_log, record_format(flight.get("platform_log") or {}, "platform_log"))
    ds = rigid.rigid_l1(record_file, flight["record"]["format"], despike_window_s=float(despike["window_s"]),
                        despike_n_mad=float(despike["n_mad"]), limits=str(sonic.get("limits", "trisonica_mini")),
                        where=f"payload flight {flight_id} record.format", platform_state=state)
    ds.attrs["source_file"] = source_name(record_file, data_root)
    if platform_log is not None:
        ds.attrs["platform_log_file"] = source_name(platform_log, data_root)
    ds.attrs["source"] = data_source(False)
    ds.attrs.update(attribution or {})
    LOG.info("flight %s rigid-mount L1: %d samples; %s", flight_id, ds.sizes["time"], ds.attrs["processing_log"])
    fields = {"campaign": campaign, "flight": flight_id, "model": sonic.get("model", "3-D")}
    where = Position(site["latitude"], site["longitude"], flight.get("target_height_m"))
    inputs = [record_file] if platform_log is None else [record_file, platform_log]
    return write_product(track_to_cf(ds), output, "rigid_l1", fields, where, inputs,
                         {"processing": {"despike": despike}})


def rigid_l2(l1_file: str | Path, output: str | Path, *, campaign: str, flight_id: str, flight: Mapping[str, Any],
             site: Mapping[str, Any], rigid_mount: Mapping[str, Any], max_missing_fraction: float) -> Path:
    """L1 -> L2 file for a rigid-mount flight: steady segment, lag, motion correction.

    Parameters
    ----------
    l1_file : str or Path
        :func:`rigid_l1` output.
    output : str or Path
        L2 NetCDF file.
    campaign, flight_id : str
        Campaign name and flight id.
    flight : mapping
        The flight's manifest entry (``sonic`` mount, optional ``target_height_m``).
    site : mapping
        Manifest ``site`` (``altitude_m`` [m]).
    rigid_mount : mapping
        ``processing.rigid_mount``: ``alt_band_m``, ``max_horizontal_speed_ms``,
        ``min_segment_s``, ``max_lag_s``.
    max_missing_fraction : float
        ``processing.max_missing_fraction``.

    Returns
    -------
    Path
        The written file.
    """
    l1 = track_from_cf(strip_cf(open_product(l1_file)))
    mount = rigid.rigid_mount(flight["sonic"], f"payload flight {flight_id} sonic")
    target = flight.get("target_height_m")
    ds = rigid.rigid_l2(l1, mount, alt_band_m=float(rigid_mount["alt_band_m"]),
                        max_horizontal_speed_ms=float(rigid_mount["max_horizontal_speed_ms"]),
                        min_segment_s=float(rigid_mount["min_segment_s"]), max_lag_s=float(rigid_mount["max_lag_s"]),
                        max_missing_fraction=float(max_missing_fraction), site_altitude_m=float(site["altitude_m"]),
                        target_height_m=None if target is None else float(target), flight_id=flight_id)
    ds.attrs["target_height_m"] = float(target) if target is not None else float("nan")
    LOG.info("flight %s rigid-mount L2: lag %.3f s, usable %s %s", flight_id, ds.attrs["lag_sonic_ins_s"],
             ds.attrs["usable"], ds.attrs["unusable_reason"])
    ds = track_to_cf(ds)
    where = Position(float(ds["precise_lat"].median()), float(ds["precise_lon"].median()), float(ds.attrs["height_m"]))
    settings = {"processing": {"rigid_mount": rigid_mount, "max_missing_fraction": max_missing_fraction}}
    return write_product(ds, output, "rigid_l2", {"campaign": campaign, "flight": flight_id}, where, [l1_file],
                         settings)


def drone_l3(drone_l2_file: str | Path, output: str | Path, *, campaign: str, flight_id: str,
             flight: Mapping[str, Any], site: Mapping[str, Any], rotation: str) -> Path:
    """L2 -> drone-only L3 file for a flight without a reference mast.

    Parameters
    ----------
    drone_l2_file : str or Path
        L2 of the drone.
    output : str or Path
        L3 NetCDF file.
    campaign, flight_id : str
        Campaign name and flight id.
    flight : mapping
        The flight's manifest entry.
    site : mapping
        Manifest ``site`` (position of the product).
    rotation : str
        ``processing.rotation``.

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.compare.chain import compute_drone_l3

    ds = compute_drone_l3(track_from_cf(strip_cf(open_product(drone_l2_file))), flight, rotation)
    LOG.info("flight %s drone-only L3: %d samples at %g Hz", flight_id, ds.sizes["time"], ds.attrs["sampling_rate_hz"])
    where = Position(site["latitude"], site["longitude"], float(ds["height_m"].values[0]))
    return write_product(ds, output, "l3_drone", {"campaign": campaign, "flight": flight_id}, where,
                         [drone_l2_file], {"processing": {"rotation": rotation}})


# ----------------------------------------------------------------------------- campaign table

#: Columns of results/<name>/tables/flight_stats.csv (docs/data-contract.md, "Outputs that other tools read").
FLIGHT_STATS_COLUMNS: tuple[str, ...] = (
    "flight", "sensor", "height_m", "U_ms", "wind_from_deg", "sigma_u_ms", "sigma_v_ms", "sigma_w_ms",
    "uw_m2s2", "wT_Kms", "L_m", "zeta", "lag_sonic_ins_s", "lag_drone_mast_s", "Sw_Su", "Sv_Su",
)


def _flight_stats_row(ds: xr.Dataset) -> dict[str, Any]:
    """One row of ``flight_stats.csv`` from an L4 product."""
    sensor = str(ds.attrs["sensor"])
    row: dict[str, Any] = {"flight": ds.attrs["flight"], "sensor": sensor}
    for col in FLIGHT_STATS_COLUMNS[2:]:
        if col == "lag_sonic_ins_s":
            value = ds.attrs.get(col, math.nan) if sensor == "drone" else math.nan
        elif col == "lag_drone_mast_s":
            value = ds.attrs.get(col, math.nan)
        else:
            value = float(ds[col]) if col in ds else math.nan
        row[col] = value
    row["usable"] = int(ds.attrs.get(f"{sensor}_usable", 1))
    row["unusable_reason"] = str(ds.attrs.get(f"{sensor}_unusable_reason", ""))
    return row


def flight_stats(l4_files: Sequence[str | Path], output: str | Path) -> Path:
    """Assemble ``tables/flight_stats.csv``: one row per payload flight and sensor.

    Parameters
    ----------
    l4_files : sequence of path
        L4 files (``<flight>_<sensor>.nc``).
    output : str or Path
        CSV to write (atomically).

    Returns
    -------
    Path
        The written file.
    """
    import pandas as pd

    rows = [_flight_stats_row(open_product(path)) for path in l4_files]
    table = pd.DataFrame(rows, columns=[*FLIGHT_STATS_COLUMNS, "usable", "unusable_reason"])
    table = table.sort_values(["flight", "sensor"], key=lambda s: s.astype(str)).reset_index(drop=True)
    # full precision (shortest round-trip form of each value); the report pages format for reading
    text = table.to_csv(index=False, na_rep="")
    LOG.info("flight_stats: %d rows", len(table))
    return atomic_write_text(output, text)
