r"""The forward model of a measured payload flight, and its response to each mechanism.

For one flight of a campaign (measured or virtual, it does not matter), the conditions
the simulator needs are taken from the *processed data*
(:mod:`dronewind.diagnose.forward_conditions`): the reference mast's mean wind,
direction, temperature, friction velocity and Obukhov length at its height, the drone's
hover height, position relative to the mast and hover window. Nothing is read from the
campaign's own ``simulation:`` section (for a virtual campaign that would be reading the
answer). The flight is then simulated without any mechanism (the *baseline*, with two
seeds) and with each catalog mechanism at a few *probe levels* (common random numbers:
the first baseline seed; :mod:`dronewind.diagnose.probe_runs`), and pushed through the
same chain functions as the measured flight (:mod:`dronewind.payload.chain`, :mod:`dronewind.mast.chain`,
:mod:`dronewind.compare.chain`), ending in the residual features of
:mod:`dronewind.diagnose.features`.

The runs stay in memory: the simulator's raw records (:mod:`dronewind.core.raw`, exactly the
values its writers would print) go to the chain's readers without a file; the flight's true
state (turbulence, payload motion, mast field) is simulated once per seed and reused by every
probe of a measurement-stage mechanism (all but :data:`dronewind.diagnose.probes.TRUTH_MECHANISMS`); and the products
of records a probe leaves unchanged are reused (:class:`ForwardCache`). Each shortcut gives
bit for bit the result of the long way round (``tests/diagnose/test_forward_memory.py``), and
:func:`file_round_trip` checks one flight through the files.

The atmosphere (``diagnosis.atmosphere``, :data:`dronewind.diagnose.probes.ATMOSPHERES`): with ``measured`` (the
default) the forward runs take the turbulence both sensors share from the reference mast as
measured: its record over the flight
(:func:`dronewind.diagnose.forward_atmosphere.atmosphere_record`, the mast L1) constrains the
simulated field at the mast sonic, so the simulated mast sees the measured realisation
(trend and low frequencies included), and the record's smoothed spectra, carried to the
hover height by the model's height dependence, set the spectral amplitudes at every point
(:func:`dronewind.simulate.payload_wind.measured_constraint`; Rinker 2018 for the constrained
generation, Kaimal et al. 1972 for the height scaling). The hover point then gets the part of
the record coherent at its separation plus an unconstrained remainder drawn by the seed. The
record's smoothed spectra are one estimate of the true spectra: each seed draws them again
from their sampling distribution given the record
(:func:`dronewind.simulate.constraint.spectral_sampling_factors`), so that the baseline seeds
vary the remainder, the mast record's spectral sampling error and the instruments, and their
scatter is that of a feature across independent atmospheres
(``tests/diagnose/test_measured_atmosphere_scatter.py``). With ``model`` the turbulence is the similarity model's
at the measured mean conditions (mean wind, direction, u*, L). A mechanism acting on the
mast's record (:data:`~dronewind.diagnose.forward_atmosphere.RECORD_INVERSES`) is probed by
undoing it on the record; with the
atmosphere defined by the mast, a drone w gain g and a mast w attenuation 1/g then predict the
same sensor differences (an ambiguity the diagnosis reports).

Settings: the functions that run the chain take ``processing``, the ``processing`` section
of the workflow configuration (at least the keys of
:data:`dronewind.diagnose.probes.CHAIN_SETTINGS`; defaults from
:func:`dronewind.manifest.default_config`), the same as for the measured flight.

Probe levels are chosen inside each mechanism's physical range, large enough to rise above
sampling noise and small enough that the response stays smooth (it is interpolated
piecewise-linearly between levels and the baseline, see
:mod:`dronewind.diagnose.fitting`).
"""

from __future__ import annotations

import contextlib
import logging
import math
import shutil
import tempfile
from collections.abc import Callable, Collection, Mapping, Sequence
from pathlib import Path, PurePath
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from dronewind.compare.chain import compute_l3
from dronewind.core.raw import RawRecord
from dronewind.core.reuse import StepStore, read_only, reusing, same_bits
from dronewind.diagnose.features import FlightFeatures, flight_features
from dronewind.diagnose.forward_conditions import measured_span
from dronewind.diagnose.probes import (
    LAG_SETTINGS,
)
from dronewind.errors import InputError
from dronewind.mast.chain import compute_mast_l1, compute_mast_l2
from dronewind.payload.chain import compute_ins_l1, compute_payload_l2, compute_sonic_l1

__all__ = [
    "measured_features",
    "run_forward",
    "ForwardCache",
    "same_records",
    "lag_halves",
    "file_round_trip",
    "run_differences",
]

if TYPE_CHECKING:
    from dronewind.payload.ins import InsTable
    from dronewind.simulate.payload import PayloadTruth

LOG = logging.getLogger("dronewind")


def lag_halves(sonic_l1: xr.Dataset, ins_l1: xr.Dataset, l2: xr.Dataset, flight: Mapping[str, Any],
               site_altitude_m: float, *, sonic_ins_lag: Mapping[str, Any], hover: Mapping[str, Any],
               max_missing_fraction: float) -> tuple[float, float]:
    """Sonic-INS lags found on the first and the second half of the hover window [s].

    The lag search of the flight's L2 on each half of its hover window (the same sonic
    segment and INS, :func:`dronewind.payload.l2.payload_l2` with ``lag_halves``): read
    from ``l2``'s attributes when it was made with them, else found by a lag-only pass.

    Parameters
    ----------
    sonic_l1, ins_l1, l2 : xarray.Dataset
        The flight's payload sonic and INS L1, and its L2.
    flight : mapping
        The flight's manifest entry.
    site_altitude_m : float
        Ground altitude of the site [m].
    sonic_ins_lag, hover, max_missing_fraction
        ``processing`` settings of :func:`dronewind.payload.chain.compute_payload_l2`.

    Returns
    -------
    tuple of float
        Lags of the two halves [s]; NaN for a half the search cannot use.
    """
    if "lag_first_half_s" not in l2.attrs:
        try:
            l2 = compute_payload_l2(sonic_l1, ins_l1, flight, site_altitude_m, sonic_ins_lag=sonic_ins_lag,
                                    hover=hover, max_missing_fraction=max_missing_fraction, lag_only=True,
                                    lag_halves=True)
        except InputError as exc:  # no hover or no lag: the feature is then missing
            LOG.warning("lags of the hover's halves failed: %s", exc)
            return float("nan"), float("nan")
    return float(l2.attrs["lag_first_half_s"]), float(l2.attrs["lag_second_half_s"])


def measured_features(campaign_data: Mapping[str, Any], flight_id: str, sonic_l1: xr.Dataset, ins_l1: xr.Dataset,
                      l2: xr.Dataset, l3: xr.Dataset, *, sonic_ins_lag: Mapping[str, Any], hover: Mapping[str, Any],
                      max_missing_fraction: float) -> FlightFeatures:
    """Residual features of one flight from its processed products (in memory).

    Parameters
    ----------
    campaign_data : mapping
        Manifest content (or the one-flight view) with the flight and the site altitude.
    flight_id : str
        Payload flight id.
    sonic_l1, ins_l1, l2, l3 : xarray.Dataset
        The flight's products.
    sonic_ins_lag, hover, max_missing_fraction
        ``processing`` settings of the lag feature (:data:`LAG_SETTINGS`).

    Returns
    -------
    FlightFeatures
        See :func:`dronewind.diagnose.features.flight_features`.
    """
    flight = next(f for f in campaign_data["payload_flights"] if f["id"] == flight_id)
    halves = lag_halves(sonic_l1, ins_l1, l2, flight, float(campaign_data["site"]["altitude_m"]),
                        sonic_ins_lag=sonic_ins_lag, hover=hover, max_missing_fraction=max_missing_fraction)
    return flight_features(l3, l2, lag_halves_s=halves, lag_step_s=float(sonic_ins_lag["step_s"]))


class ForwardCache:
    """Products of a flight's baseline run, reused by probe runs whose raw records are identical.

    A probe of a measurement-stage mechanism changes one instrument's record and leaves the
    others bit-identical to the baseline's (same true state, same random streams): a sonic
    probe leaves the INS and the masts, an INS probe the masts, a mast probe the payload.
    Each product is a pure function of its records and the settings, so it is found by its
    records: the same record objects, or records whose columns are bit for bit the same
    (:func:`same_records`; comparing is about twenty times cheaper than hashing them, and the
    cache holds few products of each kind). Entries are stored while the cache is open (the
    baseline run) and only read after :meth:`freeze`, so memory stays one run's products.

    :attr:`steps` does the same for steps inside a product whose own input a probe left
    unchanged (e.g. despiking a sonic channel; :mod:`dronewind.core.reuse`), found by
    comparing that input with the stored ones; it is frozen with the cache.
    """

    def __init__(self) -> None:
        self._store: dict[tuple[str, str], list[tuple[tuple[RawRecord | str | Path, ...], Any]]] = {}
        self.frozen = False
        self.hits = 0
        self.misses = 0
        #: results of steps inside the products
        self.steps = StepStore(frozen=lambda: self.frozen)

    def freeze(self) -> None:
        """Stop storing: later runs only read the entries."""
        self.frozen = True

    def get(self, kind: str, records: Sequence[RawRecord | str | Path], make: Callable[[], Any],
            settings: str = "") -> Any:
        """The product ``kind`` of these records (and ``settings``), made by ``make()`` if absent."""
        key = tuple(records)
        entries = self._store.setdefault((kind, settings), [])
        for stored, value in entries:
            if same_records(stored, key):
                self.hits += 1
                return value
        self.misses += 1
        value = make()
        if not self.frozen:
            # handed out to every later run: read-only, so that no run can change another's inputs
            # (the L2 takes views of the L1 where it windows it, dronewind.payload.l2)
            entries.append((key, read_only(value)))
        return value


def same_records(a: Sequence[RawRecord | str | Path], b: Sequence[RawRecord | str | Path]) -> bool:
    """Whether two lists of records hold the same data: the same objects, or equal columns bit for bit.

    File paths are equal only as the same object: a file rewritten in place is never taken for
    the one read before (:func:`process_forward_flight` gives files a fresh cache).

    Parameters
    ----------
    a, b : sequence of RawRecord, str or Path
        Records (:class:`dronewind.core.raw.RawRecord`) or file paths.

    Returns
    -------
    bool
    """
    if len(a) != len(b):
        return False
    for x, y in zip(a, b, strict=True):
        if x is y:
            continue
        if not (isinstance(x, RawRecord) and isinstance(y, RawRecord)):
            return False
        if (x.source, x.first_line, dict(x.units), dict(x.meta), list(x.columns)) != (
                y.source, y.first_line, dict(y.units), dict(y.meta), list(y.columns)):
            return False
        if not all(_same_column(np.asarray(x.columns[k]), np.asarray(y.columns[k])) for k in x.columns):
            return False
    return True


def _same_column(a: np.ndarray, b: np.ndarray) -> bool:
    """Bit-identical numeric columns, or equal object columns (by their values)."""
    if a.dtype.kind == "O" or b.dtype.kind == "O":
        return a.dtype == b.dtype and a.shape == b.shape and a.tolist() == b.tolist()
    return same_bits(a, b)


def _clock_settings(ins_table: InsTable, ins_src: str | Path | RawRecord) -> str:
    """What the sonic L1 takes from the INS (:func:`dronewind.payload.sonic.payload_sonic_l1`), as text.

    The logger-clock fit, the stable-time row, the parsing's log and counts and the source
    name: not the INS's values.
    """
    return repr((ins_table.fit, ins_table.rpi_stable_us, list(ins_table.log), sorted(ins_table.counts.items()),
                 str(ins_src)))


def process_forward_flight(manifest: Mapping[str, Any], flight_id: str, sources: Sequence[str | Path | RawRecord],
                           processing: Mapping[str, Any], cache: ForwardCache | None = None,
                           lag_drift: bool = True, features: Collection[str] | None = None,
                           errors: bool = True) -> tuple[FlightFeatures, dict[str, Any]]:
    """Process the raw records of a simulated forward flight like measured data, up to its features.

    Parameters
    ----------
    manifest : mapping
        The forward manifest (:func:`forward_manifest`).
    flight_id : str
        Payload flight id.
    sources : sequence of path or RawRecord
        What the simulator made, in its order: sonic, INS, then the mast records (those of the
        flight's reference sonic are used), as files
        (:func:`dronewind.simulate.payload.simulate_payload_flight`) or in-memory records
        (:func:`dronewind.simulate.payload.payload_records`).
    processing : mapping
        ``processing`` settings (keys of :data:`CHAIN_SETTINGS`).
    cache : ForwardCache, optional
        Products of identical records from an earlier run of the same flight and settings.
    lag_drift : bool
        Find the lags of the hover's two halves for the ``lag_drift_s`` feature (two more
        lag searches on the L2's segment); without, that feature is missing (NaN). For
        observations that hold no lag, e.g. published statistics.
    features : collection of str, optional
        Only these features (:func:`dronewind.diagnose.features.flight_features`); all by
        default.
    errors : bool
        Give the features' standard errors (:func:`~dronewind.diagnose.features.flight_features`).

    Returns
    -------
    features : FlightFeatures
    products : dict
        ``{"l2": ..., "l3": ..., "l1": {"sonic", "ins", "mast"}}`` datasets.
    """
    if cache is None or not all(isinstance(src, RawRecord) for src in sources):
        cache = ForwardCache()  # files are not keyed by content: a file rewritten in place is never reused
    with reusing(cache.steps):
        return _process_forward_flight(manifest, flight_id, sources, processing, cache, lag_drift, features, errors)


def _process_forward_flight(manifest: Mapping[str, Any], flight_id: str, sources: Sequence[str | Path | RawRecord],
                            processing: Mapping[str, Any], cache: ForwardCache, lag_drift: bool,
                            features: Collection[str] | None, errors: bool) -> tuple[FlightFeatures, dict[str, Any]]:
    """:func:`process_forward_flight` with its cache, inside the cache's :func:`reusing` block."""
    flight = next(f for f in manifest["payload_flights"] if f["id"] == flight_id)
    sonic_info = next(s for m in manifest["masts"] for s in m["sonics"] if s["id"] == flight["reference"])
    sonic_src, ins_src = sources[0], sources[1]
    # the reference sonic's records: those whose path matches one of its file patterns
    mast_srcs = [src for src in sources[2:] if any(PurePath(str(src)).match(str(pattern))
                                                   for pattern in sonic_info["files"])]
    lag = {key: processing[key] for key in LAG_SETTINGS}
    ins_table, ins_l1 = cache.get("ins_l1", [ins_src], lambda: compute_ins_l1(ins_src))
    # the sonic L1 takes from the INS only its clock (fit, stable time, log): an INS probe that
    # leaves the INS's times alone (heading bias, attitude lag, lever arm) reuses it
    sonic_l1 = cache.get("sonic_l1", [sonic_src],
                         lambda: compute_sonic_l1(sonic_src, ins_src, ins_table, processing["despike"]),
                         settings=_clock_settings(ins_table, ins_src))
    site_altitude_m = float(manifest["site"]["altitude_m"])

    # a run processed over the measured hover window (forward_manifest with a measured
    # atmosphere) keeps the measured L2's samples: the same record lengths downstream
    conditions = manifest.get("simulation", {}).get("payload_flights", {}).get(flight_id, {})
    measured_window = "window" in flight and "start" in conditions and "duration_s" in conditions

    def payload_l2() -> tuple[xr.Dataset, tuple[float, float] | None]:
        l2 = compute_payload_l2(sonic_l1, ins_l1, flight, site_altitude_m, lag_halves=lag_drift, **lag)
        if measured_window:
            l2 = measured_span(l2, conditions)
        return l2, lag_halves(sonic_l1, ins_l1, l2, flight, site_altitude_m, **lag) if lag_drift else None

    l2, halves = cache.get("l2" if lag_drift else "l2 without halves", [sonic_src, ins_src], payload_l2)
    mast_l1 = cache.get("mast_l1", mast_srcs, lambda: compute_mast_l1(mast_srcs, sonic_info, processing["despike"]))
    # the mast over the drone's hover window: a probe that leaves the mast and the window alone
    # (most do) finds it made
    span = (l2["time"].values[0], l2["time"].values[-1])
    mast_l2 = cache.get("mast_l2", mast_srcs, lambda: compute_mast_l2(mast_l1, l2, flight_id, processing["drone_mast"],
                                                                      source="forward mast"),
                        settings=repr((flight_id, span, sorted(processing["drone_mast"].items()))))
    l3 = compute_l3(l2, mast_l2, flight, processing["drone_mast"], processing["rotation"])
    found = flight_features(l3, l2, lag_halves_s=halves, lag_step_s=float(processing["sonic_ins_lag"]["step_s"]),
                            features=features, errors=errors)
    return found, {"l2": l2, "l3": l3, "l1": {"sonic": sonic_l1, "ins": ins_l1, "mast": mast_l1}}


def run_forward(
    manifest: Mapping[str, Any],
    flight_id: str,
    processing: Mapping[str, Any],
    work_dir: str | Path | None = None,
    truth: PayloadTruth | None = None,
    cache: ForwardCache | None = None,
    atmosphere: xr.Dataset | None = None,
    lag_drift: bool = True,
    features: Collection[str] | None = None,
    errors: bool = True,
) -> tuple[FlightFeatures, dict[str, Any]]:
    """Simulate one flight of a forward manifest, process it as measured data, return its features.

    Parameters
    ----------
    manifest : mapping
        Output of :func:`forward_manifest`.
    flight_id : str
        Payload flight id.
    processing : mapping
        ``processing`` settings (keys of :data:`CHAIN_SETTINGS`; the same as for the
        measured data).
    work_dir : str or Path, optional
        Write the raw files there and process the files (the file round trip); by default
        the simulator's in-memory records go to the chain's readers directly
        (:mod:`dronewind.core.raw`), which gives the same L1 (tested) without printing and
        parsing text.
    truth : PayloadTruth, optional
        The flight's true state (turbulence, motion, mast field) from an earlier run of the
        same conditions, seed and ``height_offset``: only the measurement stage is
        simulated again (:func:`dronewind.simulate.payload.payload_records`).
    cache : ForwardCache, optional
        Products of identical raw records from an earlier run (:class:`ForwardCache`).
    atmosphere : xarray.Dataset, optional
        The reference mast's measured record (:func:`atmosphere_record`): the field is
        constrained by it and takes its spectra
        (:func:`dronewind.simulate.payload_wind.measured_constraint`); the model field by default.
    lag_drift : bool
        Compute the ``lag_drift_s`` feature (:func:`process_forward_flight`).
    features : collection of str, optional
        Only these features; all by default (:func:`process_forward_flight`).
    errors : bool
        Give their standard errors (:func:`process_forward_flight`).

    Returns
    -------
    features : FlightFeatures
        Residual features of the simulated flight.
    products : dict
        ``{"l2": ..., "l3": ..., "l1": {...}, "truth": PayloadTruth}``.
    """
    from dronewind.simulate.payload import payload_records
    from dronewind.simulate.writers import write_record

    # inside the flight's cache, the simulator's steps that depend on neither seed nor probe
    # (the measured record's constraint) are made once too
    with reusing(cache.steps) if cache is not None else contextlib.nullcontext():
        records, truth = payload_records(dict(manifest), flight_id, truth, atmosphere)
    sources: list[str | Path | RawRecord] = list(records)
    if work_dir is not None:
        folder = Path(str(work_dir))
        sources = [write_record(folder / rec.source, rec) for rec in records]
    found, products = process_forward_flight(manifest, flight_id, sources, processing, cache, lag_drift, features,
                                             errors)
    products["truth"] = truth
    return found, products


def file_round_trip(manifest: Mapping[str, Any], flight_id: str, processing: Mapping[str, Any],
                    truth: PayloadTruth | None = None) -> dict[str, Any]:
    """Check that the in-memory forward run and its printed files give the same L1 and features.

    Parameters
    ----------
    manifest, flight_id, processing, truth
        As :func:`run_forward`.

    Returns
    -------
    dict
        ``identical`` (bool), ``differences`` (names of the L1 variables, attributes or
        features that differ; source paths excepted).
    """
    mem, mem_products = run_forward(manifest, flight_id, processing, truth=truth)
    folder = Path(tempfile.mkdtemp(prefix="dronewind_forward_"))
    try:
        disk, disk_products = run_forward(manifest, flight_id, processing, work_dir=folder, truth=mem_products["truth"])
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    differences = run_differences((mem, mem_products), (disk, disk_products))
    return {"identical": not differences, "differences": differences}


def run_differences(a: tuple[FlightFeatures, Mapping[str, Any]],
                    b: tuple[FlightFeatures, Mapping[str, Any]]) -> list[str]:
    """What differs between two forward runs: L1 variables and attributes, and features.

    Parameters
    ----------
    a, b : (FlightFeatures, dict)
        Outputs of :func:`run_forward`.

    Returns
    -------
    list of str
        ``"L1 <sensor> <variable>"``, ``"L1 <sensor> attribute <name>"`` (the source paths
        excepted) and ``"feature <name>"`` entries; empty when the runs agree bit for bit.
    """
    differences = []
    for name in ("sonic", "ins", "mast"):
        da, db = a[1]["l1"][name], b[1]["l1"][name]
        differences += [f"L1 {name} {v}" for v in sorted(map(str, set(da.variables) | set(db.variables)))
                        if v not in da.variables or v not in db.variables or not da[v].identical(db[v])]
        differences += [f"L1 {name} attribute {k}" for k in sorted(set(da.attrs) | set(db.attrs))
                        if k not in _SOURCE_ATTRS and str(da.attrs.get(k)) != str(db.attrs.get(k))]
    fa, fb = a[0].values, b[0].values
    differences += [f"feature {k}" for k in sorted(set(fa) | set(fb))
                    if not (fa.get(k) == fb.get(k) or (_isnan(fa.get(k)) and _isnan(fb.get(k))))]
    return differences


#: L1 attributes that name the raw source (a path for files, the manifest path for records).
_SOURCE_ATTRS = ("source_file", "ins_source_file", "source_files")


def _isnan(x: object) -> bool:
    return isinstance(x, float) and math.isnan(x)
