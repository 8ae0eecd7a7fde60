"""The block series of tower- and mast-only campaigns, drawn from ``tables/block_stats.csv``.

Nothing is computed here: every plotted number is a column of the stored table
(:func:`dronewind.steps.blocks.block_stats`), one point per block at the middle of its
[start, end) interval. Unusable blocks are not drawn; how many there are, and why, is
listed below the axes.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

from dronewind.figures.labels import BLOCK_FIGURE
from dronewind.figures.style import UNIT_KMS, UNIT_MS, PathLike, add_notes, new_figure, no_data, save_figure

__all__ = ["BLOCK_FIGURE", "BLOCK_PANELS", "block_series"]

#: Panels: block_stats.csv column and axis label.
BLOCK_PANELS: tuple[tuple[str, str], ...] = (
    ("U_ms", f"U [{UNIT_MS}]"),
    ("wind_from_deg", "wind from [°]"),
    ("sigma_w_ms", f"σ$_w$ [{UNIT_MS}]"),
    ("ustar_ms", f"u$_*$ [{UNIT_MS}]"),
    ("wT_Kms", f"w'T' [{UNIT_KMS}]"),
    ("zeta", "z/L [1]"),
    ("Sw_Su", "S$_w$/S$_u$ [1]"),
)


def _reason_kind(reason: str) -> str:
    """The criterion of an unusable block (its reason up to the first number)."""
    text = str(reason).split(":")[0].strip()
    for word in ("missing fraction", "velocity statistics", "temperature statistics"):
        if text.startswith(word):
            return word
    return text or "unstated"


def block_series(table_csv: PathLike, out_stem: PathLike) -> list[Path]:
    """Figure of the block statistics over time, one colour per record and sensor.

    Parameters
    ----------
    table_csv : str or Path
        ``tables/block_stats.csv``.
    out_stem : str or Path
        Output path without suffix (``.png`` and ``.pdf`` are written).

    Returns
    -------
    list of Path
        The PNG and the PDF.
    """
    table = pd.read_csv(table_csv, keep_default_na=True)
    start, end = pd.to_datetime(table["start_utc"]), pd.to_datetime(table["end_utc"])
    mid = start + (end - start) / 2
    table = table.assign(mid=mid.dt.tz_localize(None) if mid.dt.tz is not None else mid)
    usable = table["usable"].astype(str).str.lower().isin(("true", "1"))
    # records apart by more than a day (e.g. two campaign days months apart) get a column each
    times = np.sort(table["mid"].to_numpy())
    cuts = np.flatnonzero(np.diff(times) > np.timedelta64(1, "D")) if times.size else np.array([], int)
    spans = [(times[a], times[b - 1]) for a, b in zip(np.r_[0, cuts + 1], np.r_[cuts + 1, times.size], strict=True)]
    spans = spans if 1 <= len(spans) <= 4 else [(times[0], times[-1])] if times.size else [(None, None)]
    fig = new_figure(4.5 + 3.5 * len(spans), 11.0)
    grid = np.asarray(fig.subplots(len(BLOCK_PANELS), len(spans), sharex="col", sharey="row", squeeze=False))
    notes = []
    groups = list(table.groupby(["record", "sensor"], sort=True))
    gap = np.timedelta64(int(1.5 * 1e9 * max(float((pd.to_datetime(table["end_utc"]) - pd.to_datetime(
        table["start_utc"])).dt.total_seconds().min()), 1.0)), "ns") if len(table) else np.timedelta64(0, "ns")
    for row, (col, label) in zip(grid, BLOCK_PANELS, strict=True):
        drawn = 0
        for (record, sensor), part in groups:
            ok = part[usable.loc[part.index]]
            x, y = ok["mid"].to_numpy(), ok[col].to_numpy(dtype=float)
            keep = np.isfinite(y)
            x, y = x[keep], y[keep]
            # lines are broken where blocks are missing (no line across a gap)
            brk = np.flatnonzero(np.diff(x) > gap) + 1
            xs = np.insert(x, brk, x[brk - 1] + gap / 2) if brk.size else x
            ys = np.insert(y, brk, np.nan) if brk.size else y
            height = float(part["height_m"].iloc[0])
            for ax in row:
                ax.plot(xs, ys, marker="o", ms=3, lw=0.8, label=f"{record} {sensor} ({height:g} m)")
            drawn += int(keep.sum())
            missing = int((~keep).sum())
            if missing:
                notes.append(f"{col}: {missing} usable block(s) of {record} {sensor} without a value (stored NaN: "
                             "see the L4 status flags)")
        for ax, (t0, t1) in zip(row, spans, strict=True):
            if t0 is not None:
                pad = max((t1 - t0) * 0.03, np.timedelta64(30, "m"))
                ax.set_xlim(t0 - pad, t1 + pad)
            if col == "wind_from_deg":
                ax.set_ylim(0, 360)
                ax.set_yticks([0, 90, 180, 270, 360])
            if col in ("wT_Kms", "zeta"):
                ax.axhline(0.0, color="0.5", lw=0.6)
        row[0].set_ylabel(label)
        if not drawn:
            no_data(row[0], f"no usable block with {col}")
    axes = grid[:, 0]
    if groups and any(ax.get_legend_handles_labels()[0] for ax in axes):
        axes[0].legend(loc="lower left", bbox_to_anchor=(0.0, 1.02), ncol=2, fontsize=8, frameon=False)
    for ax in grid[-1]:
        for tick in ax.get_xticklabels():
            tick.set_rotation(30)
            tick.set_ha("right")
    fig.supxlabel("time (UTC), middle of the block", fontsize=9)
    bad = table[~usable]
    for (record, sensor), part in bad.groupby(["record", "sensor"], sort=True):
        kinds = Counter(_reason_kind(r) for r in part["reason"].fillna(""))
        notes.append(f"{record} {sensor}: {len(part)} unusable block(s) not drawn ("
                     + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())) + ")")
    notes = add_notes(fig, notes)
    return save_figure(fig, out_stem, notes)
