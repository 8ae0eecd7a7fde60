"""The quadrotor (SWUF-3D, Wetz et al. 2021) and wind-tunnel (Kistner et al. 2024) workflow steps: files in, files out.

Each function reads its inputs, calls the library (:mod:`dronewind.quadrotor.chain`,
:mod:`dronewind.tunnel.analysis`, :mod:`dronewind.diagnose.quadrotor`, the simulators) and
writes its outputs: NetCDF through :func:`dronewind.core.cf.write_netcdf`, tables
atomically. The settings and manifest entries a step uses are its arguments (Snakemake
passes them as ``params``). Snakemake scripts in ``workflow/scripts/quadrotor_*.py`` and
``workflow/scripts/tunnel_*.py`` call them; they can be rerun by hand. The workflow runs the
fleet's per-flight steps for every flight in one job each (the simulation, L1 and windows, L2):
a flight's UAV files are named by the manifest, which no wildcard pattern describes.

Steps and products (``R = results/<name>``):

* :func:`simulate_quadrotor` / :func:`simulate_tunnel` (virtual campaigns only): L0 files.
* :func:`quadrotor_l1_flight` (per flight; :func:`quadrotor_l1` for each of its UAVs):
  ``R/netcdf/L1/quadrotor/<flight>_<uav>.nc`` (attitude and GNSS log in CF form).
* :func:`quadrotor_windows` (per flight): the flight's averaging windows
  ``R/quadrotor/windows/<flight>_{windows,blocks,problems}.csv`` (10-min and 2-min windows,
  Wetz et al. (2021), Sect. 5 and App. C; UAV logs that cannot be used are listed, never dropped
  silently).
* :func:`quadrotor_calibration` (campaign): ``R/tables/quadrotor_calibration.csv`` (the
  contract table), ``quadrotor_table2/3/C1/C2.csv``, ``quadrotor_direction.csv``,
  ``quadrotor_windows.csv`` (per-window predictions that the figures plot),
  ``quadrotor_profiles.csv``, ``quadrotor_problems.csv`` and ``R/quadrotor/calibration.json``.
* :func:`quadrotor_l2_flight` (per flight; :func:`quadrotor_l2` for each of its UAVs):
  ``R/netcdf/L2/quadrotor/<flight>_<uav>.nc``, the calibrated 1 Hz wind of the UAV (Wetz et al. (2021)
  Sect. 6).
* :func:`quadrotor_diagnosis` (campaign): ``R/quadrotor_diagnosis.json``.
* :func:`tunnel_analysis`: ``R/tables/tunnel_<table>.csv`` (Kistner et al. (2024), Table 2 equivalent,
  Figs 4-5 RMSEs, gusts, steps, turbulence).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from dronewind.core.cf import atomic_write_text, data_source, write_netcdf
from dronewind.core.cf_names import strip_cf, track_from_cf
from dronewind.errors import InputError, ProcessingError
from dronewind.manifest import confined_path
from dronewind.quadrotor import chain
from dronewind.quadrotor.chain import QUAD_TABLES
from dronewind.quadrotor.io import read_quadrotor
from dronewind.quadrotor.reference import read_tower_reference
from dronewind.steps.common import LOG, open_product
from dronewind.tunnel import TUNNEL_TABLES

__all__ = [
    "QUAD_TABLES", "simulate_quadrotor", "simulate_tunnel", "tunnel_root",
    "quadrotor_l1", "quadrotor_l1_flight", "quadrotor_windows", "read_windows", "quadrotor_calibration",
    "quadrotor_l2", "quadrotor_l2_flight", "quadrotor_diagnosis", "tunnel_analysis",
]


def _csv(frame: pd.DataFrame, path: str | Path) -> Path:
    return atomic_write_text(path, frame.to_csv(index=False, float_format="%.8g", na_rep=""))


# ----------------------------------------------------------------------------- simulation


def simulate_quadrotor(flight: Mapping[str, Any], simulation: Mapping[str, Any], site: Mapping[str, Any],
                       out_dir: str | Path) -> list[Path]:
    """Write the L0 files of one simulated quadrotor flight (UAV CSVs and tower reference).

    Parameters
    ----------
    flight : mapping
        The flight's manifest entry (``id``, ``reference``, ``uavs``).
    simulation : mapping
        The parts of the manifest's ``simulation`` section this flight uses: ``seed``,
        ``quadrotor`` (fleet settings), ``quadrotor_flights: {<id>: conditions}`` and
        ``mechanisms``.
    site : mapping
        The manifest's ``site``.
    out_dir : str or Path
        L0 root (``results/<name>/L0``); files go to the manifest's relative paths.

    Returns
    -------
    list of Path
        The written files.
    """
    from dronewind.simulate.quadrotor import simulate_quadrotor_flight

    confined_path(out_dir, str(flight["reference"]), f"quadrotor flight {flight['id']} reference")
    for uav in flight["uavs"]:
        confined_path(out_dir, str(uav["file"]), f"quadrotor flight {flight['id']} uav {uav['id']} file")
    campaign = {"site": dict(site), "quadrotor_flights": [dict(flight)], "simulation": dict(simulation)}
    paths = simulate_quadrotor_flight(campaign, Path(out_dir), str(flight["id"]), Path(out_dir))
    for path in paths:
        LOG.info("wrote %s", path)
    return paths


def tunnel_root(runs: str) -> Path:
    """Folder below which a simulated tunnel campaign writes ``tunnel/runs.csv``.

    The simulator always writes ``<root>/tunnel/runs.csv``; the manifest's ``tunnel.runs``
    must therefore end in ``tunnel/runs.csv``.

    Raises
    ------
    InputError
        Naming ``tunnel.runs`` when it does not.
    """
    rel = Path(runs)
    if rel.name != "runs.csv" or rel.parent.name != "tunnel":
        raise InputError("tunnel.runs", f"{runs!r}: a simulated tunnel campaign writes '<folder>/tunnel/runs.csv'")
    return rel.parent.parent


def simulate_tunnel(simulation: Mapping[str, Any], runs: str, out_dir: str | Path) -> list[Path]:
    """Write the L0 files of a simulated wind-tunnel campaign (``simulation.tunnel``).

    Parameters
    ----------
    simulation : mapping
        The manifest's ``simulation`` section (``tunnel`` and ``seed`` are read).
    runs : str
        The manifest's ``tunnel.runs`` (path of the run index, ending in ``tunnel/runs.csv``).
    out_dir : str or Path
        L0 root; the run index goes to ``out_dir / runs``.

    Returns
    -------
    list of Path
        Files written (run index last).

    Raises
    ------
    InputError
        Without ``simulation.tunnel``, or when ``runs`` does not end in ``tunnel/runs.csv``.

    Notes
    -----
    The seed is SHA-256 of ``"<campaign seed>:tunnel"`` (like a flight's seed).
    """
    from dronewind.simulate.settings import flight_seed
    from dronewind.simulate.tunnel import simulate_tunnel as _simulate

    if "tunnel" not in simulation:
        raise InputError("simulation.tunnel", "missing: a simulated tunnel campaign needs its settings")
    root = Path(out_dir) / tunnel_root(runs)
    paths = _simulate(dict(simulation.get("tunnel") or {}), root, flight_seed(int(simulation.get("seed", 0)), "tunnel"))
    LOG.info("tunnel: wrote %d files under %s", len(paths), root / "tunnel")
    return paths


# ----------------------------------------------------------------------------- per flight and UAV


def quadrotor_l1(campaign: str, flight_id: str, uav: str, log_file: str | Path, site: Mapping[str, Any],
                 out_l1: str | Path, *, simulated: bool, attribution: Mapping[str, str] | None = None,
                 fmt: str | Mapping[str, Any] | None = None) -> Path:
    """L0 -> L1 NetCDF of one UAV log (attitude and GNSS in CF form).

    Parameters
    ----------
    campaign : str
        Campaign name.
    flight_id, uav : str
        Quadrotor flight and UAV ids.
    log_file : str or Path
        Raw log (CSV or ULog).
    site : mapping
        The manifest's ``site`` (nominal position when the log has no track).
    out_l1 : str or Path
        L1 NetCDF to write.

    simulated : bool
        The campaign is virtual (its manifest has ``simulation:``): stated in ``source``.
    attribution : mapping, optional
        Creator and licence from the manifest (:func:`dronewind.core.attribution.attribution`),
        inherited by every later level.
    fmt : str or mapping, optional
        The UAV's declared ``format`` (:func:`dronewind.quadrotor.io.read_quadrotor`; default:
        by the file suffix).

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    InputError
        A log that cannot be read (e.g. without attitude columns): its L1 file cannot be
        written, so the job stops naming the file and what is missing.
    """
    ds = chain.compute_quadrotor_l1(read_quadrotor(log_file, fmt))
    lat, lon, height = chain.nominal_position(ds, site)
    LOG.info("flight %s uav %s L1: %d samples; %s", flight_id, uav, ds.sizes["time"],
             ds.attrs.get("processing_log", "").replace("\n", "; "))
    return write_netcdf(
        ds, out_l1, title=f"{campaign} flight {flight_id}: quadrotor {uav} attitude and GNSS, L1",
        summary="Attitude (roll, pitch, yaw) and GNSS/EKF velocity and position of a SWUF-3D quadrotor as "
                "logged, time sorted and de-duplicated (Wetz et al. (2021), Sect. 2).",
        processing_level="L1: UTC time, sorted, duplicates removed", history=f"quadrotor_flight {flight_id} {uav}",
        inputs=[log_file], config={}, station_id=f"{flight_id}_{uav}", latitude=lat, longitude=lon,
        height_m=height, extra_attrs={"campaign": campaign, "flight": flight_id, "uav": uav,
                                      "source": data_source(simulated), **(attribution or {})},
        nonstandard_group="platform_velocity")


def _per_uav(flight_id: str, uavs: Sequence[str], **files: Sequence[str | Path]) -> None:
    """Check that each list of files has one entry per UAV of the flight (same order)."""
    for name, paths in files.items():
        if len(paths) != len(uavs):
            raise ProcessingError(f"quadrotor flight {flight_id}: {len(paths)} {name} for {len(uavs)} UAVs "
                                  f"({', '.join(uavs)})")


def quadrotor_l1_flight(campaign: str, flight_id: str, uavs: Sequence[str], log_files: Sequence[str | Path],
                        site: Mapping[str, Any], out_l1: Sequence[str | Path], *, simulated: bool,
                        attribution: Mapping[str, str] | None = None,
                        formats: Sequence[str | Mapping[str, Any] | None] | None = None) -> list[Path]:
    """L0 -> L1 NetCDF of every UAV of a quadrotor flight (:func:`quadrotor_l1` for each).

    One workflow job per flight: the UAVs are processed in one process, which pays the
    library imports once.

    Parameters
    ----------
    campaign : str
        Campaign name.
    flight_id : str
        Quadrotor flight id.
    uavs : sequence of str
        The flight's UAV ids (manifest order).
    log_files, out_l1 : sequence of str or Path
        Raw log and L1 file of each UAV, in the order of ``uavs``.
    site : mapping
        The manifest's ``site``.
    simulated : bool
        The campaign is virtual (stated in ``source``).
    attribution : mapping, optional
        As :func:`quadrotor_l1`.
    formats : sequence, optional
        Each UAV's declared ``format`` (None: by the file suffix), in the order of ``uavs``.

    Returns
    -------
    list of Path
        The written files, in the order of ``uavs``.
    """
    _per_uav(flight_id, uavs, logs=log_files, outputs=out_l1)
    fmts = list(formats) if formats is not None else [None] * len(uavs)
    return [quadrotor_l1(campaign, flight_id, uav, log, site, out, simulated=simulated, attribution=attribution,
                         fmt=fmt)
            for uav, log, out, fmt in zip(uavs, log_files, out_l1, fmts, strict=True)]


def quadrotor_windows(flight: Mapping[str, Any], l1_files: Mapping[str, str | Path], reference_file: str | Path,
                      site_altitude_m: float, block_s: float, hover: Mapping[str, float],
                      out_windows: str | Path, out_blocks: str | Path, out_problems: str | Path) -> list[Path]:
    """Averaging windows of every UAV of a flight (see :func:`dronewind.quadrotor.chain.compute_flight_windows`).

    Parameters
    ----------
    flight : mapping
        The flight's manifest entry (``id``, ``uavs`` with their ``file``).
    l1_files : mapping
        UAV id -> L1 file.
    reference_file : str or Path
        Tower reference CSV.
    site_altitude_m : float
        Ground altitude above MSL [m].
    block_s : float
        Block length of the attitude averages [s].
    hover : mapping
        Hover selection settings (:func:`dronewind.quadrotor.hover.hover_segment`).
    out_windows, out_blocks, out_problems : str or Path
        CSV files to write.

    Returns
    -------
    list of Path
        Written files.
    """
    flight_id = str(flight["id"])
    logs = {uav: track_from_cf(strip_cf(open_product(path))) for uav, path in l1_files.items()}
    if isinstance(flight.get("reference"), Mapping):
        # the reference is each UAV record's own ref_speed/ref_from columns: windows UAV by UAV
        return _windows_from_records(flight, logs, site_altitude_m, block_s, hover, out_windows, out_blocks,
                                     out_problems)
    try:
        ref = read_tower_reference(reference_file)
    except InputError as exc:
        LOG.warning("flight %s: %s", flight_id, exc)
        w, b, problems = chain.unreadable_reference(list(logs), str(Path(reference_file).name), flight_id, exc)
    else:
        files = {u["id"]: Path(u["file"]).name for u in flight["uavs"]}
        w, b, problems = chain.compute_flight_windows(logs, ref, flight_id, float(site_altitude_m), files,
                                                      block_s=float(block_s), hover=hover)
    LOG.info("flight %s: %d windows (600 s and 120 s), %d problem(s)", flight_id, len(w), len(problems))
    return [_csv(w, out_windows), _csv(b, out_blocks), _csv(problems, out_problems)]


def _windows_from_records(flight: Mapping[str, Any], logs: Mapping[str, Any], site_altitude_m: float, block_s: float,
                          hover: Mapping[str, float], out_windows: str | Path, out_blocks: str | Path,
                          out_problems: str | Path) -> list[Path]:
    """:func:`quadrotor_windows` for a flight whose reference is in the UAV records' columns."""
    from dronewind.quadrotor.delimited import reference_from_record

    flight_id = str(flight["id"])
    files = {u["id"]: Path(u["file"]).name for u in flight["uavs"]}
    parts = []
    for uav, ds in logs.items():
        try:
            ref = reference_from_record(ds, float(flight["reference"]["height_m"]))
        except InputError as exc:
            parts.append(chain.unreadable_reference([uav], files.get(uav, ""), flight_id, exc))
            continue
        parts.append(chain.compute_flight_windows({uav: ds}, ref, flight_id, float(site_altitude_m), files,
                                                  block_s=float(block_s), hover=hover))
    w, b, problems = (pd.concat([p[i] for p in parts], ignore_index=True) for i in range(3))
    LOG.info("flight %s: %d windows (600 s and 120 s) against the records' own reference, %d problem(s)",
             flight_id, len(w), len(problems))
    return [_csv(w, out_windows), _csv(b, out_blocks), _csv(problems, out_problems)]


# ----------------------------------------------------------------------------- campaign


def read_windows(windows_files: Sequence[str | Path], blocks_files: Sequence[str | Path],
                 window_s: float) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Concatenate per-flight window and block tables of one window length.

    Returns
    -------
    blocks, windows : pandas.DataFrame
        As :func:`dronewind.quadrotor.windows.flight_windows` (``start``/``end`` as datetime64).
    """
    ws = [pd.read_csv(f, dtype={"flight": str, "uav": str, "window_key": str}) for f in windows_files]
    bs = [pd.read_csv(f, dtype={"window_key": str}) for f in blocks_files]
    w = pd.concat([x for x in ws if len(x)], ignore_index=True) if any(len(x) for x in ws) else ws[0]
    b = pd.concat([x for x in bs if len(x)], ignore_index=True) if any(len(x) for x in bs) else bs[0]
    w = w[np.isclose(w["window_s"].astype(float), window_s)].reset_index(drop=True)
    b = b[np.isclose(b["window_s"].astype(float), window_s)].reset_index(drop=True)
    for col in ("start", "end"):
        w[col] = pd.to_datetime(w[col].astype(str).str.rstrip("Z")).astype("datetime64[ns]")
    return b.drop(columns="window_s"), w


def _json_default(value: Any) -> Any:
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return None if not np.isfinite(value) else float(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, pd.Timestamp | np.datetime64):
        return str(value)
    return str(value)


def quadrotor_calibration(campaign: str, windows_files: Sequence[str | Path], blocks_files: Sequence[str | Path],
                          problems_files: Sequence[str | Path], tables_dir: str | Path, summary_file: str | Path,
                          calibration_window_s: float, roles: Mapping[str, str] | None = None) -> list[Path]:
    """Campaign calibration and validation tables of the quadrotor fleet (Wetz et al. (2021), Sect. 5).

    Parameters
    ----------
    campaign : str
        Campaign name.
    windows_files, blocks_files, problems_files : sequence of path
        Per-flight outputs of :func:`quadrotor_windows`.
    tables_dir : str or Path
        ``results/<name>/tables``; files ``<name>.csv`` for each of :data:`QUAD_TABLES`.
    summary_file : str or Path
        JSON with the aerodynamic parameters, convergence, scenarios and hover accuracy.
    calibration_window_s : float
        Window length of the contract table [s] (600, or 120 for short flights).
    roles : mapping, optional
        Flight id -> ``calibration`` or ``validation`` (the manifest's ``role``).

    Returns
    -------
    list of Path
        Written files.

    Notes
    -----
    A calibration that does not converge is not hidden: ``converged`` is 0 in the contract
    table and ``status`` in the JSON says so, and the log carries a warning.
    """
    b10, w10 = read_windows(windows_files, blocks_files, 600.0)
    b2, w2 = read_windows(windows_files, blocks_files, 120.0)
    probs = [pd.read_csv(f, dtype=str) for f in problems_files]
    problems = pd.concat(probs, ignore_index=True) if probs else pd.DataFrame()
    res = chain.compute_quadrotor_tables(b10, w10, b2, w2, problems, float(calibration_window_s), roles=roles)
    summary = {"campaign": campaign, **res.pop("summary")}
    if not summary["converged"]:
        LOG.warning("quadrotor calibration did not converge: %s", summary["aero"])
    written = [_csv(res[name], Path(tables_dir) / f"{name}.csv") for name in QUAD_TABLES]
    written.append(atomic_write_text(summary_file, json.dumps(summary, indent=2, default=_json_default) + "\n"))
    LOG.info("quadrotor calibration: c_d0A0 = %.4f m2, c_p = %.4f m2/rad; mean RMSE %.3f m/s",
             summary["aero"]["cd0a0_m2"], summary["aero"]["cp_m2_per_rad"],
             float(np.nanmean(res["quadrotor_calibration"]["rmse_ms"])))
    return written


def quadrotor_diagnosis(campaign: str, windows_files: Sequence[str | Path], blocks_files: Sequence[str | Path],
                        runs_file: str | Path | None, output: str | Path, alpha: float, min_gain: float,
                        window_s: float) -> Path:
    """Diagnosis of the single-law quadrotor model (:func:`dronewind.diagnose.quadrotor.diagnose_quadrotor`).

    Parameters
    ----------
    campaign : str
        Campaign name.
    windows_files, blocks_files : sequence of path
        Per-flight outputs of :func:`quadrotor_windows` (may be empty: no field part).
    runs_file : str or Path or None
        Tunnel run index (None: no tunnel part).
    output : str or Path
        ``quadrotor_diagnosis.json``.
    alpha : float
        Family-wise false-alarm rate per naming round.
    min_gain : float
        Smallest held-out gain that names a cause.
    window_s : float
        Window length of the field part [s].

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.diagnose.quadrotor import diagnose_quadrotor, to_json_ready

    blocks = windows = None
    if windows_files:
        blocks, windows = read_windows(windows_files, blocks_files, float(window_s))
    res = diagnose_quadrotor(campaign, blocks, windows, runs_file, alpha=float(alpha), min_gain=float(min_gain))
    LOG.info("quadrotor diagnosis: named causes %s", res["named_causes"])
    for c in res["candidates"]:
        LOG.info("  %s (%s): gain %.3f, p %.2g, significant %s", c["mechanism"], c["source"], c["gain"],
                 c["p_value"], c["significant"])
    return atomic_write_text(output, json.dumps(to_json_ready(res), indent=2) + "\n")


# ----------------------------------------------------------------------------- L2 per flight and UAV


def quadrotor_l2(campaign: str, flight_id: str, uav: str, l1_file: str | Path, calibration_file: str | Path,
                 summary_file: str | Path, site: Mapping[str, Any], out_l2: str | Path, average_s: float,
                 hover: Mapping[str, float]) -> Path:
    """L1 -> L2 NetCDF of one UAV: calibrated 1 Hz wind (Wetz et al. (2021), Sect. 6, Fig. 7).

    Parameters
    ----------
    campaign : str
        Campaign name.
    flight_id, uav : str
        Quadrotor flight and UAV ids.
    l1_file : str or Path
        The UAV's L1 file.
    calibration_file, summary_file : str or Path
        ``tables/quadrotor_calibration.csv`` and ``quadrotor/calibration.json``.
    site : mapping
        The manifest's ``site``.
    out_l2 : str or Path
        L2 file to write.
    average_s : float
        Output averaging [s].
    hover : mapping
        Hover selection settings (:func:`dronewind.quadrotor.hover.hover_segment`).

    Returns
    -------
    Path
        The written file.
    """
    table = pd.read_csv(calibration_file, dtype={"uav": str})
    aero = json.loads(Path(summary_file).read_text())["aero"]
    log = track_from_cf(strip_cf(open_product(l1_file)))
    ds = chain.compute_quadrotor_l2(log, table, aero, uav, float(average_s), hover)
    LOG.info("flight %s uav %s L2: %d samples, usable %d %s", flight_id, uav, ds.sizes["time"],
             ds.attrs["usable"], ds.attrs["unusable_reason"])
    ds = chain.uav_track_to_cf(ds)
    lat, lon, height = chain.nominal_position(ds, site)
    return write_netcdf(
        ds, out_l2, title=f"{campaign} flight {flight_id}: quadrotor {uav} wind, L2",
        summary="Horizontal wind from the attitude of a hovering SWUF-3D quadrotor: drag balance with the "
                "universal aerodynamic parameters and the UAV's pitch and yaw offsets from the campaign "
                "calibration, GNSS velocity added, 1 s averages over the hover (Wetz et al. 2021, Eqs 12-18, Sect. 6).",
        processing_level="L2: calibrated wind, earth frame", history=f"quadrotor_l2 {flight_id} {uav}",
        inputs=[l1_file, calibration_file, summary_file],
        config={"average_s": average_s, "hover": dict(hover)}, station_id=f"{flight_id}_{uav}",
        latitude=lat, longitude=lon, height_m=height,
        extra_attrs={"campaign": campaign, "flight": flight_id, "uav": uav}, nonstandard_group="weather_vane")


def quadrotor_l2_flight(campaign: str, flight_id: str, uavs: Sequence[str], l1_files: Sequence[str | Path],
                        calibration_file: str | Path, summary_file: str | Path, site: Mapping[str, Any],
                        out_l2: Sequence[str | Path], average_s: float, hover: Mapping[str, float]) -> list[Path]:
    """L1 -> L2 NetCDF of every UAV of a quadrotor flight (:func:`quadrotor_l2` for each).

    One workflow job per flight (the library imports are paid once per flight).

    Parameters
    ----------
    campaign : str
        Campaign name.
    flight_id : str
        Quadrotor flight id.
    uavs : sequence of str
        The flight's UAV ids (manifest order).
    l1_files, out_l2 : sequence of str or Path
        L1 file and L2 file of each UAV, in the order of ``uavs``.
    calibration_file, summary_file : str or Path
        ``tables/quadrotor_calibration.csv`` and ``quadrotor/calibration.json``.
    site : mapping
        The manifest's ``site``.
    average_s : float
        Output averaging [s].
    hover : mapping
        Hover selection settings.

    Returns
    -------
    list of Path
        The written files, in the order of ``uavs``.
    """
    _per_uav(flight_id, uavs, l1_files=l1_files, outputs=out_l2)
    return [quadrotor_l2(campaign, flight_id, uav, l1, calibration_file, summary_file, site, out, average_s, hover)
            for uav, l1, out in zip(uavs, l1_files, out_l2, strict=True)]



# ----------------------------------------------------------------------------- tunnel


def tunnel_analysis(campaign: str, runs_file: str | Path, tables_dir: str | Path) -> list[Path]:
    """All Kistner et al. (2024) tables of the tunnel campaign (:func:`dronewind.tunnel.analysis.analyse_tunnel`).

    Parameters
    ----------
    campaign : str
        Campaign name (for the log only).
    runs_file : str or Path
        ``tunnel/runs.csv``.
    tables_dir : str or Path
        Output folder; one ``tunnel_<table>.csv`` per :data:`TUNNEL_TABLES` (empty tables
        for run kinds absent from the programme).

    Returns
    -------
    list of Path
        Written files.

    Raises
    ------
    InputError
        Bad index or runs (named by the library); ProcessingError when no speed range
        of the calibration converges.
    """
    from dronewind.tunnel.analysis import analyse_tunnel

    res = analyse_tunnel(runs_file)
    cal = res["calibration"]
    if len(cal) and not bool(cal["converged"].astype(bool).any()):
        raise ProcessingError(f"{runs_file}: tunnel calibration did not converge in any speed range")
    written = []

    for name in TUNNEL_TABLES:
        table = res.get(name, pd.DataFrame())
        written.append(_csv(table if isinstance(table, pd.DataFrame) else pd.DataFrame(table),
                            Path(tables_dir) / f"tunnel_{name}.csv"))
    LOG.info("%s tunnel: %d calibration ranges, %d sideslip rows, %d gusts, %d steps, %d turbulence runs",
             campaign, len(cal), len(res.get("sideslip", [])), len(res.get("gusts", [])),
             len(res.get("steps", [])), len(res.get("turbulence", [])))
    return written
