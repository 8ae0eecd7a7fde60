"""The payload chain, step by step: from raw flight and mast files to L4 and flight_stats.

Each function reads its inputs, calls the pure library functions and writes its outputs
(NetCDF through :mod:`dronewind.core.cf`, tables atomically). The Snakemake scripts in
``scripts/`` and the ``dronewind`` command line both call these functions, so a step can be
rerun and debugged by hand without Snakemake. This is the only module besides ``cli`` that
does file I/O for the workflow; the science lives in the topical modules.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from dronewind.core.cf import atomic_write_text
from dronewind.manifest import load_campaign
from dronewind.steps.common import LOG, open_product


# ----------------------------------------------------------------------------- payload chain
#
# Each step is a pure ``compute_*`` function (datasets in, dataset out) and a thin file
# wrapper that reads, calls it and writes NetCDF. Snakemake calls the wrappers; the
# diagnosis runs the same compute functions in-process on forward-model flights, so a
# measured and a simulated flight go through identical code.


def _processing(config: Mapping[str, Any]) -> Mapping[str, Any]:
    return config.get("processing", {})


def _window(flight: Mapping[str, Any]) -> tuple[Any, Any] | None:
    window = flight.get("window")
    if not window:
        return None
    from dronewind.manifest import parse_utc

    return parse_utc(window["start"]), parse_utc(window["end"])


def _track_to_cf(ds: Any) -> Any:
    """GNSS track of a hovering platform as CF H.5 ``precise_lat/precise_lon`` (time)."""
    rename = {k: v for k, v in (("lat_deg", "precise_lat"), ("lon_deg", "precise_lon"), ("alt_m", "altitude"))
              if k in ds.variables}
    out = ds.rename(rename)
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


def _track_from_cf(ds: Any) -> Any:
    """Inverse of :func:`_track_to_cf`: back to the library's variable names."""
    pairs = (("precise_lat", "lat_deg"), ("precise_lon", "lon_deg"), ("altitude", "alt_m"))
    return ds.rename({k: v for k, v in pairs if k in ds.variables})


def _strip_cf(ds: Any) -> Any:
    """Drop the writer's station coordinates so a dataset can be processed and re-written."""
    drop = [c for c in ("station", "lat", "lon", "alt") if c in ds.variables]
    out = ds.drop_vars(drop)
    for var in out.variables.values():
        var.attrs.pop("coordinates", None)
        var.encoding.pop("coordinates", None)
    return out


def compute_payload_l1(sonic_file: str | Path, ins_file: str | Path, config: Mapping[str, Any]) -> tuple[Any, Any]:
    """Payload sonic and INS L1 datasets (library names; see :mod:`dronewind.payload.io`)."""
    from dronewind.payload import io as io_payload

    despike = _processing(config).get("despike", {})
    table = io_payload.load_ins_table(ins_file)  # parsed once for the clock fit and the INS L1
    sonic = io_payload.payload_sonic_l1(
        sonic_file, ins_file, despike_window_s=float(despike.get("window_s", 10.0)),
        despike_n_mad=float(despike.get("n_mad", 7.0)), ins_table=table,
    )
    return sonic, io_payload.ins_l1(ins_file, ins_table=table)


def compute_mast_l1(files: list[str | Path], sonic: Mapping[str, Any], config: Mapping[str, Any]) -> Any:
    """Mast sonic L1 dataset from TOA5 files (see :func:`dronewind.mast.toa5.mast_l1`)."""
    from dronewind.mast import toa5

    from dronewind.core import rotation as rot
    from dronewind.errors import DronewindError

    despike = _processing(config).get("despike", {})
    ds = toa5.mast_l1(
        files, azimuth_deg=float(sonic["azimuth_deg"]), height_m=float(sonic["height_m"]), sensor_id=str(sonic["id"]),
        despike_window_s=float(despike.get("window_s", 10.0)), despike_n_mad=float(despike.get("n_mad", 7.0)),
    )
    # Planar fit of this sonic over all its 30-min blocks (used when rotation = planar_fit):
    # the tilt of a fixed instrument is a property of the whole record, not of one flight.
    u, v, w = rot.block_means(ds["time"].values, ds["u_east_ms"].values, ds["v_north_ms"].values,
                              ds["w_up_ms"].values, fs_hz=float(ds.attrs["sampling_rate_hz"]))
    try:
        fit, note = rot.planar_fit_tilt(u, v, w), ""
    except DronewindError as exc:
        fit, note = None, f"no planar fit: {exc}"
    ds.attrs.update(rot.planar_fit_attrs(fit, note))
    return ds


def compute_payload_l2(
    sonic: Any, ins: Any, flight: Mapping[str, Any], site_altitude_m: float, config: Mapping[str, Any]
) -> Any:
    """Payload L2: hover window, sonic-INS lag, motion correction (see :func:`dronewind.payload.sync.payload_l2`)."""
    from dronewind.payload import sync

    proc = _processing(config)
    lag_cfg = proc.get("sonic_ins_lag", {})
    hover = proc.get("hover", {})
    ds = sync.payload_l2(
        sonic, ins, mount=flight["sonic"].get("mount", "upside_down"),
        max_lag_s=float(lag_cfg.get("max_lag_s", 2.0)), lag_step_s=float(lag_cfg.get("step_s", 1 / 32)),
        window=_window(flight), max_missing_fraction=float(proc.get("max_missing_fraction", 0.02)),
        min_hover_s=float(hover.get("min_duration_s", 600.0)),
        hover_alt_tol_m=float(hover.get("alt_tol_m", 3.0)), hover_horiz_tol_m=float(hover.get("horiz_tol_m", 4.0)),
        site_altitude_m=float(site_altitude_m),
    )
    ds.attrs["target_height_m"] = float(flight.get("target_height_m", float("nan")))
    return ds


def compute_mast_l2(
    mast: Any, drone_l2: Any, flight_id: str, config: Mapping[str, Any], source: str | Path = "mast L1",
    margin_s: float = 30.0, min_coverage: float = 0.9,
) -> Any:
    """The reference mast sonic over a flight's hover window.

    The window is the drone's L2 span widened by the drone-mast lag search range and a
    margin, so that alignment can shift the drone by up to ``max_lag_s`` either way.

    Raises
    ------
    InputError
        When the valid mast data cover less than ``min_coverage`` of the hover window.
    """
    import numpy as np

    from dronewind.errors import InputError

    max_lag_s = float(_processing(config).get("drone_mast", {}).get("max_lag_s", 6.0))
    t0, t1 = drone_l2["time"].values[0], drone_l2["time"].values[-1]
    pad = np.timedelta64(int((max_lag_s + margin_s) * 1e6), "us")
    cut = mast.sel(time=slice(t0 - pad, t1 + pad))
    inside = cut.sel(time=slice(t0, t1))
    span_s = float((t1 - t0) / np.timedelta64(1, "s"))
    covered_s = 0.0
    if inside.sizes["time"] > 1:
        covered_s = np.isfinite(inside["u_east_ms"].values).sum() / float(mast.attrs.get("sampling_rate_hz", 10.0))
    coverage = min(covered_s / span_s, 1.0) if span_s > 0 else 0.0
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


def _planar_fits(mast_l2: Any, rotation: str) -> dict[str, Any] | None:
    """The mast's stored planar fit when ``rotation == "planar_fit"`` (an error when there is none)."""
    from dronewind.core import rotation as rot
    from dronewind.errors import ProcessingError

    if rotation != "planar_fit":
        return None
    fit = rot.planar_fit_from_attrs(dict(mast_l2.attrs))
    if fit is None:
        raise ProcessingError(
            f"rotation 'planar_fit' requested but mast sonic {mast_l2.attrs.get('sensor_id', '?')} has no planar fit: "
            f"{mast_l2.attrs.get('planar_fit_note', 'not computed')} (choose rotation: double, or provide a longer "
            "mast record with at least 3 half-hours from several directions)")
    return {"mast": fit}


def compute_l3(drone_l2: Any, mast_l2: Any, flight: Mapping[str, Any], config: Mapping[str, Any]) -> Any:
    """L3: drone-mast lag, common 8 Hz base, streamline rotation (see :func:`dronewind.payload.sync.align_drone_mast`)."""
    from dronewind.payload import sync

    proc = _processing(config)
    dm = proc.get("drone_mast", {})
    rotation = str(proc.get("rotation", "double"))
    ds = sync.align_drone_mast(
        drone_l2, mast_l2, max_lag_s=float(dm.get("max_lag_s", 6.0)), decimate=int(dm.get("decimation", 4)),
        rotation=rotation, planar_fit=_planar_fits(mast_l2, rotation),
        drone_height_m=float(drone_l2.attrs.get("height_m", flight.get("target_height_m", float("nan")))),
    )
    ds.attrs["lag_sonic_ins_s"] = float(drone_l2.attrs.get("lag_sonic_ins_s", float("nan")))
    ds.attrs["drone_usable"] = int(drone_l2.attrs.get("usable", 1))
    ds.attrs["drone_unusable_reason"] = str(drone_l2.attrs.get("unusable_reason", ""))
    if rotation == "planar_fit":
        ds.attrs["rotation_note"] = ("planar fit (Wilczak et al. 2001) for the mast sonic, from its whole record; "
                                     "double rotation for the drone, whose frame is re-levelled every flight")
    # Streamline components: CF x_wind/y_wind are components along the axes of the
    # coordinate system in use; here x points along the mean wind of each sensor.
    ds["u_ms"].attrs.update(standard_name="x_wind", comment="x axis along the mean wind (streamline coordinates)")
    ds["v_ms"].attrs.update(standard_name="y_wind", comment="y axis 90 degrees counter-clockwise from x")
    ds["w_ms"].attrs.update(standard_name="upward_air_velocity", comment="normal to the mean streamline plane")
    return ds


def compute_l4(l3_ds: Any, sensor: str, config: Mapping[str, Any]) -> Any:
    """L4 of one sensor (see :func:`dronewind.compare.l4.flight_l4`) with a period time coordinate."""
    from dronewind.compare.l4 import flight_l4

    proc = _processing(config)
    spec = proc.get("spectra", {})
    quad = proc.get("quadrant", {})
    ds = flight_l4(
        l3_ds, sensor, n_segments=int(spec.get("segments", 3)), overlap=float(spec.get("overlap", 0.5)),
        n_bins=int(spec.get("bins", 100)), fr_band=(float(quad.get("fr_min", 2.0)), float(quad.get("fr_max", 10.0))),
        quadrant_min_speed_ms=float(quad.get("min_speed_ms", 2.0)),
    )
    for key in ("lag_sonic_ins_s", "lag_drone_mast_s", "drone_usable", "drone_unusable_reason", "reference"):
        if key in l3_ds.attrs:
            ds.attrs[key] = l3_ds.attrs[key]
    return _period_time(ds, l3_ds["time"].values)


def payload_l1(
    manifest: str | Path,
    flight_id: str,
    sonic_file: str | Path,
    ins_file: str | Path,
    out_sonic: str | Path,
    out_ins: str | Path,
    config: Mapping[str, Any],
) -> tuple[Path, Path]:
    """L0 -> L1 files for one payload flight: sonic and INS to UTC with range/spike/gap QC.

    Parameters
    ----------
    manifest : str or Path
        Campaign manifest.
    flight_id : str
        Payload flight id.
    sonic_file, ins_file : str or Path
        Raw payload sonic and INS CSV files.
    out_sonic, out_ins : str or Path
        L1 NetCDF files to write.
    config : mapping
        Workflow configuration.

    Returns
    -------
    tuple of Path
        The written files.
    """
    from dronewind.core.cf import write_netcdf

    campaign = load_campaign(manifest)
    site = campaign.data["site"]
    LOG.info("flight %s: reading %s and %s", flight_id, sonic_file, ins_file)
    sonic, ins = compute_payload_l1(sonic_file, ins_file, config)
    LOG.info("sonic L1: %d samples; %s", sonic.sizes["time"], sonic.attrs.get("processing_log", ""))
    LOG.info("INS L1: %d samples; %s", ins.sizes["time"], ins.attrs.get("processing_log", ""))
    common = dict(config=config, latitude=site["latitude"], longitude=site["longitude"],
                  height_m=float(campaign.payload_flight(flight_id).get("target_height_m", 0.0)) or None,
                  extra_attrs={"campaign": campaign.name, "flight": flight_id})
    a = write_netcdf(
        sonic, out_sonic, title=f"{campaign.name} flight {flight_id}: payload sonic, L1",
        summary="RM Young 81000 sonic on the SAMURAI-S sling load, sensor frame, logger clock "
        "converted to UTC through the INS; range, spike and missing-data flags.",
        processing_level="L1: UTC time, QC flags, flagged values set to NaN",
        history=f"payload_l1 flight {flight_id}", inputs=[sonic_file, ins_file],
        station_id=f"{flight_id}_payload_sonic", nonstandard_group="sensor_frame", **common,
    )
    b = write_netcdf(
        _track_to_cf(ins), out_ins, title=f"{campaign.name} flight {flight_id}: INS, L1",
        summary="SBG Ellipse-D EKF output on the SAMURAI-S payload from the first stable valid GNSS time.",
        processing_level="L1: UTC time, QC flags", history=f"payload_l1 flight {flight_id}",
        inputs=[ins_file], station_id=f"{flight_id}_payload_ins", nonstandard_group="ins_raw", **common,
    )
    return a, b


def mast_l1(
    manifest: str | Path,
    sonic_id: str,
    files: list[str | Path],
    output: str | Path,
    config: Mapping[str, Any],
) -> Path:
    """L0 -> L1 file for one mast sonic: TOA5 files to east/north/up with QC flags.

    Parameters
    ----------
    manifest : str or Path
        Campaign manifest.
    sonic_id : str
        Mast sonic id.
    files : list of path
        TOA5 files of the sonic (concatenated in time order).
    output : str or Path
        L1 NetCDF file.
    config : mapping
        Workflow configuration.

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.core.cf import write_netcdf

    campaign = load_campaign(manifest)
    sonic = campaign.mast_sonics()[sonic_id]
    ds = compute_mast_l1(files, sonic, config)
    LOG.info("mast %s L1: %d samples from %d file(s); %s", sonic_id, ds.sizes["time"], len(files),
             ds.attrs.get("processing_log", ""))
    return write_netcdf(
        ds, output, title=f"{campaign.name} mast sonic {sonic_id}, L1",
        summary=f"{sonic.get('model', 'CSAT3')} sonic at {sonic['height_m']} m on mast {sonic['mast_id']}, "
        "rotated from the sensor frame to east/north/up; range, spike and diagnostic flags.",
        processing_level="L1: UTC time, east/north/up, QC flags", history=f"mast_l1 {sonic_id}",
        inputs=files, config=config, station_id=sonic_id, latitude=sonic["latitude"],
        longitude=sonic["longitude"], height_m=float(sonic["height_m"]),
        extra_attrs={"campaign": campaign.name, "mast": sonic["mast_id"]}, nonstandard_group="sensor_frame",
    )


def payload_l2(
    manifest: str | Path,
    flight_id: str,
    sonic_l1: str | Path,
    ins_l1: str | Path,
    output: str | Path,
    config: Mapping[str, Any],
) -> Path:
    """L1 -> L2 file for one payload flight: hover window, sonic-INS lag, motion correction.

    Parameters
    ----------
    manifest : str or Path
        Campaign manifest.
    flight_id : str
        Payload flight id.
    sonic_l1, ins_l1 : str or Path
        L1 files of the flight.
    output : str or Path
        L2 NetCDF file.
    config : mapping
        Workflow configuration.

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.core.cf import write_netcdf

    campaign = load_campaign(manifest)
    sonic = _strip_cf(open_product(sonic_l1))
    ins = _track_from_cf(_strip_cf(open_product(ins_l1)))
    ds = compute_payload_l2(sonic, ins, campaign.payload_flight(flight_id),
                            float(campaign.data["site"]["altitude_m"]), config)
    LOG.info("flight %s L2: lag_sonic_ins_s = %.4f, usable = %s %s", flight_id, ds.attrs["lag_sonic_ins_s"],
             ds.attrs["usable"], ds.attrs.get("unusable_reason", ""))
    ds = _track_to_cf(ds)
    lat = float(ds["precise_lat"].median()) if "precise_lat" in ds else campaign.data["site"]["latitude"]
    lon = float(ds["precise_lon"].median()) if "precise_lon" in ds else campaign.data["site"]["longitude"]
    return write_netcdf(
        ds, output, title=f"{campaign.name} flight {flight_id}: drone wind, L2",
        summary="Synchronised (sonic-INS lag of minimum TKE) and motion-corrected wind from the "
        "SAMURAI-S payload in east/north/up at the sonic rate, hover window only.",
        processing_level="L2: synchronised, motion-corrected, east/north/up", history=f"payload_l2 {flight_id}",
        inputs=[sonic_l1, ins_l1], config=config, station_id=f"{flight_id}_drone", latitude=lat, longitude=lon,
        height_m=float(ds.attrs.get("height_m", ds.attrs["target_height_m"])),
        extra_attrs={"campaign": campaign.name, "flight": flight_id}, nonstandard_group="synchronisation",
    )


def mast_l2(
    manifest: str | Path,
    flight_id: str,
    mast_l1_file: str | Path,
    drone_l2_file: str | Path,
    output: str | Path,
    config: Mapping[str, Any],
) -> Path:
    """Mast L1 -> L2 file for one flight: the reference sonic over the flight's hover window.

    Parameters
    ----------
    manifest : str or Path
        Campaign manifest.
    flight_id : str
        Payload flight id (its ``reference`` names the mast sonic).
    mast_l1_file : str or Path
        L1 file of the reference mast sonic.
    drone_l2_file : str or Path
        L2 file of the drone (gives the hover window).
    output : str or Path
        L2 mast file to write.
    config : mapping
        Workflow configuration.

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.core.cf import write_netcdf

    campaign = load_campaign(manifest)
    flight = campaign.payload_flight(flight_id)
    sonic = campaign.mast_sonics()[flight["reference"]]
    cut = compute_mast_l2(_strip_cf(open_product(mast_l1_file)), open_product(drone_l2_file), flight_id, config,
                          source=mast_l1_file)
    LOG.info("flight %s mast L2: %d samples, coverage %.1f %%", flight_id, cut.sizes["time"],
             100 * cut.attrs["flight_coverage_fraction"])
    return write_netcdf(
        cut, output, title=f"{campaign.name} flight {flight_id}: reference mast sonic, L2",
        summary=f"Mast sonic {flight['reference']} in east/north/up over the hover window of flight {flight_id}.",
        processing_level="L2: east/north/up, flight window", history=f"mast_l2 {flight_id}",
        inputs=[mast_l1_file, drone_l2_file], config=config, station_id=flight["reference"],
        latitude=sonic["latitude"], longitude=sonic["longitude"], height_m=float(sonic["height_m"]),
        extra_attrs={"campaign": campaign.name, "flight": flight_id}, nonstandard_group="sensor_frame",
    )


def l3(
    manifest: str | Path,
    flight_id: str,
    drone_l2_file: str | Path,
    mast_l2_file: str | Path,
    output: str | Path,
    config: Mapping[str, Any],
) -> Path:
    """L2 -> L3 file for one flight: drone-mast lag, common 8 Hz base, streamline rotation.

    Parameters
    ----------
    manifest : str or Path
        Campaign manifest.
    flight_id : str
        Payload flight id.
    drone_l2_file, mast_l2_file : str or Path
        L2 files of the flight.
    output : str or Path
        L3 NetCDF file.
    config : mapping
        Workflow configuration.

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.core.cf import write_netcdf

    campaign = load_campaign(manifest)
    flight = campaign.payload_flight(flight_id)
    drone = _track_from_cf(_strip_cf(open_product(drone_l2_file)))
    mast = _strip_cf(open_product(mast_l2_file))
    ds = compute_l3(drone, mast, flight, config)
    LOG.info("flight %s L3: lag_drone_mast_s = %.3f, %d samples at %g Hz", flight_id, ds.attrs["lag_drone_mast_s"],
             ds.sizes["time"], ds.attrs["sampling_rate_hz"])
    sonic = campaign.mast_sonics()[flight["reference"]]
    return write_netcdf(
        ds, output, title=f"{campaign.name} flight {flight_id}: drone and mast aligned, L3",
        summary="Drone and reference mast sonic aligned by the advection lag, decimated to a common rate "
        "with an FIR anti-alias filter and rotated into streamline coordinates.",
        processing_level="L3: aligned, decimated, streamline coordinates", history=f"l3 {flight_id}",
        inputs=[drone_l2_file, mast_l2_file], config=config, station_id=f"{flight_id}_drone_and_mast",
        latitude=sonic["latitude"], longitude=sonic["longitude"], height_m=float(sonic["height_m"]),
        extra_attrs={"campaign": campaign.name, "flight": flight_id, "reference": flight["reference"]},
        nonstandard_group="alignment",
    )


# ----------------------------------------------------------------------------- simulation


def simulate_payload(manifest: str | Path, flight_id: str, out_dir: str | Path) -> list[Path]:
    """Write the raw files of one simulated payload flight (sonic, INS, mast TOA5).

    Parameters
    ----------
    manifest : str or Path
        Manifest with a ``simulation:`` section.
    flight_id : str
        Payload flight id.
    out_dir : str or Path
        L0 folder of the campaign (``results/<name>/L0``); files go to the manifest's
        relative paths below it.

    Returns
    -------
    list of Path
        The written files.
    """
    from dronewind.simulate.payload import simulate_payload_flight

    campaign = load_campaign(manifest)
    paths = simulate_payload_flight(campaign.data, campaign.directory, flight_id, Path(out_dir))
    for path in paths:
        LOG.info("wrote %s", path)
    return paths


# ----------------------------------------------------------------------------- analysis


def l4(
    manifest: str | Path,
    flight_id: str,
    sensor: str,
    l3_file: str | Path,
    output: str | Path,
    config: Mapping[str, Any],
) -> Path:
    """L3 -> L4 file for one flight and sensor: statistics, spectra, fits, uncertainties, scales.

    Parameters
    ----------
    manifest : str or Path
        Campaign manifest.
    flight_id : str
        Payload flight id.
    sensor : str
        ``"drone"`` or ``"mast"``.
    l3_file : str or Path
        L3 file of the flight.
    output : str or Path
        L4 NetCDF file.
    config : mapping
        Workflow configuration.

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.core.cf import write_netcdf

    campaign = load_campaign(manifest)
    flight = campaign.payload_flight(flight_id)
    ds = compute_l4(_strip_cf(open_product(l3_file)), sensor, config)
    sonic = campaign.mast_sonics()[flight["reference"]]
    LOG.info("flight %s %s L4: U = %.2f m/s, sigma_w = %.3f m/s", flight_id, sensor,
             float(ds["U_ms"]), float(ds["sigma_w_ms"]))
    return write_netcdf(
        ds, output, title=f"{campaign.name} flight {flight_id}: {sensor} statistics and spectra, L4",
        summary="Mean wind, standard deviations, skewness, kurtosis, fluxes, friction velocity, TKE, Obukhov "
        "length, spectra with blunt/pointed model fits, isotropy ratios, random-error estimates and "
        "integral scales (seed 000, Sects. 4.1-4.3).",
        processing_level="L4: statistics, spectra, uncertainties, scales", history=f"l4 {flight_id} {sensor}",
        inputs=[l3_file], config=config, feature_type=None, latitude=sonic["latitude"],
        longitude=sonic["longitude"], height_m=float(ds["height_m"]),
        extra_attrs={"campaign": campaign.name, "flight": flight_id, "sensor": sensor}, nonstandard_group="analysis",
    )


def _period_time(ds: Any, times: Any) -> Any:
    """Scalar time coordinate (mid-period) with bounds for statistics over a record (CF 7.1)."""
    import numpy as np
    import xarray as xr

    t0, t1 = times.min(), times.max()
    out = ds.assign_coords(time=xr.DataArray([t0 + (t1 - t0) / 2], dims=("time",), attrs={"bounds": "time_bnds"}))
    out["time_bnds"] = xr.DataArray(np.array([[t0, t1]]), dims=("time", "nv"))
    return out


#: Columns of results/<name>/tables/flight_stats.csv (DESIGN.md, "Outputs that other tools read").
FLIGHT_STATS_COLUMNS: tuple[str, ...] = (
    "flight", "sensor", "height_m", "U_ms", "wind_from_deg", "sigma_u_ms", "sigma_v_ms", "sigma_w_ms",
    "uw_m2s2", "wT_Kms", "L_m", "zeta", "lag_sonic_ins_s", "lag_drone_mast_s", "Sw_Su", "Sv_Su",
)


def flight_stats(l4_files: list[str | Path], output: str | Path) -> Path:
    """Assemble ``tables/flight_stats.csv``: one row per payload flight and sensor.

    Parameters
    ----------
    l4_files : list of path
        L4 files (``<flight>_<sensor>.nc``).
    output : str or Path
        CSV to write (atomically).

    Returns
    -------
    Path
        The written file.
    """
    import math

    import pandas as pd

    rows = []
    for path in l4_files:
        ds = open_product(path)
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
        row["usable"] = int(ds.attrs.get("drone_usable", 1)) if sensor == "drone" else 1
        row["unusable_reason"] = str(ds.attrs.get("drone_unusable_reason", "")) if sensor == "drone" else ""
        rows.append(row)
    table = pd.DataFrame(rows, columns=[*FLIGHT_STATS_COLUMNS, "usable", "unusable_reason"])
    table = table.sort_values(["flight", "sensor"], key=lambda s: s.astype(str)).reset_index(drop=True)
    text = table.to_csv(index=False, float_format="%.6g", na_rep="")
    LOG.info("flight_stats: %d rows", len(table))
    return atomic_write_text(output, text)
