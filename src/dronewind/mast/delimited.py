r"""Mast sonic L1 from generic delimited text: the manifest's column mapping instead of a reader.

A sonic whose files no dedicated reader knows is declared in the manifest with
``format: {name: delimited, ...}`` (README "Input formats"; the mapping is read by
:mod:`dronewind.core.delimited`): the time column and its zone or epoch, each variable's
column, scale, offset and unit, the sensor's axis convention and mount, the range limits.
The result is the mast L1 dataset of :func:`dronewind.mast.level1.mast_l1`: the same variables,
grid, QC bits and attributes, so that the rest of the chain cannot tell the readers apart.

Sensor frame to east/north/up (``axes.convention``), after the mount (``upside_down``:
the sensor hangs head down, :math:`(u, v, w) \to (u, -v, -w)`):

* ``enu``: u east, v north, w up;
* ``csat3``: :func:`dronewind.mast.level1.csat3_to_enu` with ``azimuth_deg`` (``docs/data-contract.md``
  "Frames and signs");
* ``gill``: :func:`dronewind.mast.ameriflux.gill_to_enu` with ``north_azimuth_deg`` (u
  towards the sensor's N spar, v towards its W);
* ``matrix``: :math:`(u_E, v_N, w_U)^T = M\,(u, v, w)^T`.

An azimuth not given in ``axes`` is the sonic's ``azimuth_deg``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.core.cf import variable_attrs
from dronewind.core.constants import ZERO_CELSIUS_K
from dronewind.core.delimited import DelimitedLayout, delimited_layout, read_delimited
from dronewind.core.filtering import INSTRUMENT_LIMITS, despike_moving_mad, range_mask
from dronewind.core.qc import QC_DIAG, QC_GAP_FILLED, QC_MISSING, QC_OUT_OF_RANGE, QC_SPIKE, qc_flag_attrs
from dronewind.errors import InputError
from dronewind.mast.ameriflux import gill_to_enu
from dronewind.mast.level1 import _Grid, _on_grid, _regular_grid, csat3_to_enu
from dronewind.mast.toa5 import UNREADABLE_PREFIX

__all__ = ["sensor_to_enu", "limits_for", "mast_l1_delimited"]

_N_LOGGED = 5


def sensor_to_enu(u_ms: np.ndarray, v_ms: np.ndarray, w_ms: np.ndarray, axes: Mapping[str, Any],
                  mount: str = "upright", azimuth_deg: float | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sensor components to east, north, up by the declared axis convention and mount.

    Parameters
    ----------
    u_ms, v_ms, w_ms : numpy.ndarray
        The sensor's components [m s-1].
    axes : mapping
        ``convention`` (``enu``, ``csat3``, ``gill``, ``matrix``) and its ``azimuth_deg``,
        ``north_azimuth_deg`` [degree] or ``matrix`` (3 rows east, north, up).
    mount : str
        ``upright`` or ``upside_down`` (v and w change sign first).
    azimuth_deg : float, optional
        The sonic's azimuth [degree], used when ``axes`` gives none.

    Returns
    -------
    u_east_ms, v_north_ms, w_up_ms : numpy.ndarray
        [m s-1].

    Raises
    ------
    InputError
        An unknown convention or mount, or no azimuth for csat3/gill.
    """
    u, v, w = (np.asarray(x, dtype=float) for x in (u_ms, v_ms, w_ms))
    if mount == "upside_down":
        v, w = -v, -w
    elif mount != "upright":
        raise InputError("format.mount", f"{mount!r}; expected upright or upside_down")
    conv = str(axes.get("convention"))
    if conv == "enu":
        return u, v, w
    if conv == "matrix":
        m = np.asarray(axes["matrix"], dtype=float)
        return m[0, 0] * u + m[0, 1] * v + m[0, 2] * w, m[1, 0] * u + m[1, 1] * v + m[1, 2] * w, \
            m[2, 0] * u + m[2, 1] * v + m[2, 2] * w
    key = {"csat3": "azimuth_deg", "gill": "north_azimuth_deg"}.get(conv)
    if key is None:
        raise InputError("format.axes.convention", f"{conv!r}; expected enu, csat3, gill or matrix")
    az = axes.get(key, azimuth_deg)
    if az is None:
        raise InputError(f"format.axes.{key}", f"no azimuth for the {conv} convention; expected axes.{key} or the "
                         "sonic's azimuth_deg")
    e, n = csat3_to_enu(u, v, float(az)) if conv == "csat3" else gill_to_enu(u, v, float(az))
    return e, n, w


def limits_for(model: str | None, declared: str | None = None) -> tuple[str, dict[str, Any]]:
    """Range limits of the QC: declared, or from the sonic's model.

    Parameters
    ----------
    model : str or None
        Manifest ``model`` (e.g. ``CSAT3``, ``Gill WindMaster Pro``).
    declared : str, optional
        ``format.limits``: a key of :data:`dronewind.core.filtering.INSTRUMENT_LIMITS`.

    Returns
    -------
    name : str
        The instrument whose limits apply.
    limits : dict
        Its entry of ``INSTRUMENT_LIMITS``.
    """
    if declared:
        return declared, INSTRUMENT_LIMITS[declared]
    text = (model or "").lower().replace(" ", "")
    name = "csat3" if "csat" in text else "rmyoung_81000" if "81000" in text else "gill_windmaster_pro"
    return name, INSTRUMENT_LIMITS[name]


def _read(files: list[Path], layout: DelimitedLayout, max_corrupt_fraction: float, counts: dict[str, int],
          log: list[str]) -> pd.DataFrame:
    """Every file by the mapping, concatenated, exact duplicates and conflicting time stamps dropped."""
    frames = []
    errors: list[InputError] = []
    for k, f in enumerate(files):
        try:
            table = read_delimited(f, layout, max_corrupt_fraction)
        except InputError as exc:  # left out if others can be read (see dronewind.mast.level1._read_files)
            if len(files) == 1:
                raise
            errors.append(exc)
            log.append(f"{UNREADABLE_PREFIX}{exc}")
            continue
        frame = pd.DataFrame({"time": table.time, **table.values, "_file": k, "_line": table.line_no})
        counts["n_lines"] += table.n_lines
        counts["n_corrupt_lines"] += table.n_corrupt
        counts["n_nonnumeric"] += table.n_nonnumeric
        msg = f"read: {f.name}: {len(frame)} rows, {table.n_corrupt} corrupt removed"
        log.append(msg + (f" (corrupt lines {table.corrupt_lines})" if table.n_corrupt else "")
                   + (f"; {table.problem}: the lines before it read" if table.problem else ""))
        counts["n_damaged_streams"] = counts.get("n_damaged_streams", 0) + (table.problem is not None)
        frames.append(frame)
    if not frames:
        raise errors[0]
    counts["n_unreadable_files"] = len(errors)
    data = pd.concat(frames, ignore_index=True)
    value_cols = ["time", *layout.variables]
    exact_dup = data.duplicated(subset=value_cols, keep="first").to_numpy()
    data = data.loc[~exact_dup].sort_values("time", kind="stable")
    conflict = data.duplicated(subset=["time"], keep=False).to_numpy()
    n_conflict = int(conflict.sum())
    if n_conflict > max_corrupt_fraction * len(data):
        first = int(np.flatnonzero(conflict)[0])
        raise InputError(f"{files[int(data['_file'].iloc[first])]}:{int(data['_line'].iloc[first])}",
                         f"{n_conflict} of {len(data)} rows repeat a time stamp with other values; expected one row "
                         "per time stamp")
    counts["n_duplicates"] = int(exact_dup.sum())
    counts["n_time_conflicts"] = n_conflict
    log.append(f"order: {len(files)} files concatenated in time order, {int(exact_dup.sum())} exact duplicate "
               f"rows dropped, {n_conflict} rows with a conflicting time stamp dropped")
    return data.loc[~conflict].reset_index(drop=True)


def _qc(raw: dict[str, np.ndarray], speed: np.ndarray, grid: _Grid, limits: Mapping[str, Any], despike: bool,
        window_s: float, n_mad: float, counts: dict[str, int]) -> np.ndarray:
    """Missing, diagnostic, range and spike flags (bits of :mod:`dronewind.core.qc`)."""
    n = grid.time.size
    present = np.zeros(n, dtype=bool)
    present[grid.index] = True
    t_c = raw["t"] - ZERO_CELSIUS_K
    qc = np.zeros(n, dtype=np.int8)
    missing = ~(np.isfinite(raw["u"]) & np.isfinite(raw["v"]) & np.isfinite(raw["w"]) & np.isfinite(raw["t"]))
    qc[missing] |= QC_MISSING
    diag = raw.get("diag")
    diag_bad = np.isfinite(diag) & (diag != 0) if diag is not None else np.zeros(n, dtype=bool)
    qc[diag_bad] |= QC_DIAG
    out = range_mask(t_c, *limits["t_sonic_c"])
    for key, var in (("ux_ms", "u"), ("uy_ms", "v"), ("uz_ms", "w")):
        if key in limits:
            out |= range_mask(raw[var], *limits[key])
    if "speed_ms" in limits:
        out |= range_mask(speed, *limits["speed_ms"])
    qc[out] |= QC_OUT_OF_RANGE
    spikes = np.zeros(n, dtype=bool)
    if despike:
        for a, b in grid.segments:
            for x in (raw["u"], raw["v"], raw["w"], t_c):
                spikes[a:b] |= despike_moving_mad(np.where(qc[a:b] == 0, x[a:b], np.nan), grid.fs_hz, window_s,
                                                  n_mad)
    qc[spikes] |= QC_SPIKE
    counts.update(n_nan_values=int((missing & present).sum()), n_diag_flagged=int(diag_bad.sum()),
                  n_out_of_range=int(out.sum()), n_spikes=int(spikes.sum()), n_flagged=int((qc != 0).sum()))
    return qc


def _dataset(raw: dict[str, np.ndarray], enu: tuple[np.ndarray, np.ndarray, np.ndarray], qc: np.ndarray,
             time: np.ndarray, convention: str) -> xr.Dataset:
    """The mast L1 variables (as :func:`dronewind.mast.level1.mast_l1`), the sensor components as logged."""
    nanf = np.where(qc != 0, np.nan, 1.0)
    data = {
        "u_east_ms": ("time", enu[0] * nanf, variable_attrs("m s-1", "eastward_wind")),
        "v_north_ms": ("time", enu[1] * nanf, variable_attrs("m s-1", "northward_wind")),
        "w_up_ms": ("time", enu[2] * nanf, variable_attrs("m s-1", "upward_air_velocity")),
        "t_sonic_k": ("time", raw["t"] * nanf, variable_attrs(
            "K", "virtual_temperature", comment="sonic temperature (approximately the virtual temperature)",
            units_metadata="temperature: on_scale")),
        "u_sensor_ms": ("time", raw["u"], variable_attrs("m s-1", long_name=f"sensor u as logged ({convention} axes)")),
        "v_sensor_ms": ("time", raw["v"], variable_attrs("m s-1", long_name=f"sensor v as logged ({convention} axes)")),
        "w_sensor_ms": ("time", raw["w"], variable_attrs("m s-1", long_name=f"sensor w as logged ({convention} axes)")),
        "qc_mast": ("time", qc, qc_flag_attrs(
            "mast sonic QC bitmask", (QC_OUT_OF_RANGE, QC_SPIKE, QC_MISSING, QC_GAP_FILLED, QC_DIAG))),
    }
    if "diag" in raw:
        diag_i = np.where(np.isfinite(raw["diag"]), raw["diag"], -1).astype(np.int32)
        data["diag"] = ("time", diag_i, variable_attrs("1", long_name="diagnostic word as logged (-1: not available)"))
    return xr.Dataset(data, coords={"time": ("time", time, {"long_name": "time (UTC)"})})


def mast_l1_delimited(
    paths: Sequence[str | os.PathLike[str]], spec: Mapping[str, Any], sonic: Mapping[str, Any],
    despike_window_s: float = 10.0, despike_n_mad: float = 7.0, despike: bool = True,
    max_corrupt_fraction: float = 0.05, max_gap_s: float = 60.0, where: str = "format",
) -> xr.Dataset:
    """Build the mast L1 dataset from delimited-text files and their manifest mapping.

    Parameters
    ----------
    paths : sequence of path
        The sonic's files (concatenated in time order).
    spec : mapping
        The manifest's ``format`` mapping (``name: delimited``; see the module docstring).
    sonic : mapping
        Manifest entry of the sonic: ``id``, ``height_m`` [m], ``azimuth_deg`` [degree],
        optional ``model``.
    despike_window_s, despike_n_mad : float
        Moving-MAD despiking window [s] and threshold [scaled MAD].
    despike : bool
        Apply the despiking (QC 2).
    max_corrupt_fraction : float
        Largest tolerated fraction of corrupt rows per file [1].
    max_gap_s : float
        Longer gaps are breaks of the time axis (as :func:`dronewind.mast.level1.mast_l1`) [s].
    where : str
        Key path of the mapping in the manifest (for messages).

    Returns
    -------
    xarray.Dataset
        dim ``time`` (UTC, regular grid per segment); ``u_east_ms``, ``v_north_ms``,
        ``w_up_ms``, ``t_sonic_k`` (NaN where ``qc_mast`` != 0), ``u_sensor_ms``,
        ``v_sensor_ms``, ``w_sensor_ms`` (SI, as logged), ``diag`` (if mapped), ``qc_mast``;
        attrs ``azimuth_deg``, ``height_m``, ``sensor_id``, ``sampling_rate_hz``, ``n_*``
        counts, ``input_format``, ``axis_convention``, ``mount``, ``processing_log``.

    Raises
    ------
    InputError
        A file that does not match its mapping (file and line named), too few rows, a
        sampling interval that is not constant.
    """
    files = [Path(p) for p in paths]
    if not files:
        raise InputError(where, "no file given")
    layout = delimited_layout(spec, where)
    axes = dict(spec.get("axes") or {"convention": "enu"})
    mount = str(spec.get("mount", "upright"))
    limits_name, limits = limits_for(sonic.get("model"), spec.get("limits"))
    log: list[str] = []
    counts = {"n_lines": 0, "n_corrupt_lines": 0, "n_nonnumeric": 0}
    data, grid = _regular_grid(_read(files, layout, max_corrupt_fraction, counts, log), files, max_gap_s, counts)
    raw = {var: _on_grid(data, grid, var) for var in layout.variables}
    enu = sensor_to_enu(raw["u"], raw["v"], raw["w"], axes, mount, float(sonic["azimuth_deg"]))
    speed = np.sqrt(raw["u"] ** 2 + raw["v"] ** 2 + raw["w"] ** 2)
    qc = _qc(raw, speed, grid, limits, despike, despike_window_s, despike_n_mad, counts)
    log.append(f"grid: {grid.fs_hz:g} Hz, {counts['n_missing']} absent time stamps inserted as missing; "
               f"{counts['n_record_breaks']} record breaks (gaps > {max_gap_s:g} s kept as breaks, not filled)")
    log.append(f"frame: {axes.get('convention')} axes, mount {mount}; qc: {counts['n_nan_values']} NaN samples, "
               f"{counts['n_diag_flagged']} non-zero diagnostic, {counts['n_out_of_range']} out of {limits_name} "
               f"range, {counts['n_spikes']} spikes (moving MAD {despike_window_s:g} s, {despike_n_mad:g} scaled MAD"
               f"{'' if despike else ', off'}); {counts['n_flagged']} of {grid.time.size} samples set to NaN")
    ds = _dataset(raw, enu, qc, grid.time, str(axes.get("convention")))
    ds.attrs.update({k: int(v) for k, v in counts.items()})
    ds.attrs.update(azimuth_deg=float(sonic["azimuth_deg"]), height_m=float(sonic["height_m"]),
                    sensor_id=str(sonic["id"]), sampling_rate_hz=float(round(grid.fs_hz, 6)),
                    source_files=", ".join(f.name for f in files), input_format="delimited",
                    axis_convention=str(axes.get("convention")), mount=mount, processing_log="\n".join(log))
    return ds
