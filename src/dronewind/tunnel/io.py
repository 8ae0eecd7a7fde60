"""Files of a wind-tunnel campaign (Kistner et al. (2024)): the run index, the CTA signals and the UAS logs.

Formats in :mod:`dronewind.simulate.tunnel` (measured campaigns write the same):
``tunnel/runs.csv`` lists the runs; each run has a CTA file (``time_s,wind_speed_ms``) and a
UAS attitude log (``time_s,roll_deg,pitch_deg,yaw_deg``) on one clock.

References
----------
.. [1] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, Kistner et al. (2024)
  , Sect. 2.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from dronewind.errors import InputError

__all__ = ["RUN_COLUMNS", "read_tunnel_index", "read_tunnel_run", "preset_speeds", "event_starts"]

#: Columns of ``tunnel/runs.csv``.
RUN_COLUMNS: tuple[str, ...] = (
    "run_id", "kind", "uas", "aos_deg", "v0_ms", "vg_ms", "vdu_ms", "ti_percent", "duration_s",
    "fs_cta_hz", "fs_uas_hz", "steps_ms", "hold_s", "first_event_s", "period_s", "n_events",
    "cta_file", "uas_file",
)


_KINDS = {"calibration", "sideslip", "portability", "gust", "step", "turbulence"}


def read_tunnel_index(path: str | Path) -> pd.DataFrame:
    """Read ``tunnel/runs.csv`` (format in :mod:`dronewind.simulate.tunnel`).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    pandas.DataFrame
        One row per run; attrs ``root`` (folder the file paths are relative to).

    Raises
    ------
    InputError
        Missing file or columns, unknown ``kind``.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "tunnel run index not found")
    df = pd.read_csv(path, dtype={"run_id": str, "uas": str, "steps_ms": str})
    missing = [c for c in RUN_COLUMNS if c not in df.columns]
    if missing:
        raise InputError(path, f"missing column(s) {missing}")
    bad = sorted(set(df["kind"]) - _KINDS)
    if bad:
        line = int(np.flatnonzero(df["kind"].isin(bad))[0]) + 2
        raise InputError(f"{path}:{line}", f"unknown kind {bad[0]!r}; expected one of {sorted(_KINDS)}")
    df.attrs["root"] = str(path.parent.parent)
    return df


def read_tunnel_run(index: pd.DataFrame, run_id: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Read the CTA signal and UAS log of one run.

    Parameters
    ----------
    index : pandas.DataFrame
        From :func:`read_tunnel_index`.
    run_id : str

    Returns
    -------
    cta : pandas.DataFrame
        ``time_s``, ``wind_speed_ms``.
    uas : pandas.DataFrame
        ``time_s``, ``roll_deg``, ``pitch_deg``, ``yaw_deg``.

    Raises
    ------
    InputError
        Unknown run, missing files or columns, non-increasing time.
    """
    root = Path(index.attrs.get("root", "."))
    rows = index.loc[index["run_id"] == run_id]
    if rows.empty:
        raise InputError("tunnel/runs.csv", f"no run {run_id!r}")
    row = rows.iloc[0]
    out = []
    for col, cols in (("cta_file", ("time_s", "wind_speed_ms")),
                      ("uas_file", ("time_s", "roll_deg", "pitch_deg", "yaw_deg"))):
        p = root / str(row[col])
        if not p.is_file():
            raise InputError(p, f"file of run {run_id!r} not found")
        df = pd.read_csv(p)
        missing = [c for c in cols if c not in df.columns]
        if missing:
            raise InputError(p, f"missing column(s) {missing}; expected {','.join(cols)}")
        if np.any(np.diff(df["time_s"].to_numpy()) <= 0):
            raise InputError(p, "time_s must increase strictly")
        out.append(df)
    return out[0], out[1]


def preset_speeds(row: pd.Series) -> list[float]:
    """Preset speeds of a stepped run (``steps_ms``, separated by ``;``) [m s-1]."""
    return [float(s) for s in str(row["steps_ms"]).split(";") if s not in ("", "nan")]


def event_starts(row: pd.Series) -> list[float]:
    """Start times of the gusts or velocity-step repetitions of a run [s]."""
    return [float(row["first_event_s"]) + k * float(row["period_s"]) for k in range(int(row["n_events"]))]
