r"""Tower and mast records in blocks: L1 to per-block L4 and the rows of ``block_stats.csv``.

A tower- or mast-only campaign has no drone to align with, so each sonic's L1 record
(east/north/up, sonic temperature, flagged samples NaN; :func:`dronewind.mast.chain.compute_mast_l1`)
is cut into blocks of ``processing.block_s`` (30 min by default) that start at whole
multiples of ``block_s`` in UTC (00:00, 00:30, ...). Each block goes through the steps of a
flight's mast sensor:

1. coverage: the fraction of the block's ``block_s * fs`` samples that are absent or
   flagged; above ``processing.max_missing_fraction`` the block is unusable and is not
   gap-filled (Ghirardelli et al. (2025), Sect. 3.2: "did not exceed 2 %"); otherwise the flagged samples
   are bridged linearly (:func:`dronewind.core.filtering.gap_fill_linear`, as the flight
   L3 bridges the mast);
2. wind-from direction of the mean (east, north) vector and rotation into streamline
   coordinates: ``processing.rotation`` per block (``double`` by default), or the record's
   planar fit (Wilczak et al. 2001, :func:`dronewind.mast.chain.record_planar_fit`) for
   ``planar_fit``, as :mod:`dronewind.compare.align` does for the mast of a flight;
3. the block's L3-equivalent (one ``sensor`` = ``"mast"``, native sampling rate: with no
   drone there is no common 8 Hz base to decimate to) goes to
   :func:`dronewind.compare.l4.flight_l4` with ``processing.detrending``, ``spectra`` and
   ``quadrant``: the same statistics, spectra, fits, quadrant ratios, uncertainties and
   length scales as a flight's mast sensor (Ghirardelli et al. (2025), Sects. 4.1-4.4).

:func:`block_stats_row` turns a block's L4 into a row of ``tables/block_stats.csv``
(``docs/data-contract.md``, "Outputs that other tools read"). ``usable`` is False, with the reason naming
the criterion and its numbers, when the coverage fails or the L4 velocity or temperature
statistics could not be computed (e.g. too few samples). The flight L4 has no
stationarity test, so neither do the blocks.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.compare.chain import period_time
from dronewind.compare.l4 import flight_l4
from dronewind.core import rotation as rot
from dronewind.core.angles import rad2deg
from dronewind.core.cf import variable
from dronewind.core.filtering import gap_fill_linear
from dronewind.core.timeseries import require_variables, time_ns
from dronewind.errors import InputError, ProcessingError
from dronewind.manifest import default_config

__all__ = [
    "BLOCK_STATS_COLUMNS",
    "Block",
    "BlockCoverage",
    "BlockSettings",
    "block_l3",
    "block_l4",
    "block_stats_row",
    "block_stats_table",
    "iter_blocks",
    "record_blocks",
    "stack_blocks",
    "stacked_block_rows",
    "to_ns",
    "utc_text",
]

#: Columns of ``tables/block_stats.csv``: the contract of ``docs/data-contract.md``, then ``missing_fraction``.
BLOCK_STATS_COLUMNS: tuple[str, ...] = (
    "record", "sensor", "height_m", "start_utc", "end_utc", "U_ms", "wind_from_deg", "sigma_u_ms", "sigma_v_ms",
    "sigma_w_ms", "ustar_ms", "uw_m2s2", "wT_Kms", "L_m", "zeta", "Sw_Su", "usable", "reason", "missing_fraction",
)  # fmt: skip

#: L1 variables a block needs (flagged samples NaN).
_L1_VARS = ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k")

#: block_stats.csv column -> L4 variable, where the names differ.
_L4_NAME = {"ustar_ms": "u_star_ms"}

_NS = 1_000_000_000


@dataclass(frozen=True)
class BlockSettings:
    """Settings of the block analysis (``processing`` keys of the configuration).

    Attributes
    ----------
    block_s : float
        Block length [s] (``processing.block_s``).
    rotation : str
        ``processing.rotation``: ``single``, ``double``, ``triple`` or ``planar_fit``.
    detrending : str
        ``processing.detrending``: ``linear`` or ``block_mean``.
    max_missing_fraction : float
        ``processing.max_missing_fraction`` [1].
    n_segments, overlap, n_bins
        ``processing.spectra``: Welch segments, overlap [1] and logarithmic bins.
    fr_band : tuple of float
        ``processing.quadrant`` ``fr_min``, ``fr_max``: reduced-frequency band of the ratios [1].
    quadrant_min_speed_ms : float
        ``processing.quadrant.min_speed_ms`` [m s-1].
    """

    block_s: float
    rotation: str
    detrending: str
    max_missing_fraction: float
    n_segments: int
    overlap: float
    n_bins: int
    fr_band: tuple[float, float]
    quadrant_min_speed_ms: float

    @classmethod
    def from_processing(cls, processing: Mapping[str, Any] | None = None) -> BlockSettings:
        """Settings from the ``processing`` section; absent keys take the schema's defaults.

        Parameters
        ----------
        processing : mapping, optional
            ``config["processing"]`` (nested ``spectra`` and ``quadrant`` may be partial).

        Returns
        -------
        BlockSettings
        """
        p = dict(default_config()["processing"])
        for key, value in (processing or {}).items():
            p[key] = {**p[key], **value} if isinstance(value, Mapping) and isinstance(p.get(key), dict) else value
        settings = cls(
            block_s=float(p["block_s"]), rotation=str(p["rotation"]), detrending=str(p["detrending"]),
            max_missing_fraction=float(p["max_missing_fraction"]), n_segments=int(p["spectra"]["segments"]),
            overlap=float(p["spectra"]["overlap"]), n_bins=int(p["spectra"]["bins"]),
            fr_band=(float(p["quadrant"]["fr_min"]), float(p["quadrant"]["fr_max"])),
            quadrant_min_speed_ms=float(p["quadrant"]["min_speed_ms"]),
        )
        if not settings.block_s > 0:
            raise InputError("processing.block_s", f"expected a positive block length [s], got {settings.block_s}")
        if settings.rotation not in rot.ROTATION_METHODS:
            raise InputError("processing.rotation", f"expected one of {rot.ROTATION_METHODS}, got "
                             f"{settings.rotation!r}")
        return settings


@dataclass(frozen=True)
class Block:
    """One block of a record: its UTC bounds and its samples.

    Attributes
    ----------
    index : int
        Block number ``floor(t / block_s)`` of the UTC time since 1970.
    start, end : numpy.datetime64
        Bounds [start, end) (datetime64[ns], UTC).
    samples : slice
        Positions of the record's samples inside the bounds.
    """

    index: int
    start: np.datetime64
    end: np.datetime64
    samples: slice


@dataclass(frozen=True)
class BlockCoverage:
    """How much of a block the record covers, and whether that is enough.

    Attributes
    ----------
    n_expected : int
        Samples of a full block, ``round(block_s * fs)``.
    n_present : int
        Samples of the record inside the block (time-grid points, flagged or not).
    n_valid : int
        Samples with finite u, v, w and temperature.
    n_filled : int
        Samples bridged by linear interpolation (0 when the block is not filled).
    missing_fraction : float
        ``1 - n_valid / n_expected`` [1].
    ok : bool
        ``missing_fraction <= max_missing_fraction``.
    reason : str
        Why not ``ok`` (empty when ok).
    """

    n_expected: int
    n_present: int
    n_valid: int
    n_filled: int
    missing_fraction: float
    ok: bool
    reason: str


def to_ns(t: Any) -> int:
    """A UTC time (datetime64 of any unit) as int nanoseconds since 1970 [ns]."""
    return int(np.asarray(t).astype("datetime64[ns]").astype(np.int64))


def utc_text(t: np.datetime64) -> str:
    """ISO 8601 UTC text with a trailing Z (``2023-08-21T14:30:00Z``; milliseconds only when present)."""
    t_ns = to_ns(t)
    text = np.datetime_as_string(np.asarray(t_ns).astype("datetime64[ns]"), unit="s" if t_ns % _NS == 0 else "ms")
    return str(text) + "Z"


def _sampling_rate(l1: xr.Dataset, where: str) -> float:
    fs = l1.attrs.get("sampling_rate_hz")
    if fs is None or not (np.isfinite(float(fs)) and float(fs) > 0):
        raise InputError(f"{where} attribute 'sampling_rate_hz'", f"expected a positive sampling rate [Hz], got {fs!r}")
    return float(fs)


def _height(l1: xr.Dataset, where: str) -> float:
    h = l1.attrs.get("height_m")
    if h is None or not (np.isfinite(float(h)) and float(h) > 0):
        raise InputError(f"{where} attribute 'height_m'", f"expected the sonic's height above ground [m], got {h!r}")
    return float(h)


def iter_blocks(time: np.ndarray, block_s: float) -> Iterator[Block]:
    """The blocks of ``block_s`` aligned to UTC that hold at least one sample, in time order.

    Parameters
    ----------
    time : numpy.ndarray
        Increasing datetime64 time stamps (UTC).
    block_s : float
        Block length [s]; blocks start at whole multiples of ``block_s`` since 1970-01-01T00Z
        (for 1800 s: every hour and half hour).

    Yields
    ------
    Block
    """
    t_ns = np.asarray(time).astype("datetime64[ns]").astype(np.int64)
    if t_ns.size == 0:
        return
    if np.any(np.diff(t_ns) <= 0):
        raise InputError("L1 time", "time stamps must increase strictly to be cut into blocks")
    block_ns = int(round(block_s * _NS))
    index = t_ns // block_ns
    starts = np.flatnonzero(np.r_[True, index[1:] != index[:-1]])
    stops = np.r_[starts[1:], t_ns.size]
    for a, b in zip(starts.tolist(), stops.tolist(), strict=True):
        k = int(index[a])
        yield Block(k, np.datetime64(k * block_ns, "ns"), np.datetime64((k + 1) * block_ns, "ns"), slice(a, b))


def _coverage(values: list[np.ndarray], fs_hz: float, settings: BlockSettings) -> tuple[BlockCoverage, bool]:
    """Coverage of one block (see :class:`BlockCoverage`) and whether it may be gap-filled."""
    n_present = int(values[0].size)
    valid = np.logical_and.reduce([np.isfinite(x) for x in values]) if n_present else np.zeros(0, bool)
    n_valid = int(valid.sum())
    n_expected = max(int(round(settings.block_s * fs_hz)), 1)
    frac = float(min(max(1.0 - n_valid / n_expected, 0.0), 1.0))
    ok = frac <= settings.max_missing_fraction and n_valid >= 2
    reason = "" if ok else (
        f"missing fraction {frac:.4f} > processing.max_missing_fraction {settings.max_missing_fraction:g} "
        f"({n_expected - n_valid} of {n_expected} samples of the {settings.block_s:g} s block absent or flagged)")
    return BlockCoverage(n_expected, n_present, n_valid, n_present - n_valid if ok else 0, frac, ok, reason), ok


def block_l3(l1: xr.Dataset, block: Block, settings: BlockSettings,
             planar_fit: rot.PlanarFit | None = None) -> tuple[xr.Dataset, BlockCoverage]:
    """The L3-equivalent of one block: gap-filled, rotated into streamline coordinates.

    Parameters
    ----------
    l1 : xarray.Dataset
        Mast L1 (``u_east_ms``, ``v_north_ms``, ``w_up_ms`` [m s-1], ``t_sonic_k`` [K] on
        ``time``, NaN where flagged; attrs ``sampling_rate_hz`` [Hz], ``height_m`` [m]).
    block : Block
        From :func:`iter_blocks` over ``l1["time"]``.
    settings : BlockSettings
        Block length, rotation and missing-data limit.
    planar_fit : PlanarFit, optional
        The record's planar fit; required when ``settings.rotation == "planar_fit"``.

    Returns
    -------
    l3 : xarray.Dataset
        Layout of :func:`dronewind.compare.align.align_drone_mast` with one sensor
        (``"mast"``): ``u_ms``, ``v_ms``, ``w_ms`` [m s-1] (streamline, means kept),
        ``theta_v_k`` [K], ``wind_from_deg``, ``height_m`` and the rotation angles; NaN
        throughout when the coverage fails (the L4 statuses then say ``invalid_input``).
    coverage : BlockCoverage

    Raises
    ------
    InputError
        Missing variables or attributes.
    ProcessingError
        ``planar_fit`` requested without a fit.
    """
    require_variables(l1, _L1_VARS, "mast L1")
    fs_hz = _sampling_rate(l1, "mast L1")
    height_m = _height(l1, "mast L1")
    cut = l1.isel(time=block.samples)
    values = [np.asarray(cut[k].values, dtype=float) for k in _L1_VARS]
    coverage, fill = _coverage(values, fs_hz, settings)
    method = settings.rotation
    if method == "planar_fit" and planar_fit is None:
        raise ProcessingError(
            f"rotation 'planar_fit' requested but mast sonic {l1.attrs.get('sensor_id', '?')} has no planar fit: "
            f"{l1.attrs.get('planar_fit_note', 'not computed')} (choose rotation: double, or a record with at least "
            "3 half-hours from several directions)")
    n = values[0].size
    if fill:
        ue, vn, wu, th = (gap_fill_linear(x, 1.0)[0] for x in values)
        u, v, w, angles = rot.rotate(ue, vn, wu, method, planar_fit=planar_fit)
        wind_from = float(rad2deg(np.arctan2(-ue.mean(), -vn.mean())) % 360.0)
    else:
        u = v = w = th = np.full(n, np.nan)
        angles = {"yaw_deg": np.nan, "pitch_deg": np.nan, "roll_deg": np.nan}
        wind_from = np.nan
    dims = ("sensor", "time")
    ds = xr.Dataset(
        {
            "u_ms": variable(dims, u[None, :], "m s-1", "x_wind", long_name="streamwise wind component"),
            "v_ms": variable(dims, v[None, :], "m s-1", "y_wind",
                             long_name="cross-stream wind component (positive to the left)"),
            "w_ms": variable(dims, w[None, :], "m s-1", "upward_air_velocity",
                             long_name="vertical wind component in streamline coordinates"),
            "theta_v_k": variable(dims, th[None, :], "K", "virtual_temperature",
                                  comment="sonic temperature used as (virtual potential) temperature"),
            "wind_from_deg": variable(("sensor",), np.array([wind_from]), "degree", "wind_from_direction",
                                      comment="mean wind direction before rotation"),
            "height_m": variable(("sensor",), np.array([height_m]), "m", "height", positive="up"),
            **{f"rotation_{k}": variable(("sensor",), np.array([float(angles[k])]), "degree",
                                         long_name=f"streamline rotation: {k[:-4]}")
               for k in ("yaw_deg", "pitch_deg", "roll_deg")},
        },
        coords={"sensor": ("sensor", np.array(["mast"])), "time": ("time", cut["time"].values)},
    )
    ds.attrs.update(sampling_rate_hz=fs_hz, rotation_method=method, rotation_method_mast=method,
                    n_samples=int(n), n_gap_filled=int(coverage.n_filled))
    return ds, coverage


def block_l4(l1: xr.Dataset, block: Block, settings: BlockSettings,
             planar_fit: rot.PlanarFit | None = None) -> xr.Dataset:
    """L4 of one block: :func:`block_l3` then :func:`dronewind.compare.l4.flight_l4`.

    Parameters
    ----------
    l1, block, settings, planar_fit
        As :func:`block_l3`.

    Returns
    -------
    xarray.Dataset
        The flight L4 variables of the mast sensor (statistics, spectra, fits, ratios,
        uncertainties, scales, ``status_*``), a period ``time`` with bounds = the block's
        UTC bounds, and attrs ``block_start_utc``, ``block_end_utc``, ``block_s``,
        ``missing_fraction``, ``n_expected_samples``, ``n_valid_samples``, ``n_gap_filled``,
        ``usable`` (1/0) and ``unusable_reason``, ``sensor_id``.
    """
    l3, coverage = block_l3(l1, block, settings, planar_fit)
    out = flight_l4(l3, "mast", n_segments=settings.n_segments, overlap=settings.overlap, n_bins=settings.n_bins,
                    fr_band=settings.fr_band, quadrant_min_speed_ms=settings.quadrant_min_speed_ms,
                    detrending=settings.detrending)
    out = period_time(out, np.array([block.start, block.end], dtype="datetime64[ns]"))
    reasons = [coverage.reason] if not coverage.ok else []
    if coverage.ok:
        for status, what in (("status_statistics", "velocity statistics"),
                             ("status_temperature", "temperature statistics")):
            if int(out[status]) != 0:
                reasons.append(f"{what}: {out[status].attrs['flag_meanings'].split()[int(out[status])]}: "
                               f"{out[status].attrs['reason']}")
    out.attrs.update(
        block_start_utc=utc_text(block.start), block_end_utc=utc_text(block.end), block_s=float(settings.block_s),
        missing_fraction=float(coverage.missing_fraction), n_expected_samples=int(coverage.n_expected),
        n_valid_samples=int(coverage.n_valid), n_gap_filled=int(coverage.n_filled), usable=int(not reasons),
        unusable_reason="; ".join(reasons), sensor_id=str(l1.attrs.get("sensor_id", "")),
        rotation_method=settings.rotation,
    )
    return out


def record_blocks(l1: xr.Dataset, settings: BlockSettings, planar_fit: rot.PlanarFit | None = None,
                  start: np.datetime64 | None = None, stop: np.datetime64 | None = None) -> list[xr.Dataset]:
    """L4 of every block of a record (:func:`block_l4`) that holds at least one sample.

    Parameters
    ----------
    l1 : xarray.Dataset
        Mast L1 (see :func:`block_l3`).
    settings : BlockSettings
        Block settings.
    planar_fit : PlanarFit, optional
        The record's planar fit (``rotation == "planar_fit"``); by default read from the
        L1's planar-fit attributes (:func:`dronewind.mast.chain.record_planar_fit`).
    start, stop : numpy.datetime64, optional
        Only blocks that start in [start, stop).

    Returns
    -------
    list of xarray.Dataset
        One L4 per block, in time order.
    """
    if planar_fit is None and settings.rotation == "planar_fit":
        planar_fit = rot.planar_fit_from_attrs(dict(l1.attrs))
    t = time_ns(l1, "mast L1")
    lo = -(2**62) if start is None else to_ns(start)
    hi = 2**62 if stop is None else to_ns(stop)
    out = []
    for block in iter_blocks(t.astype("datetime64[ns]"), settings.block_s):
        if lo <= to_ns(block.start) < hi:
            out.append(block_l4(l1, block, settings, planar_fit))
    return out


def block_stats_row(l4: xr.Dataset, record: str, sensor: str) -> dict[str, Any]:
    """One row of ``tables/block_stats.csv`` from a block's L4 (:func:`block_l4`).

    Parameters
    ----------
    l4 : xarray.Dataset
        L4 of one block.
    record : str
        Record name (the mast or tower).
    sensor : str
        Sonic id.

    Returns
    -------
    dict
        :data:`BLOCK_STATS_COLUMNS`: ``U_ms`` mean horizontal speed [m s-1] (speed of the
        mean vector after rotation), ``wind_from_deg`` meteorological [degree],
        ``sigma_*_ms`` [m s-1], ``ustar_ms`` [m s-1], ``uw_m2s2`` [m2 s-2], ``wT_Kms``
        kinematic buoyancy flux [K m s-1], ``L_m`` Obukhov length [m] (Ghirardelli et al. (2025), Eq. 9),
        ``zeta`` = z/L [1], ``Sw_Su`` inertial-subrange ratio [1] (Ghirardelli et al. (2025), Sect. 4.1),
        ``usable`` (bool), ``reason``, ``missing_fraction`` [1].
    """
    row: dict[str, Any] = {"record": record, "sensor": sensor, "start_utc": l4.attrs["block_start_utc"],
                           "end_utc": l4.attrs["block_end_utc"]}
    for col in BLOCK_STATS_COLUMNS:
        if col in row or col in ("usable", "reason", "missing_fraction"):
            continue
        name = _L4_NAME.get(col, col)
        row[col] = float(l4[name]) if name in l4 else math.nan
    row["usable"] = bool(int(l4.attrs["usable"]))
    row["reason"] = str(l4.attrs.get("unusable_reason", ""))
    row["missing_fraction"] = float(l4.attrs["missing_fraction"])
    return {col: row[col] for col in BLOCK_STATS_COLUMNS}


def block_stats_table(rows: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """The rows as the ``block_stats.csv`` table, ordered by record, sensor and start.

    Parameters
    ----------
    rows : sequence of mapping
        From :func:`block_stats_row`.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`BLOCK_STATS_COLUMNS`.
    """
    table = pd.DataFrame(list(rows), columns=list(BLOCK_STATS_COLUMNS))
    table["usable"] = table["usable"].astype(bool)
    return table.sort_values(["record", "sensor", "start_utc"], kind="stable").reset_index(drop=True)


#: Per-block attributes of :func:`block_l4` stored as variables of the stacked L4 (name, units, long name).
_BLOCK_ATTR_VARIABLES: tuple[tuple[str, str, str], ...] = (
    ("missing_fraction", "1", "fraction of the block's samples absent or flagged"),
    ("n_expected_samples", "1", "samples of a full block (block length times sampling rate)"),
    ("n_valid_samples", "1", "samples with finite u, v, w and temperature"),
    ("n_gap_filled", "1", "samples bridged by linear interpolation"),
    ("n_samples", "1", "time-grid points of the record inside the block"),
)

#: Attributes equal for every block of a record; kept once, as global attributes of the stack.
_RECORD_ATTRS = ("sampling_rate_hz", "detrending", "spectral_method", "obukhov_temperature", "karman_constant",
                 "gravity_ms2", "spectral_fit_f_max_hz", "rotation_method", "block_s", "sensor_id", "sensor")


def stack_blocks(l4s: Sequence[xr.Dataset]) -> xr.Dataset:
    """The L4 of a record's blocks as one dataset with the blocks along ``time``.

    Every block's L4 (:func:`block_l4`) is a period statistic (``time`` = middle of the
    block, ``time_bnds`` = its UTC bounds). Stacked, they form a CF timeSeries of
    block statistics: scalars become ``(time,)``, spectra ``(time, frequency_bin)``. The
    log-frequency bins of the spectra depend on the block's sample count (a block one sample
    short has bins 0.01 % apart), so the bin centres are kept per block as the auxiliary
    coordinate ``frequency(time, frequency_bin)`` [Hz]; blocks with fewer non-empty bins
    (or none, when unusable) are padded with NaN (``n_estimates`` with 0).

    Parameters
    ----------
    l4s : sequence of xarray.Dataset
        L4 of the blocks (:func:`block_l4`), in time order, all of one sonic.

    Returns
    -------
    xarray.Dataset
        The L4 variables on ``time`` (and ``frequency_bin``); ``time_bnds`` [start, end) of
        each block; ``usable`` (1/0, flag values), ``unusable_reason`` (text),
        ``missing_fraction`` [1] and the sample counts per block; global attributes
        ``detrending``, ``rotation_method``, ``block_s`` [s], ``spectral_method``,
        ``sampling_rate_hz`` [Hz] and the blocks' ``processing_log`` lines prefixed with
        their start.

    Raises
    ------
    InputError
        No block, or blocks processed with different settings (detrending, rotation, block length).
    """
    if not l4s:
        raise InputError("blocks", "no block to stack: the record holds no sample")
    first = l4s[0]
    for ds in l4s[1:]:
        for key in ("detrending", "rotation_method", "block_s", "sensor_id"):
            if ds.attrs.get(key) != first.attrs.get(key):
                raise InputError(f"block {ds.attrs.get('block_start_utc')} attribute {key!r}",
                                 f"expected {first.attrs.get(key)!r} as in the first block, got {ds.attrs.get(key)!r}")
    parts = []
    for ds in l4s:
        n_bins = ds.sizes.get("frequency", 0)
        one = ds.reset_index("frequency").rename_dims(frequency="frequency_bin") if "frequency" in ds.dims else ds
        one = one.assign_coords(frequency_bin=("frequency_bin", np.arange(n_bins, dtype=np.int32)))
        if "frequency" in one.variables:
            one = one.set_coords("frequency")
        extra = {name: xr.DataArray([float(ds.attrs[name])] if name == "missing_fraction" else [int(ds.attrs[name])],
                                    dims=("time",), attrs={"units": units, "long_name": text})
                 for name, units, text in _BLOCK_ATTR_VARIABLES}
        extra["usable"] = xr.DataArray(np.array([int(ds.attrs["usable"])], dtype=np.int8), dims=("time",), attrs={
            "long_name": "block usable for block_stats.csv", "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "unusable usable"})
        extra["unusable_reason"] = xr.DataArray(np.array([str(ds.attrs.get("unusable_reason", ""))], dtype=object),
                                                dims=("time",), attrs={"long_name": "why the block is unusable "
                                                                       "(empty when usable)"})
        parts.append(one.assign(extra))
    fill: dict[Hashable, Any] = {k: np.nan for k in parts[0].data_vars}
    fill["n_estimates"] = 0
    stacked: xr.Dataset = xr.concat(parts, dim="time", data_vars="all", coords="different", compat="equals",
                                    join="outer", fill_value=fill, combine_attrs="drop")
    for name in list(stacked.data_vars):
        if str(name).startswith("status_") or name == "usable":
            stacked[name] = stacked[name].astype(np.int8)
        stacked[name].attrs = dict(parts[0][name].attrs) if name in parts[0] else stacked[name].attrs
    if "frequency" in stacked.coords:
        stacked["frequency"].attrs = dict(first["frequency"].attrs) if "frequency" in first.variables else {}
        stacked["frequency"].attrs["comment"] = ("centre of the logarithmic frequency bin; per block, as the bins "
                                                 "depend on the block's sample count")
    stacked["frequency_bin"].attrs = {"long_name": "index of the non-empty logarithmic frequency bin", "units": "1"}
    stacked["time"].attrs = {"bounds": "time_bnds", "long_name": "middle of the block (UTC)"}
    stacked.attrs = {k: first.attrs[k] for k in _RECORD_ATTRS if k in first.attrs}
    stacked.attrs["n_blocks"] = len(l4s)
    stacked.attrs["n_usable_blocks"] = int(sum(int(ds.attrs["usable"]) for ds in l4s))
    stacked.attrs["processing_log"] = "\n".join(
        f"{ds.attrs['block_start_utc']}: {line}" for ds in l4s
        for line in str(ds.attrs.get("processing_log", "")).split("\n") if line)
    return stacked


def stacked_block_rows(stacked: xr.Dataset, record: str, sensor: str) -> list[dict[str, Any]]:
    """Rows of ``block_stats.csv`` from a record's stacked block L4 (:func:`stack_blocks`).

    Parameters
    ----------
    stacked : xarray.Dataset
        Stacked L4 of one sonic (as written by the workflow and read back).
    record, sensor : str
        Record (mast) and sonic names in the rows.

    Returns
    -------
    list of dict
        One row per block, the columns and units of :func:`block_stats_row`.
    """
    require_variables(stacked, ("time_bnds", "usable", "unusable_reason", "missing_fraction"), "stacked block L4")
    bounds = np.asarray(stacked["time_bnds"].values).astype("datetime64[ns]")
    rows = []
    for i in range(stacked.sizes["time"]):
        row: dict[str, Any] = {"record": record, "sensor": sensor, "start_utc": utc_text(bounds[i, 0]),
                               "end_utc": utc_text(bounds[i, 1])}
        for col in BLOCK_STATS_COLUMNS:
            if col in row or col in ("usable", "reason", "missing_fraction"):
                continue
            name = _L4_NAME.get(col, col)
            row[col] = float(stacked[name].values[i]) if name in stacked else math.nan
        row["usable"] = bool(int(stacked["usable"].values[i]))
        reason = stacked["unusable_reason"].values[i]
        row["reason"] = "" if reason is None or (isinstance(reason, float) and math.isnan(reason)) else str(reason)
        row["missing_fraction"] = float(stacked["missing_fraction"].values[i])
        rows.append({col: row[col] for col in BLOCK_STATS_COLUMNS})
    return rows
