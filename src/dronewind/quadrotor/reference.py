"""Reader of the tower reference of a quadrotor campaign (``docs/data-contract.md``, "Tower reference").

Tower reference CSV (1 Hz or 1-min means)::

    time_utc,height_m,wind_speed_ms,wind_from_deg

in long form (one row per time and height) or wide form (``time_utc`` plus one
``wind_speed_ms_<h>m`` and one ``wind_from_deg_<h>m`` column per height ``h``). The reader
returns an :class:`xarray.Dataset` on (``time``, ``height``) with CF attributes,
removed-sample counts ``n_*`` and a ``processing_log``; bad input raises
:class:`dronewind.errors.InputError` naming the file, line or variable.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.errors import InputError
from dronewind.quadrotor.io import _corrupt_check, _corrupt_log, _csv_rows

__all__ = [
    "read_tower_reference",
]


_WIDE = re.compile(r"^(wind_speed_ms|wind_from_deg)_(\d+(?:\.\d+)?)m?$")


def _reference_long_form(df: pd.DataFrame, time: np.ndarray, line_no: np.ndarray) -> pd.DataFrame:
    """Long-form reference rows: ``time``, ``height_m``, ``wind_speed_ms``, ``wind_from_deg``, ``line``."""
    return pd.DataFrame({
        "time": time,
        "height_m": _numbers(df["height_m"]),
        "wind_speed_ms": _numbers(df["wind_speed_ms"]),
        "wind_from_deg": _numbers(df["wind_from_deg"]),
        "line": line_no,
    })


def _numbers(s: pd.Series) -> np.ndarray:
    """float64 of text fields (stripped; not a number -> NaN)."""
    return pd.to_numeric(s.astype(str).str.strip(), errors="coerce").to_numpy(dtype=float)


def _reference_wide_to_long(df: pd.DataFrame, time: np.ndarray, line_no: np.ndarray, path: Path) -> pd.DataFrame:
    """Wide-form reference (``wind_speed_ms_<h>m``, ``wind_from_deg_<h>m``) as long-form rows."""
    cols = {c: m for c in df.columns if (m := _WIDE.match(c))}
    heights = sorted({float(m.group(2)) for m in cols.values()})
    if not heights:
        raise InputError(path, "neither long form (time_utc,height_m,wind_speed_ms,"
                               "wind_from_deg) nor wide form (wind_speed_ms_<h>m, "
                               "wind_from_deg_<h>m columns)")
    parts = []
    for h in heights:
        sp = [c for c, m in cols.items() if m.group(1) == "wind_speed_ms" and float(m.group(2)) == h]
        di = [c for c, m in cols.items() if m.group(1) == "wind_from_deg" and float(m.group(2)) == h]
        if not sp:
            raise InputError(path, f"wide form: no wind_speed_ms column for height {h:g} m")
        parts.append(pd.DataFrame({
            "time": time, "height_m": h,
            "wind_speed_ms": _numbers(df[sp[0]]),
            "wind_from_deg": _numbers(df[di[0]]) if di else np.nan,
            "line": line_no,
        }))
    return pd.concat(parts, ignore_index=True)


def _reference_value_problems(long: pd.DataFrame) -> tuple[np.ndarray, list[str]]:
    """Rows with a bad height, speed or direction: their mask and ``"<line>: <what>"`` (a row's first problem)."""
    checks = [
        (~np.isfinite(long["height_m"]) | (long["height_m"] < 0), "height_m must be a number >= 0 (m above ground)"),
        (long["wind_speed_ms"] < 0, "wind_speed_ms must be >= 0"),
        ((long["wind_from_deg"] < 0) | (long["wind_from_deg"] > 360), "wind_from_deg must be within [0, 360]"),
    ]
    wrong = np.zeros(len(long), dtype=bool)
    what = np.full(len(long), "", dtype=object)
    for mask, text in checks:
        m = mask.to_numpy(dtype=bool) & ~wrong
        what[m] = text
        wrong |= m
    lines = long["line"].to_numpy()
    return wrong, [f"{int(lines[i])}: {what[i]}" for i in np.flatnonzero(wrong)]


def _reference_rows(path: Path, max_corrupt_fraction: float = 0.05) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The good long-form rows of a tower reference with their file lines, and counts.

    A line is corrupt when it has another number of fields than the header or a time stamp
    that is not ISO 8601 UTC with a trailing ``Z``; a (time, height) row when its height is
    not a number >= 0, its speed negative or its direction outside [0, 360].

    Returns
    -------
    long : pandas.DataFrame
        ``time``, ``height_m``, ``wind_speed_ms``, ``wind_from_deg``, ``line``.
    counts : dict
        ``form``, ``n_lines``, ``n_corrupt_lines`` (lines and rows), ``_log``.

    Raises
    ------
    InputError
        See :func:`read_tower_reference`.
    """
    header, frame, time, line_no, bad, n_lines = _csv_rows(path, "tower reference not found")
    if {"height_m", "wind_speed_ms", "wind_from_deg"} <= set(header):
        form, long = "long", _reference_long_form(frame, time, line_no)
    else:
        form, long = "wide", _reference_wide_to_long(frame, time, line_no, path)
    wrong, bad_values = _reference_value_problems(long)
    long = long.loc[~wrong]
    bad = sorted(bad + bad_values, key=lambda b: int(b.split(":", 1)[0]))
    _corrupt_check(path, bad, n_lines, max_corrupt_fraction, "another number of fields than the header, a "
                   "time_utc that is not ISO 8601 UTC with a trailing 'Z', or a height, speed or direction out "
                   "of range")
    if long.empty:
        raise InputError(path, "no data rows")
    return long.reset_index(drop=True), {"form": form, "n_lines": n_lines, "n_corrupt_lines": len(bad),
                                         "_log": _corrupt_log(path, bad, n_lines)}


def _reference_grid(long: pd.DataFrame) -> xr.Dataset:
    """Long-form rows on a (time, height) grid with CF attributes."""
    ds = long.drop(columns="line").set_index(["time", "height_m"]).to_xarray()
    ds = ds.rename({"height_m": "height"}).sortby("time").sortby("height")
    ds = ds.assign_coords(height_m=("height", ds["height"].to_numpy().astype(float)))
    ds = ds.drop_vars("height")
    ds["wind_speed_ms"].attrs.update({"units": "m s-1", "standard_name": "wind_speed"})
    ds["wind_from_deg"].attrs.update({"units": "degree",
                                      "standard_name": "wind_from_direction"})
    ds["height_m"].attrs.update({"units": "m", "standard_name": "height",
                                 "long_name": "height above ground"})
    ds["time"].attrs.update({"standard_name": "time", "long_name": "time (UTC)"})
    return ds


def read_tower_reference(path: str | Path, max_corrupt_fraction: float = 0.05) -> xr.Dataset:
    """Read the tower reference CSV (1 Hz or 1-min means; long or wide form).

    Parameters
    ----------
    path : str or Path
        Long form ``time_utc,height_m,wind_speed_ms,wind_from_deg`` (one row per time and
        height), or wide form ``time_utc,wind_speed_ms_<h>m,wind_from_deg_<h>m,...``.
    max_corrupt_fraction : float, optional
        Largest tolerated fraction of corrupt lines (:func:`_reference_rows`) [1].

    Returns
    -------
    xarray.Dataset
        Dimensions ``time`` (UTC, time stamp of each record) and ``height`` (coordinate
        ``height_m`` [m above ground]); variables ``wind_speed_ms`` [m s-1] and
        ``wind_from_deg`` [degree], NaN where a height has no record at a time. attrs
        ``sampling_interval_s`` (median spacing), ``n_lines``, ``n_corrupt_lines`` (removed,
        their lines in the log), ``n_nonfinite``, ``n_duplicates``, ``n_time_conflicts``,
        ``processing_log``.

    Raises
    ------
    InputError
        Missing file/columns, more than ``max_corrupt_fraction`` of the lines corrupt (bad
        times, negative speeds or heights, a direction outside [0, 360]; names the first),
        or no data.
    """
    path = Path(path)
    long, counts = _reference_rows(path, max_corrupt_fraction)
    form = counts["form"]
    log = [f"read: {len(long)} rows from {path.name}"]
    if counts["n_corrupt_lines"]:
        log.append(counts["_log"])
    n_nonfinite = int((~np.isfinite(long["wind_speed_ms"])).sum() + (~np.isfinite(long["wind_from_deg"])).sum())
    exact = long.drop(columns="line").duplicated(keep="first").to_numpy()
    long = long.loc[~exact]
    conflict = long.duplicated(["time", "height_m"], keep=False).to_numpy()
    long = long.loc[~conflict]
    n_dup, n_conflict = int(exact.sum()), int(conflict.sum())
    if n_dup:
        log.append(f"dedupe: {n_dup} duplicated (time, height) rows removed (first kept)")
    if n_conflict:
        log.append(f"dedupe: {n_conflict} rows repeating a (time, height) with other values removed, none trusted")
    if n_nonfinite:
        log.append(f"parse: {n_nonfinite} missing or non-numeric values kept as NaN")
    if long.empty:
        raise InputError(path, "no data rows left after removing conflicting time stamps")
    ds = _reference_grid(long)
    t_ns = ds["time"].to_numpy().astype("int64")
    ds.attrs.update({
        "sampling_interval_s": float(np.median(np.diff(t_ns)) / 1e9) if t_ns.size > 1 else float("nan"),
        "n_nonfinite": n_nonfinite, "n_duplicates": n_dup, "n_time_conflicts": n_conflict, "form": form,
        "n_lines": counts["n_lines"], "n_corrupt_lines": counts["n_corrupt_lines"],
        "source_file": str(path), "processing_log": "\n".join(log),
    })
    return ds
