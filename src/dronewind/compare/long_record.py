r"""Long mast/tower records in bounded memory: TOA5 files -> L1 per file -> block L4 -> ``block_stats.csv``.

Loggers write one TOA5 file per day; a month at 20 Hz is 52 million rows (about 3 GB of
text). :func:`process_long_record` never holds the record: it runs one task per file and
one per file's blocks with :mod:`dask` (``dask.delayed``, threaded scheduler, ``n_workers``
at a time), so the peak memory is that of ``n_workers`` files, whatever the length.

1. **Scan** (:func:`scan_files`): the first and last rows of each file give its time span
   and sampling rate; files are ordered by their first time stamp.
2. **L1 per file** (:func:`file_l1`): :func:`dronewind.mast.level1.mast_l1` on the file with
   *context*: the last rows of the previous file and the first rows of the next one,
   copied byte for byte into small TOA5 files. The result is cut to the file's
   *partition*: from its first time stamp to the next file's first time stamp. The L1 of
   each file is written atomically as CF NetCDF (:func:`dronewind.core.cf.write_netcdf`).
   Each task also returns the 30-min sums for the record's planar fit
   (:func:`dronewind.core.rotation.block_sums`), merged exactly over files.
3. **Blocks per file** (:func:`file_blocks`): the blocks that start in a file's partition
   (:mod:`dronewind.compare.blocks`), reading the L1 files they cover; rows of
   ``block_stats.csv``, written atomically at the end.

Why the L1 of the pieces equals the L1 of the concatenated record
---------------------------------------------------------------
Every L1 step is pointwise (NAN and diagnostic flags, CSAT3 range limits, the sensor-to-
east/north/up rotation, the regular time grid of logger time stamps) except the moving-MAD
despiking (:func:`dronewind.core.filtering.despike_moving_mad`). Its flag at sample i is a
median over [i - h, i + h] of deviations from medians over windows of the same half-width
h = round(window_s fs / 2), so it depends only on samples i - 2h ... i + 2h. With at least
2h rows of each neighbour as context, every sample of the partition sees exactly the
samples it sees in the concatenated record (a window that reaches a record break or the
record's ends is shortened in both alike). Context = ``2 * (2h + 1)`` rows, twice the
reach, so that duplicated rows at a file boundary cannot shorten it. Conditions: time
stamps on the logger's sampling grid (Campbell TOA5 are), and files that overlap in time
by less than the context (checked; an :class:`~dronewind.errors.InputError` otherwise).
Tested in ``tests/compare/test_long_record.py``: the L1 of the pieces is identical to the L1 of
the concatenated files, and without context it is not.

The per-file counts of the L1 (``n_spikes``, ``n_missing``, ...) describe that file's
partition plus context reading; the samples and flags are the record's.
"""

from __future__ import annotations

import logging
import math
import tempfile
import threading
from collections.abc import Mapping, Sequence
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import dask
import numpy as np
import xarray as xr

from dronewind.compare.blocks import (
    Block,
    BlockSettings,
    block_l4,
    block_stats_row,
    block_stats_table,
    iter_blocks,
    to_ns,
)
from dronewind.core import rotation as rot
from dronewind.core.cf import atomic_write_text, write_netcdf
from dronewind.core.progress import Progress
from dronewind.errors import DronewindError, InputError
from dronewind.manifest import default_config
from dronewind.mast import level1, toa5

__all__ = ["RecordFile", "FileL1", "LongRecordResult", "context_rows", "scan_files", "file_l1", "file_blocks",
           "process_long_record"]

LOG = logging.getLogger("dronewind")

_NS = 1_000_000_000
_READ_CHUNK = 1 << 16
#: Rows read at the head of each file to find its first time and sampling rate.
_SCAN_ROWS = 64
#: Planar fit block length [s] (as :func:`dronewind.mast.chain.record_planar_fit`).
_PLANAR_FIT_BLOCK_S = 1800.0
#: NetCDF/HDF5 calls from two threads at once crash the process (a bus error was seen with the
#: netCDF4 library when one task wrote an L1 file while another read one): every NetCDF read
#: and write of the driver holds this lock; parsing, despiking and the block statistics run
#: in parallel.
_NETCDF_LOCK = threading.Lock()


@dataclass(frozen=True)
class RecordFile:
    """One TOA5 file of a long record.

    Attributes
    ----------
    path : Path
        The file.
    first_time, last_time : numpy.datetime64
        Earliest time stamp of its first rows and latest of its last rows (UTC, ns).
    fs_hz : float
        Sampling rate from its first rows [Hz].
    """

    path: Path
    first_time: np.datetime64
    last_time: np.datetime64
    fs_hz: float


@dataclass(frozen=True)
class FileL1:
    """What the L1 task of one file hands on (the data stay in its NetCDF file).

    Attributes
    ----------
    path : Path
        The L1 NetCDF file.
    n_samples : int
        Samples of the partition.
    first_time, last_time : numpy.datetime64
        Time span of the partition's samples.
    sums : BlockSums
        30-min sums for the record's planar fit.
    fs_hz : float
        Sampling rate [Hz].
    attrs : dict
        Counts of the L1 (``n_spikes``, ``n_missing``, ...).
    """

    path: Path
    n_samples: int
    first_time: np.datetime64
    last_time: np.datetime64
    sums: rot.BlockSums
    fs_hz: float
    attrs: dict[str, Any] = field(default_factory=dict)


@dataclass
class LongRecordResult:
    """Outputs and numbers of :func:`process_long_record`.

    Attributes
    ----------
    l1_files : list of Path
        L1 NetCDF per input file, in time order.
    table : Path
        ``block_stats.csv``.
    n_samples : int
        Samples of the whole record (time-grid points).
    n_blocks, n_usable : int
        Blocks analysed and usable.
    planar_fit : dict
        The record's planar fit (:func:`dronewind.core.rotation.planar_fit_attrs`).
    """

    l1_files: list[Path]
    table: Path
    n_samples: int
    n_blocks: int
    n_usable: int
    planar_fit: dict[str, Any]


# ----------------------------------------------------------------------------- edges of files


def _head_lines(path: Path, n_rows: int) -> tuple[bytes, list[bytes]]:
    """The 4 header lines (as bytes) and the first ``n_rows`` data lines of a TOA5 file."""
    with path.open("rb") as fh:
        header = b"".join(fh.readline() for _ in range(4))
        rows = []
        for _ in range(n_rows):
            line = fh.readline()
            if not line:
                break
            rows.append(line)
    return header, rows


def _tail_lines(path: Path, n_rows: int) -> list[bytes]:
    """The last ``n_rows`` data lines of a TOA5 file (never a header line), read from the end."""
    size = path.stat().st_size
    with path.open("rb") as fh:
        pos, data = size, b""
        while pos > 0 and data.count(b"\n") <= n_rows + 1:
            step = min(_READ_CHUNK, pos)
            pos -= step
            fh.seek(pos)
            data = fh.read(step) + data
    lines = data.splitlines(keepends=True)
    if pos == 0:
        lines = lines[4:]  # the whole file was read: drop its header
    else:
        lines = lines[1:]  # the first line may be cut
    return lines[-n_rows:] if n_rows > 0 else []


def _write_piece(folder: Path, name: str, header: bytes, rows: list[bytes]) -> Path:
    """A small TOA5 file: the source's header and some of its rows, byte for byte."""
    path = folder / name
    body = b"".join(rows)
    if body and not body.endswith(b"\n"):
        body += b"\n"
    path.write_bytes(header + body)
    return path


def _times_of_rows(path: Path, header: bytes, rows: list[bytes], folder: Path, name: str) -> np.ndarray:
    """Time stamps of some rows of ``path``, parsed by :func:`dronewind.mast.toa5.read_toa5` itself."""
    piece = _write_piece(folder, name, header, rows)
    try:
        frame, _ = toa5.read_toa5(piece, max_corrupt_fraction=0.5)
    except InputError as exc:
        raise InputError(path, f"its {'first' if 'head' in name else 'last'} {len(rows)} rows: {exc}") from exc
    return frame["time"].to_numpy().astype("datetime64[ns]")


def scan_files(files: Sequence[str | Path]) -> list[RecordFile]:
    """Time span and sampling rate of every file from its first and last rows; in time order.

    Parameters
    ----------
    files : sequence of path
        TOA5 files of one sonic.

    Returns
    -------
    list of RecordFile
        Ordered by first time stamp.

    Raises
    ------
    InputError
        A missing file, or one whose first rows give no sampling rate.
    """
    out = []
    with tempfile.TemporaryDirectory(prefix="dronewind_scan_") as tmp:
        for f in files:
            path = Path(f)
            if not path.is_file():
                raise InputError(path, "file not found")
            header, head = _head_lines(path, _SCAN_ROWS)
            t_head = _times_of_rows(path, header, head, Path(tmp), "head.dat")
            t_tail = _times_of_rows(path, header, _tail_lines(path, _SCAN_ROWS), Path(tmp), "tail.dat")
            steps = np.diff(np.sort(t_head)).astype(np.int64)
            steps = steps[steps > 0]
            if steps.size == 0:
                raise InputError(path, f"the first {len(head)} rows give no sampling interval; expected a "
                                 "TOA5 file of a 10 or 20 Hz sonic")
            out.append(RecordFile(path, t_head.min(), max(t_tail.max(), t_head.max()),
                                  float(_NS / np.median(steps))))
    return sorted(out, key=lambda r: (r.first_time, str(r.path)))


def context_rows(fs_hz: float, despike_window_s: float) -> int:
    """Rows of each neighbour file read as context: twice the despiking reach 2h + 1.

    Parameters
    ----------
    fs_hz : float
        Sampling rate [Hz].
    despike_window_s : float
        Moving-MAD window [s] (``processing.despike.window_s``).

    Returns
    -------
    int
        ``2 * (2 h + 1)`` with ``h = max(1, round(window_s fs / 2))`` (the half-window of
        :func:`dronewind.core.filtering.despike_moving_mad`).
    """
    half = max(1, int(round(despike_window_s * fs_hz / 2.0)))
    return 2 * (2 * half + 1)


def _check_overlaps(scanned: list[RecordFile], n_context: list[int]) -> None:
    """Files may overlap in time by less than the context (else the partitions would lose rows)."""
    for k in range(len(scanned) - 1):
        a, b = scanned[k], scanned[k + 1]
        overlap_s = float((a.last_time - b.first_time) / np.timedelta64(1, "s"))
        limit_s = 0.5 * n_context[k] / a.fs_hz
        if overlap_s > limit_s:
            raise InputError(b.path, f"starts {overlap_s:.1f} s before the end of {a.path.name}; files of one "
                             f"record may overlap by at most {limit_s:.1f} s (half the {n_context[k]}-row context); "
                             "merge or remove the repeated file")


# ------------------------------------------------------------------------------------- tasks


def _l1_output(out_dir: Path, record: str, sensor: str, path: Path) -> Path:
    return out_dir / "netcdf" / "L1" / f"{record}_{sensor}_{path.stem}.nc"


def file_l1(scanned: list[RecordFile], k: int, sonic: Mapping[str, Any], despike: Mapping[str, Any],
            out_dir: Path, record: str, progress: Progress | None = None) -> FileL1:
    """L1 of file ``k`` with the neighbours' context, cut to its partition, written as NetCDF.

    Parameters
    ----------
    scanned : list of RecordFile
        All files of the record (:func:`scan_files`).
    k : int
        Index of the file.
    sonic : mapping
        ``id``, ``height_m`` [m], ``azimuth_deg`` [degree] (manifest entry of the sonic).
    despike : mapping
        ``processing.despike``: ``window_s`` [s], ``n_mad``.
    out_dir : Path
        Results folder of the campaign (the L1 goes to ``netcdf/L1/``).
    record : str
        Record name (in file names and attributes).
    progress : Progress, optional
        Counts the file.

    Returns
    -------
    FileL1
    """
    me = scanned[k]
    window_s = float(despike["window_s"])
    counted = progress.item(me.path.name) if progress is not None else nullcontext()
    with counted, tempfile.TemporaryDirectory(prefix="dronewind_ctx_") as tmp:
        sources: list[Path] = []
        note = []
        if k > 0:
            prev = scanned[k - 1]
            n = context_rows(prev.fs_hz, window_s)
            sources.append(_write_piece(Path(tmp), f"{prev.path.stem}.last{n}.dat", _head_lines(prev.path, 0)[0],
                                        _tail_lines(prev.path, n)))
            note.append(f"last {n} rows of {prev.path.name}")
        sources.append(me.path)
        if k + 1 < len(scanned):
            nxt = scanned[k + 1]
            n = context_rows(nxt.fs_hz, window_s)
            head, rows = _head_lines(nxt.path, n)
            sources.append(_write_piece(Path(tmp), f"{nxt.path.stem}.first{n}.dat", head, rows))
            note.append(f"first {n} rows of {nxt.path.name}")
        ds = level1.mast_l1(sources, azimuth_deg=float(sonic["azimuth_deg"]), height_m=float(sonic["height_m"]),
                          sensor_id=str(sonic["id"]), despike_window_s=window_s,
                          despike_n_mad=float(despike["n_mad"]))
    t = ds["time"].values
    lo = 0 if k == 0 else int(np.searchsorted(t, me.first_time, side="left"))
    hi = t.size if k + 1 == len(scanned) else int(np.searchsorted(t, scanned[k + 1].first_time, side="left"))
    part = ds.isel(time=slice(lo, hi))
    del ds
    part.attrs["source_files"] = me.path.name
    part.attrs["processing_log"] = (str(part.attrs.get("processing_log", "")) + "\nlong record: context "
                                    + (", ".join(note) or "none") + " read for the despiking window; cut to "
                                    f"{part.sizes['time']} samples from this file's first time stamp to the next "
                                    "file's").strip()
    part.attrs["record"] = record
    with _NETCDF_LOCK:
        out = write_netcdf(
            part, _l1_output(out_dir, record, str(sonic["id"]), me.path),
            title=f"{record} sonic {sonic['id']}, L1 ({me.path.name})",
            summary=(f"Sonic at {float(sonic['height_m']):g} m, rotated from the sensor frame to east/north/up; range, "
                     "spike and diagnostic flags; one logger file of a long record."),
            processing_level="L1: UTC time, east/north/up, QC flags", history=f"long_record L1 {me.path.name}",
            inputs=[me.path], config={"processing": {"despike": dict(despike)}}, feature_type="timeSeries",
            station_id=str(sonic["id"]), height_m=float(sonic["height_m"]), nonstandard_group="sensor_frame",
        )
    tp = part["time"].values
    sums = rot.block_sums(tp, part["u_east_ms"].values, part["v_north_ms"].values, part["w_up_ms"].values,
                          _PLANAR_FIT_BLOCK_S)
    counts = {key: v for key, v in part.attrs.items() if key.startswith("n_")}
    return FileL1(out, int(tp.size), tp[0] if tp.size else me.first_time, tp[-1] if tp.size else me.first_time,
                  sums, float(part.attrs["sampling_rate_hz"]), counts)


def _file_l1_in_slot(slots: threading.BoundedSemaphore, *args: Any) -> FileL1:
    """:func:`file_l1` once one of the ``l1_at_once`` slots is free."""
    with slots:
        return file_l1(*args)


def record_planar_fit_of(parts: Sequence[FileL1]) -> dict[str, Any]:
    """The record's planar fit from the files' 30-min sums (as :func:`dronewind.mast.chain.record_planar_fit`).

    Parameters
    ----------
    parts : sequence of FileL1
        All files of the record.

    Returns
    -------
    dict
        :func:`dronewind.core.rotation.planar_fit_attrs` of the fit, or the reason there is none.
    """
    sums = rot.merge_block_sums([p.sums for p in parts])
    fs = parts[0].fs_hz if parts else math.nan
    u, v, w = rot.means_of_block_sums(sums, fs, _PLANAR_FIT_BLOCK_S)
    try:
        fit, note = rot.planar_fit_tilt(u, v, w), ""
    except DronewindError as exc:
        fit, note = None, f"no planar fit: {exc}"
    return rot.planar_fit_attrs(fit, note)


class _L1Files:
    """The L1 NetCDF files a block task reads, opened lazily: one block's samples are read at a time."""

    _VARS = ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k")

    def __init__(self, paths: Sequence[Path]) -> None:
        with _NETCDF_LOCK:
            self.handles = [xr.open_dataset(p, engine="netcdf4") for p in paths]
            times = [np.asarray(h["time"].values).astype("datetime64[ns]") for h in self.handles]
            self.attrs = {k: self.handles[0].attrs[k] for k in ("sampling_rate_hz", "height_m", "sensor_id")
                          if k in self.handles[0].attrs}
        self.time = np.concatenate(times)
        self.bounds = np.cumsum([0] + [t.size for t in times])

    def block(self, samples: slice) -> xr.Dataset:
        """The L1 variables of the samples ``samples`` of the concatenated files (read now)."""
        a, b = int(samples.start), int(samples.stop)
        cols: dict[str, list[np.ndarray]] = {k: [] for k in self._VARS}
        with _NETCDF_LOCK:
            for j, h in enumerate(self.handles):
                lo, hi = max(a, int(self.bounds[j])), min(b, int(self.bounds[j + 1]))
                if lo < hi:
                    cut = h[list(self._VARS)].isel(time=slice(lo - int(self.bounds[j]), hi - int(self.bounds[j])))
                    for k in self._VARS:
                        cols[k].append(np.asarray(cut[k].values, dtype=float))
        return xr.Dataset({k: ("time", np.concatenate(v)) for k, v in cols.items()},
                          coords={"time": self.time[a:b]}, attrs=dict(self.attrs))

    def close(self) -> None:
        with _NETCDF_LOCK:
            for h in self.handles:
                h.close()


def file_blocks(parts: Sequence[FileL1], k: int, first_times: Sequence[np.datetime64], settings: BlockSettings,
                record: str, sensor: str, planar_fit: Mapping[str, Any] | None = None,
                progress: Progress | None = None) -> list[dict[str, Any]]:
    """``block_stats.csv`` rows of the blocks that start in file ``k``'s partition.

    Parameters
    ----------
    parts : sequence of FileL1
        L1 of file ``k`` and of the later files its last block can reach (see
        :func:`process_long_record`), in time order; ``parts[0]`` is file ``k``.
    k : int
        Index of the file.
    first_times : sequence of numpy.datetime64
        First time stamp of every file (the partition bounds).
    settings : BlockSettings
        Block settings.
    record, sensor : str
        Names in the rows.
    planar_fit : mapping, optional
        The record's planar-fit attributes (``rotation == "planar_fit"``).
    progress : Progress, optional
        Counts the file.

    Returns
    -------
    list of dict
        Rows (:func:`dronewind.compare.blocks.block_stats_row`).
    """
    start = None if k == 0 else to_ns(first_times[k])
    stop = None if k + 1 == len(first_times) else to_ns(first_times[k + 1])
    fit = rot.planar_fit_from_attrs(dict(planar_fit)) if planar_fit else None
    rows = []
    with progress.item(parts[0].path.name) if progress is not None else nullcontext():
        files = _L1Files([p.path for p in parts])
        try:
            for block in iter_blocks(files.time, settings.block_s):
                t0 = to_ns(block.start)
                if (start is not None and t0 < start) or (stop is not None and t0 >= stop):
                    continue
                one = Block(block.index, block.start, block.end, slice(0, block.samples.stop - block.samples.start))
                l4 = block_l4(files.block(block.samples), one, settings, fit)
                rows.append(block_stats_row(l4, record, sensor))
        finally:
            files.close()
    return rows


def _reach(scanned: list[RecordFile], k: int, block_s: float) -> list[int]:
    """Files whose partition a block starting in file k's partition can reach: k and the next ones
    that start before the end of k's partition plus one block."""
    if k + 1 == len(scanned):
        return [k]
    limit = scanned[k + 1].first_time + np.timedelta64(int(round(block_s * _NS)), "ns")
    return [k] + [j for j in range(k + 1, len(scanned)) if scanned[j].first_time < limit]


def process_long_record(
    files: Sequence[str | Path], out_dir: str | Path, sonic: Mapping[str, Any],
    processing: Mapping[str, Any] | None = None, *, record: str = "record", n_workers: int = 1,
    l1_at_once: int = 1, table_name: str = "block_stats.csv",
) -> LongRecordResult:
    """A long record from its TOA5 files to ``tables/block_stats.csv``, in bounded memory.

    Parameters
    ----------
    files : sequence of path
        TOA5 files of one sonic (any order; one per day as loggers write them).
    out_dir : str or Path
        Results folder: L1 NetCDF in ``netcdf/L1/``, the table in ``tables/``.
    sonic : mapping
        ``id``, ``height_m`` [m], ``azimuth_deg`` [degree] of the sonic.
    processing : mapping, optional
        ``processing`` section of the configuration (``despike``, ``block_s``, ``rotation``,
        ``detrending``, ``max_missing_fraction``, ``spectra``, ``quadrant``); absent keys
        take the schema's defaults.
    record : str
        Record name (the mast or tower) in the table and file names.
    n_workers : int
        Tasks run at once (threads). Default 1: measured on 30 days of 20 Hz data, two
        threads took the same wall time as one (the parsing, despiking and statistics hold
        the GIL most of the time) and raised the peak memory from 689 to 1073 MB
        (``benchmarks/results/long_record.json``).
    l1_at_once : int
        L1 tasks run at once (at most ``n_workers``). An L1 task holds a whole file (about
        350 MB for a day of 20 Hz rows), a block task a few tens of MB: with the default 1,
        one thread reads the next file while the other analyses the blocks of the last,
        and the peak memory is that of one file (``benchmarks/bench_long_record.py``).
    table_name : str
        File name of the table.

    Returns
    -------
    LongRecordResult

    Notes
    -----
    The dask graph: one L1 task per file (:func:`file_l1`); with ``rotation: planar_fit``
    one task merging the files' 30-min sums into the record's planar fit; one block task
    per file (:func:`file_blocks`) that depends on the L1 tasks of the files its blocks
    reach. Tasks hand on paths and small summaries only; the samples go through the L1
    NetCDF files.
    """
    settings = BlockSettings.from_processing(processing)
    despike = _despike_settings(processing)
    out = Path(out_dir)
    scanned = scan_files(files)
    if not scanned:
        raise InputError("files", "no TOA5 file given for the long record")
    _check_overlaps(scanned, [context_rows(r.fs_hz, float(despike["window_s"])) for r in scanned])
    n = len(scanned)
    p_l1 = Progress("L1 file", n, "read, despiked and written")
    p_blk = Progress("block file", n, "analysed in blocks")
    slots = threading.BoundedSemaphore(max(1, int(l1_at_once)))
    l1_tasks = [dask.delayed(_file_l1_in_slot, pure=False)(slots, scanned, k, sonic, despike, out, record, p_l1)
                for k in range(n)]
    fit_task = dask.delayed(record_planar_fit_of, pure=False)(l1_tasks)
    use_fit = fit_task if settings.rotation == "planar_fit" else None
    first_times = [r.first_time for r in scanned]
    blk_tasks = [dask.delayed(file_blocks, pure=False)([l1_tasks[j] for j in _reach(scanned, k, settings.block_s)],
                                                       k, first_times, settings, record, str(sonic["id"]), use_fit,
                                                       p_blk) for k in range(n)]
    l1s, rows, fit = dask.compute(l1_tasks, blk_tasks, fit_task, scheduler="threads", num_workers=int(n_workers))
    p_l1.finished()
    p_blk.finished()
    table = block_stats_table([r for part in rows for r in part])
    path = atomic_write_text(out / "tables" / table_name, table.to_csv(index=False, na_rep="", lineterminator="\n"))
    LOG.info("long record %s: %d files, %d samples, %d blocks (%d usable) -> %s", record, n,
             sum(p.n_samples for p in l1s), len(table), int(table["usable"].sum()), path)
    return LongRecordResult([p.path for p in l1s], path, sum(p.n_samples for p in l1s), len(table),
                            int(table["usable"].sum()), dict(fit))



def _despike_settings(processing: Mapping[str, Any] | None) -> dict[str, float]:
    """``processing.despike`` (``window_s`` [s], ``n_mad``) with the schema's defaults."""
    d = dict(default_config()["processing"]["despike"])
    d.update(dict((processing or {}).get("despike", {})))
    return {"window_s": float(d["window_s"]), "n_mad": float(d["n_mad"])}
