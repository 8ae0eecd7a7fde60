r"""The forward model of a measured payload flight, and its response to each mechanism.

For one flight of a campaign (measured or virtual, it does not matter), the conditions
the simulator needs are taken from the *processed data*: the reference mast's mean wind,
direction, temperature, friction velocity and Obukhov length at its height, the drone's
hover height, position relative to the mast and hover window. Nothing is read from the
campaign's own ``simulation:`` section (for a virtual campaign that would be reading the
answer). The flight is then simulated without any mechanism (the *baseline*, with two
seeds) and with each catalog mechanism at a few *probe levels* (common random numbers:
the first baseline seed), and pushed through the same chain functions as the measured
flight (:mod:`dronewind.payload.chain`, :mod:`dronewind.mast.chain`,
:mod:`dronewind.compare.chain`), ending in the residual features of
:mod:`dronewind.diagnose.features`.

The runs stay in memory: the simulator's raw records (:mod:`dronewind.core.raw`, exactly the
values its writers would print) go to the chain's readers without a file; the flight's true
state (turbulence, payload motion, mast field) is simulated once per seed and reused by every
probe of a measurement-stage mechanism (all but :data:`TRUTH_MECHANISMS`); and the products
of records a probe leaves unchanged are reused (:class:`ForwardCache`). Each shortcut gives
bit for bit the result of the long way round (``tests/test_forward_memory.py``), and
:func:`file_round_trip` checks one flight through the files.

The atmosphere (``diagnosis.atmosphere``, :data:`ATMOSPHERES`): with ``measured`` (the
default) the forward runs take the turbulence both sensors share from the reference mast as
measured: its record over the flight (:func:`atmosphere_record`, the mast L1) constrains the
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
(``tests/test_measured_atmosphere_scatter.py``,
``benchmarks/results/measured_atmosphere_scatter.json``). With ``model`` the turbulence is the similarity model's
at the measured mean conditions (mean wind, direction, u*, L). A mechanism acting on the
mast's record (:data:`RECORD_INVERSES`) is probed by undoing it on the record; with the
atmosphere defined by the mast, a drone w gain g and a mast w attenuation 1/g then predict the
same sensor differences (an ambiguity the diagnosis reports).

Settings: the functions that run the chain take ``processing``, the ``processing`` section
of the workflow configuration (at least the keys of :data:`CHAIN_SETTINGS`; defaults from
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
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import xarray as xr

from dronewind.compare.chain import compute_l3
from dronewind.core.constants import KARMAN
from dronewind.core.progress import Progress
from dronewind.core.raw import RawRecord
from dronewind.core.reuse import StepStore, read_only, reusing, same_bits
from dronewind.diagnose.features import FEATURES, FlightFeatures, flight_features
from dronewind.diagnose.probes import (
    ATMOSPHERES,
    BASELINE_PART,
    CHAIN_SETTINGS,
    LAG_SETTINGS,
    MECHANISM_BASELINES,
    PROBES,
    TRUTH_MECHANISMS,
    Probe,
    baseline_level,
    fresh_seeds,
    probe_parts,
)
from dronewind.errors import InputError
from dronewind.manifest import parse_utc, payload_flight_manifest
from dronewind.mast.chain import compute_mast_l1, compute_mast_l2
from dronewind.payload.chain import compute_ins_l1, compute_payload_l2, compute_sonic_l1

__all__ = ["Probe", "PROBES", "MECHANISM_BASELINES", "CHAIN_SETTINGS", "LAG_SETTINGS", "TRUTH_MECHANISMS",
           "forward_conditions", "forward_manifest", "measured_features", "run_forward", "ForwardCache",
           "same_records", "lag_halves", "probe_runs", "probe_parts", "merge_probe_runs", "BASELINE_PART",
           "file_round_trip", "run_differences", "ATMOSPHERES", "RECORD_INVERSES", "shares_truth", "atmosphere_record",
           "fresh_seeds", "record_through", "hover_span", "atmosphere_window", "ATMOSPHERE_VARIABLES",
           "simulated_sonic_ins_lag_s"]

if TYPE_CHECKING:
    from dronewind.payload.ins import InsTable
    from dronewind.simulate.payload import PayloadTruth

LOG = logging.getLogger("dronewind")


def _psi_m(zeta: float) -> float:
    from dronewind.core.surface_layer import psi_m

    return float(psi_m(zeta))


class SurfaceLayer(NamedTuple):
    """Monin-Obukhov scaling of the reference mast record of one flight."""

    z_m: float
    speed_ms: float
    ustar_ms: float
    obukhov_length_m: float
    zeta: float
    theta_mean_k: float


def mast_surface_layer(l3: xr.Dataset) -> SurfaceLayer:
    """Height, mean wind, friction velocity, Obukhov length and z/L of the flight's mast sonic.

    Parameters
    ----------
    l3 : xarray.Dataset
        The flight's L3 (sensor ``mast`` in streamline coordinates).

    Returns
    -------
    SurfaceLayer
        From the samples where u, v, w and theta_v are all finite; the friction velocity is
        at least 0.02 m s-1, the Obukhov length (Ghirardelli et al. 2025, Eq. 9) infinite beyond 1e5 m and
        limited to :math:`|z/L| \\le 5`.
    """
    from dronewind.core import stats

    m = list(np.asarray(l3["sensor"].values).astype(str)).index("mast")
    u = l3["u_ms"].values[m].astype(float)
    v = l3["v_ms"].values[m].astype(float)
    w = l3["w_ms"].values[m].astype(float)
    theta = l3["theta_v_k"].values[m].astype(float)
    ok = np.isfinite(u) & np.isfinite(v) & np.isfinite(w) & np.isfinite(theta)
    u, v, w, theta = u[ok], v[ok], w[ok], theta[ok]
    z = float(l3["height_m"].values[m])
    speed = float(np.mean(u))
    uw = float(stats.covariance(u, w))
    vw = float(stats.covariance(v, w))
    wt = float(stats.covariance(w, theta))
    ustar = max(float(stats.friction_velocity(uw, vw)), 0.02)
    theta_mean = float(np.mean(theta))
    ell = float(stats.obukhov_length(ustar, wt, theta_mean))
    if not math.isfinite(ell) or abs(ell) > 1e5:
        ell = math.inf
    zeta = 0.0 if math.isinf(ell) else z / ell
    if abs(zeta) > 5:
        zeta = math.copysign(5.0, zeta)
        ell = z / zeta
    return SurfaceLayer(z, speed, ustar, ell, zeta, theta_mean)


def roughness_length_m(layer: SurfaceLayer) -> float:
    r"""Roughness length from Monin-Obukhov similarity at the mast height [m].

    .. math:: z_0 = z \exp\left(-\frac{\kappa \bar u}{u_*} - \psi_m(z/L)\right),

    clipped to [0.001, 2] m.
    """
    z0 = layer.z_m * math.exp(-(KARMAN * layer.speed_ms / layer.ustar_ms) - _psi_m(layer.zeta))
    return float(min(max(z0, 1e-3), 2.0))


def hover_offset_enu_m(campaign_data: Mapping[str, Any], flight: Mapping[str, Any], l2_drone: xr.Dataset
                       ) -> tuple[float, float]:
    """East and north offset of the drone's median hover position from its reference mast [m]."""
    from dronewind.core.geo import local_tangent_plane_m

    site = campaign_data["site"]
    mast_lat, mast_lon = site["latitude"], site["longitude"]
    for mast in campaign_data.get("masts") or []:
        if any(s["id"] == flight["reference"] for s in mast["sonics"]):
            mast_lat, mast_lon = mast.get("latitude", mast_lat), mast.get("longitude", mast_lon)
    lat = float(np.nanmedian(l2_drone["lat_deg"].values))
    lon = float(np.nanmedian(l2_drone["lon_deg"].values))
    east, north = local_tangent_plane_m(np.array([lat]), np.array([lon]), mast_lat, mast_lon)
    return float(east[0]), float(north[0])


def forward_conditions(
    campaign_data: Mapping[str, Any],
    flight_id: str,
    l3: xr.Dataset,
    l2_drone: xr.Dataset,
) -> dict[str, Any]:
    """Simulator conditions of one flight, estimated from its processed data.

    Parameters
    ----------
    campaign_data : mapping
        Manifest content of the campaign (or its one-flight view,
        :func:`dronewind.manifest.payload_flight_manifest`).
    flight_id : str
        Payload flight id.
    l3 : xarray.Dataset
        The flight's L3 (drone and reference mast sonic, streamline coordinates).
    l2_drone : xarray.Dataset
        The drone's L2 (hover window, GNSS track, height).

    Returns
    -------
    dict
        Keys of ``simulation.payload_flights.<id>`` (see :mod:`dronewind.simulate`):
        ``mean_speed_ms``, ``wind_from_deg``, ``obukhov_length_m``, ``z_ref_m``,
        ``hover_height_m``, ``start``, ``duration_s``, ``hover_offset_enu_m``,
        ``roughness_length_m``, ``theta_mean_k``; the surface layer from
        :func:`mast_surface_layer`, the roughness length from :func:`roughness_length_m`;
        and ``sonic_ins_lag_s``, the sonic-INS lag the chain found for the flight (the L2's
        ``lag_tke_min_s``, else its ``lag_sonic_ins_s``; absent when neither is finite):
        every sonic-INS system has a processing lag of its own, different per flight
        (Ghirardelli et al. 2025, Sect. 3.3, Fig. 4), which the forward runs reproduce
        (:func:`simulated_sonic_ins_lag_s`). A condition of the forward model, the lag is
        then no evidence of the diagnosis.
    """
    layer = mast_surface_layer(l3)
    m = list(np.asarray(l3["sensor"].values).astype(str)).index("mast")
    flight = next(f for f in campaign_data["payload_flights"] if f["id"] == flight_id)
    east, north = hover_offset_enu_m(campaign_data, flight, l2_drone)
    times = l2_drone["time"].values
    height = float(l2_drone.attrs.get("height_m", flight.get("target_height_m", layer.z_m)))
    ell = layer.obukhov_length_m
    lag = _measured_lag_s(l2_drone)
    return {
        "mean_speed_ms": float(min(max(layer.speed_ms, 0.05), 40.0)),
        "wind_from_deg": float(l3["wind_from_deg"].values[m]) % 360.0,
        "obukhov_length_m": "inf" if math.isinf(ell) else float(ell),
        "z_ref_m": layer.z_m,
        "hover_height_m": float(max(height, 3.0)),
        "start": np.datetime_as_string(times[0], unit="us") + "Z",
        "duration_s": float((times[-1] - times[0]) / np.timedelta64(1, "us") * 1e-6),
        "hover_offset_enu_m": [east, north],
        "roughness_length_m": roughness_length_m(layer),
        "theta_mean_k": float(min(max(layer.theta_mean_k, 221.0), 329.0)),
        **({} if lag is None else {"sonic_ins_lag_s": lag}),
    }


def _measured_lag_s(l2_drone: xr.Dataset) -> float | None:
    """The sonic-INS lag of minimum TKE the chain found (L2 ``lag_tke_min_s``, else ``lag_sonic_ins_s``) [s]."""
    for key in ("lag_tke_min_s", "lag_sonic_ins_s"):
        value = float(l2_drone.attrs.get(key, np.nan))
        if math.isfinite(value):
            return value
    return None


def forward_manifest(
    campaign_data: Mapping[str, Any],
    flight_id: str,
    conditions: Mapping[str, Any],
    mechanisms: list[dict[str, Any]] | None = None,
    seed: int = 0,
    measured_atmosphere: bool = False,
) -> dict[str, Any]:
    """A one-flight virtual campaign that reproduces a measured flight's conditions.

    Parameters
    ----------
    campaign_data : mapping
        Manifest content of the measured campaign, or its one-flight view (its
        ``simulation:`` section, if any, is dropped).
    flight_id : str
        Payload flight id.
    conditions : mapping
        Output of :func:`forward_conditions`.
    mechanisms : list of dict, optional
        ``[{"mechanism": name, "parameters": {...}}]``; none for the baseline.
    seed : int
        Campaign seed of the forward run.
    measured_atmosphere : bool
        The run's atmosphere is the reference mast's measured record
        (:func:`atmosphere_record`), which already holds the mast sonic's white noise: the
        forward mast then adds none (``simulation.mast`` noise 0). The forward flight is
        then processed over the measured hover window (``start`` and ``duration_s`` of the
        conditions) instead of the window the chain would find in the simulated hover (which
        includes the simulator's hover margins): the features of the mast, whose record is
        the measured one, then cover the same samples as the measured features.

    Returns
    -------
    dict
        Manifest content with one payload flight (without its ``window``, or with the
        measured one for ``measured_atmosphere``), its reference
        mast sonic (:func:`dronewind.manifest.payload_flight_manifest`) and a
        ``simulation:`` section. The flight's sonic-INS processing lag is the conditions'
        ``sonic_ins_lag_s``, or 0 without one (not the simulator's per-flight draw, which
        would give every seed another lag).
    """
    data = payload_flight_manifest(campaign_data, flight_id)
    flight = data["payload_flights"][0]
    flight.pop("window", None)
    if measured_atmosphere:
        _, end = hover_span(conditions)
        flight["window"] = {"start": str(conditions["start"]), "end": np.datetime_as_string(end, unit="us") + "Z"}
    data["name"] = f"{campaign_data['name']}_forward_{flight_id}"
    data["simulation"] = {
        "seed": int(seed),
        "payload_flights": {flight_id: {**dict(conditions), "sonic_ins_lag_s": float(conditions.get("sonic_ins_lag_s",
                                                                                                    0.0))}},
        "mechanisms": [dict(m) for m in (mechanisms or [])],
    }
    if measured_atmosphere:
        data["simulation"]["mast"] = {"noise_ms": 0.0, "temperature_noise_k": 0.0}
    return data


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

    def payload_l2() -> tuple[xr.Dataset, tuple[float, float] | None]:
        l2 = compute_payload_l2(sonic_l1, ins_l1, flight, site_altitude_m, lag_halves=lag_drift, **lag)
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


def _probe_parameters(probe: Probe, level: float) -> dict[str, float]:
    """Parameters of a probe's mechanism at one level: the others fixed or at their baseline."""
    params = {probe.parameter: float(level)}
    for name in _other_parameters(probe.mechanism, probe.parameter):
        params[name] = dict(probe.fixed).get(name, baseline_level(probe.mechanism, name))
    return params



def probe_runs(
    campaign_data: Mapping[str, Any],
    flight_id: str,
    conditions: Mapping[str, Any],
    processing: Mapping[str, Any],
    seeds: tuple[int, ...],
    probes: tuple[Probe, ...] = PROBES,
    parts: Sequence[str] | None = None,
    atmosphere: xr.Dataset | None = None,
    lag_drift: bool = True,
    features: Collection[str] | None = None,
) -> dict[str, Any]:
    """Baseline and probe runs of the forward model for one flight.

    Parameters
    ----------
    campaign_data : mapping
        Manifest content of the measured campaign (or its one-flight view).
    flight_id : str
        Payload flight id.
    conditions : mapping
        Output of :func:`forward_conditions`.
    processing : mapping
        ``processing`` settings (keys of :data:`CHAIN_SETTINGS`).
    seeds : tuple of int
        Baseline seeds (``diagnosis.seeds``); the first one is also used for every probe run
        (common random numbers, so a probe's difference to that baseline is the
        mechanism's effect).
    probes : tuple of Probe
        Probes to run.
    parts : sequence of str, optional
        Run only these parts (:func:`probe_parts`: ``"baseline"`` and mechanism names);
        all by default.
    atmosphere : xarray.Dataset, optional
        The reference mast's measured record of the flight (:func:`atmosphere_record`,
        ``diagnosis.atmosphere: measured``); the similarity model's field without it.
    lag_drift : bool
        Compute the ``lag_drift_s`` feature (:func:`process_forward_flight`); when false it
        is NaN in every run and ``lag_drift`` is false in the result.
    features : collection of str, optional
        Only these features (e.g. those a set of published numbers holds); all by default.
        They are listed in the result's ``features``.

    Returns
    -------
    dict
        ``{"baseline": [features per seed], "probes": [{candidate, mechanism,
        parameter, level, fixed, features}]}`` with features as
        :func:`~dronewind.diagnose.features.features_to_dict` dictionaries; probe levels a
        flight cannot take are listed in ``skipped_probes``; ``parts`` names the parts
        run and ``reused_products`` counts the products reused (:class:`ForwardCache`),
        ``reused_steps`` the steps inside them (:attr:`ForwardCache.steps`);
        ``atmosphere`` says which atmosphere was used (``measured`` or ``model``) and
        ``atmosphere_record`` what was used of the measured record;
        ``simulated_sonic_ins_lag_s`` (when the conditions carry the measured lag
        ``sonic_ins_lag_s``) is the processing lag every run simulates
        (:func:`simulated_sonic_ins_lag_s`; a probe of ``sonic_ins_lag`` or
        ``attitude_lag`` adds to it). The probes' features
        are values only (their errors NaN, not computed): the diagnosis takes the errors
        from the baseline seeds (:mod:`dronewind.diagnose.campaign`).

    Notes
    -----
    Every part gives the same numbers alone as in a run of the whole flight: the probes'
    true state is the first seed's, simulated again when the baseline is not in the part.

    With a measured atmosphere the baseline seeds differ in the part of the field not
    determined by the record (the hover point's incoherent part, the instruments' noise,
    the payload's motion) and in the record's spectra, drawn again per seed from their
    sampling distribution, so their scatter is the sampling error of the features across
    independent atmospheres, not only given the mast. The probes take the first seed's
    spectra as well as its remainder (common random numbers: the draws depend on the seed
    and the frequencies only). A probe of a mechanism that acts on the reference mast's record
    (:data:`RECORD_INVERSES`) reads the record through that mechanism: the atmosphere is the
    record with the mechanism undone (the true wind the mast would have measured), and the
    forward mast then measures it with the mechanism, i.e. the measured record again. Such
    probes simulate their own true state.
    """
    from dronewind.diagnose.features import features_to_dict
    from dronewind.simulate.payload import payload_truth

    parts = tuple(probe_parts(probes)) if parts is None else tuple(parts)
    unknown = sorted(set(parts) - set(probe_parts(probes)))
    if unknown:
        raise InputError("parts", f"unknown forward-run part(s) {unknown}; expected some of {probe_parts(probes)}")
    out: dict[str, Any] = {"flight": flight_id, "conditions": dict(conditions), "seeds": list(seeds),
                           "parts": list(parts), "baseline": [], "probes": [],
                           "atmosphere": "model" if atmosphere is None else "measured", "lag_drift": bool(lag_drift),
                           "features": list(FEATURES) if features is None else [f for f in FEATURES if f in features]}
    levels = [(probe, level) for probe in probes if probe.mechanism in parts for level in probe.levels]
    run_seeds = seeds if BASELINE_PART in parts else ()
    progress = Progress("probe", len(run_seeds) + len(levels), "run")
    measured = atmosphere is not None
    cache = ForwardCache()  # the products of the runs, reused where a probe leaves a record unchanged
    # the first seed's true state, reused by every measurement-stage probe (made here when the
    # conditions carry the measured lag, which is reproduced on it)
    base_lag, truth = simulated_sonic_ins_lag_s(campaign_data, flight_id, conditions, processing, seeds[0],
                                                atmosphere, cache=cache)
    if base_lag is not None:
        out["simulated_sonic_ins_lag_s"] = base_lag
        conditions = {**dict(conditions), "sonic_ins_lag_s": base_lag}
    for seed in run_seeds:
        with progress.item(f"flight {flight_id} baseline seed {seed}"):
            feats, products = run_forward(forward_manifest(campaign_data, flight_id, conditions, None, seed, measured),
                                          flight_id, processing, truth=truth if seed == seeds[0] else None,
                                          cache=cache, atmosphere=atmosphere, lag_drift=lag_drift, features=features)
        if seed == seeds[0]:
            truth = products["truth"]
            cache.freeze()
        # a run's products are not read again: freed before the next run, so that two runs'
        # datasets (and a height offset's own true state) are never held at once
        del products
        out["baseline"].append(features_to_dict(feats))
    if truth is None and any(shares_truth([{"mechanism": probe.mechanism}], measured) for probe, _ in levels):
        truth = payload_truth(forward_manifest(campaign_data, flight_id, conditions, None, seeds[0], measured),
                              flight_id, atmosphere)
    if truth is not None and atmosphere is not None:
        out["atmosphere_record"] = dict(truth.atmosphere_info)
    for probe, level in levels:
        name = f"flight {flight_id} {probe.candidate} {probe.parameter}={level:g}"
        params = _probe_parameters(probe, level)
        mech = [{"mechanism": probe.mechanism, "parameters": params}]
        reuse = truth if shares_truth(mech, measured) else None
        record = None if atmosphere is None else record_through(atmosphere, mech)
        try:
            with progress.item(name):
                feats = run_forward(forward_manifest(campaign_data, flight_id, conditions, mech, seeds[0], measured),
                                    flight_id, processing, truth=reuse, cache=cache, atmosphere=record,
                                    lag_drift=lag_drift, features=features, errors=False)[0]
        except InputError as exc:
            # a level outside what this flight allows (e.g. a height offset deeper than
            # the measured hover height): recorded and left out; the candidate's response
            # for this flight then has fewer levels (NaN where missing)
            progress.skipped(name, str(exc))
            out.setdefault("skipped_probes", []).append({"candidate": probe.candidate,
                                                         "parameter": probe.parameter, "level": float(level),
                                                         "reason": str(exc)})
            continue
        out["probes"].append({"candidate": probe.candidate, "mechanism": probe.mechanism,
                              "parameter": probe.parameter, "level": float(level),
                              "fixed": dict(probe.fixed), "features": features_to_dict(feats)})
    progress.finished()
    out["reused_products"] = {"hits": cache.hits, "misses": cache.misses}
    out["reused_steps"] = {"hits": cache.steps.hits, "misses": cache.steps.misses}
    return out


def simulated_sonic_ins_lag_s(campaign_data: Mapping[str, Any], flight_id: str, conditions: Mapping[str, Any],
                              processing: Mapping[str, Any], seed: int, atmosphere: xr.Dataset | None = None,
                              truth: PayloadTruth | None = None, cache: ForwardCache | None = None
                              ) -> tuple[float | None, PayloadTruth | None]:
    """The sonic-INS processing lag with which the forward chain finds the flight's measured lag.

    The chain's lag of minimum TKE (Ghirardelli et al. 2025, Sect. 3.3) is not the
    processing lag itself: the payload's attitude follows the wind (the drone banks into
    lateral gusts, the payload weathervanes), so shifting the INS against the sonic also
    removes part of the wind's own variance, and the minimum lies below the simulated lag
    (by 0.092 +- 0.033 s, mean and standard deviation over 60 flights of the hidden-effect
    campaign without a mechanism, 3.5-9.5 m s-1). Simulating the measured lag itself would
    shift the forward runs' lag by that much again. One step of a fixed-point iteration
    removes it: the first seed's flight is simulated with the measured lag :math:`\\ell_m`
    and its lag :math:`\\ell_f` found by the chain's lag search (lag only), and the runs take

    .. math:: \\ell_{sim} = \\ell_m - (\\ell_f - \\ell_m).

    On the search grid a whole number of lag steps moves the sonic's stamps and the TKE
    curve alike, so the first seed's baseline finds :math:`\\ell_m` again
    (``tests/test_forward_lag.py``); the other seeds differ by their own sampling error.

    Parameters
    ----------
    campaign_data, flight_id, conditions, processing
        As :func:`probe_runs`; the measured lag is ``conditions["sonic_ins_lag_s"]``
        (:func:`forward_conditions`).
    seed : int
        The first baseline seed (the probes' seed).
    atmosphere : xarray.Dataset, optional
        The measured atmosphere record (:func:`atmosphere_record`).
    truth : PayloadTruth, optional
        The seed's true state, if made already.
    cache : ForwardCache, optional
        The flight's cache: the INS L1 and the simulator's steps made here are those of the
        first baseline run, which then reuses them.

    Returns
    -------
    lag_s : float or None
        The processing lag to simulate [s], within the settings' range
        (:data:`dronewind.simulate.settings.SONIC_INS_LAG_RANGE_S`); None when the conditions
        carry no lag. The measured lag itself when the lag search fails on the simulated flight.
    truth : PayloadTruth or None
        The seed's true state (None when the conditions carry no lag and none was given).
    """
    from dronewind.simulate.payload import payload_records
    from dronewind.simulate.settings import SONIC_INS_LAG_RANGE_S

    if conditions.get("sonic_ins_lag_s") is None:
        return None, truth
    measured_lag = float(conditions["sonic_ins_lag_s"])
    manifest = forward_manifest(campaign_data, flight_id, conditions, None, seed, atmosphere is not None)
    cache = ForwardCache() if cache is None else cache
    with reusing(cache.steps):
        records, truth = payload_records(manifest, flight_id, truth, atmosphere)
        ins_table, ins_l1 = cache.get("ins_l1", [records[1]], lambda: compute_ins_l1(records[1]))
        sonic_l1 = compute_sonic_l1(records[0], records[1], ins_table, processing["despike"])
        flight = next(f for f in manifest["payload_flights"] if f["id"] == flight_id)
        lag = {key: processing[key] for key in LAG_SETTINGS}
        try:
            l2 = compute_payload_l2(sonic_l1, ins_l1, flight, float(manifest["site"]["altitude_m"]), lag_only=True,
                                    **lag)
        except InputError as exc:
            LOG.warning("flight %s: the forward runs simulate the measured lag %+.5f s (lag search failed: %s)",
                        flight_id, measured_lag, exc)
            return measured_lag, truth
    found = _measured_lag_s(l2)
    if found is None:
        return measured_lag, truth
    lo, hi = SONIC_INS_LAG_RANGE_S
    return float(min(max(2.0 * measured_lag - found, lo), hi)), truth


def shares_truth(mechanisms: Sequence[Mapping[str, Any]], measured: bool) -> bool:
    """Whether a run with these mechanisms has the true state of a run without them (same seed).

    True when every mechanism acts on the measurement only: none moves the hover point
    (:data:`TRUTH_MECHANISMS`) and, with a measured atmosphere, none is undone on the
    reference record (:data:`RECORD_INVERSES`), which constrains the field. Such a run can
    take the other run's :class:`~dronewind.simulate.payload.PayloadTruth` and its
    :class:`ForwardCache` (common random numbers: the records and products it shares are
    bit-identical to those it would make itself).

    Parameters
    ----------
    mechanisms : sequence of mapping
        ``[{"mechanism": name, "parameters": {...}}]``.
    measured : bool
        The runs take the measured atmosphere (``diagnosis.atmosphere: measured``).

    Returns
    -------
    bool
    """
    names = {m["mechanism"] for m in mechanisms}
    return not names & (TRUTH_MECHANISMS | (set(RECORD_INVERSES) if measured else set()))


def merge_probe_runs(parts: Sequence[Mapping[str, Any]], probes: tuple[Probe, ...] = PROBES) -> dict[str, Any]:
    """Join the parts of one flight's forward runs (:func:`probe_runs` with ``parts``) into one.

    Parameters
    ----------
    parts : sequence of dict
        Outputs of :func:`probe_runs` for the same flight, conditions and seeds, each part
        once, together covering :func:`probe_parts`.
    probes : tuple of Probe
        The probes the parts were run with (their order is the order of the result).

    Returns
    -------
    dict
        What :func:`probe_runs` returns for all parts in one run (``reused_products``
        summed over the parts).

    Raises
    ------
    InputError
        Parts of other flights, conditions or seeds, a part twice or a part missing.
    """
    if not parts:
        raise InputError("parts", "no forward-run parts to merge")
    first = parts[0]
    names: list[str] = []
    for part in parts:
        for key in ("flight", "conditions", "seeds", "atmosphere", "lag_drift", "features",
                    "simulated_sonic_ins_lag_s"):
            if part.get(key) != first.get(key):
                raise InputError(f"parts: {key}", f"forward-run parts disagree on {key}: {part.get(key)!r} and "
                                 f"{first.get(key)!r}")
        names += list(part["parts"])
    if sorted(names) != sorted(probe_parts(probes)):
        raise InputError("parts", f"forward-run parts {sorted(names)}; expected each of {list(probe_parts(probes))} "
                         "once")
    order = {(p.candidate, p.parameter, float(level)): k for k, (p, level) in
             enumerate((p, level) for p in probes for level in p.levels)}
    out: dict[str, Any] = {"flight": first["flight"], "conditions": first["conditions"], "seeds": first["seeds"],
                           "atmosphere": first.get("atmosphere"), "lag_drift": first.get("lag_drift", True),
                           "features": first.get("features", list(FEATURES)), "parts": list(probe_parts(probes)),
                           "baseline": next(p["baseline"] for p in parts if BASELINE_PART in p["parts"]),
                           "probes": sorted((r for p in parts for r in p["probes"]),
                                            key=lambda r: order[(r["candidate"], r["parameter"], float(r["level"]))])}
    skipped = sorted((r for p in parts for r in p.get("skipped_probes", [])),
                     key=lambda r: order[(r["candidate"], r["parameter"], float(r["level"]))])
    if skipped:
        out["skipped_probes"] = skipped
    records = [p["atmosphere_record"] for p in parts if "atmosphere_record" in p]
    if records:
        out["atmosphere_record"] = records[0]
    if "simulated_sonic_ins_lag_s" in first:
        out["simulated_sonic_ins_lag_s"] = first["simulated_sonic_ins_lag_s"]
    for key in ("reused_products", "reused_steps"):
        out[key] = {k: sum(int(p.get(key, {}).get(k, 0)) for p in parts) for k in ("hits", "misses")}
    return out


def _other_parameters(mechanism: str, parameter: str) -> list[str]:
    from dronewind.mechanisms import get_mechanism

    return [p for p in get_mechanism(mechanism).parameter_names if p != parameter]


def _undo_mast_w_attenuation(record: xr.Dataset, parameters: Mapping[str, float]) -> xr.Dataset:
    """The measured mast record with ``mast_w_attenuation`` undone: w divided by the gain."""
    out = record.copy()
    out["w_up_ms"] = record["w_up_ms"] / float(parameters["gain"])
    return out


#: Mechanisms acting on the reference mast's record, and how each is undone on a measured
#: record to give the true wind at the mast (:func:`probe_runs` with a measured atmosphere).
RECORD_INVERSES: dict[str, Callable[[xr.Dataset, Mapping[str, float]], xr.Dataset]] = {
    "mast_w_attenuation": _undo_mast_w_attenuation,
}


def record_through(record: xr.Dataset, mechanisms: Sequence[Mapping[str, Any]]) -> xr.Dataset:
    """The measured atmosphere record read through the mechanisms that act on it.

    Parameters
    ----------
    record : xarray.Dataset
        :func:`atmosphere_record` output.
    mechanisms : sequence of mapping
        ``[{"mechanism": name, "parameters": {...}}]`` (e.g. the named causes of an extended
        model).

    Returns
    -------
    xarray.Dataset
        The record with each mechanism of :data:`RECORD_INVERSES` undone (the true wind the
        mast would have measured without it); the record itself when none acts on it.
    """
    for m in mechanisms:
        if m["mechanism"] in RECORD_INVERSES:
            record = RECORD_INVERSES[m["mechanism"]](record, m["parameters"])
    return record


#: Variables of the reference mast's record that the forward runs' atmosphere takes (the
#: temperature optional).
ATMOSPHERE_VARIABLES: tuple[str, ...] = ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k")
#: Margin kept around the hover window when the measured record is cut (:func:`atmosphere_record`) [s].
ATMOSPHERE_MARGIN_S = 3600.0


def hover_span(conditions: Mapping[str, Any]) -> tuple[np.datetime64, np.datetime64]:
    """Start and end of a flight's measured hover window (``start``, ``duration_s`` of :func:`forward_conditions`).

    Returns
    -------
    tuple of numpy.datetime64
        UTC, microsecond resolution.
    """
    start = parse_utc(str(conditions["start"]), "conditions.start")
    return start, start + np.timedelta64(int(round(float(conditions["duration_s"]) * 1e6)), "us")


def atmosphere_window(conditions: Mapping[str, Any]) -> slice:
    """The times of the reference mast's record that :func:`atmosphere_record` keeps: the hover
    window and :data:`ATMOSPHERE_MARGIN_S` on either side (a ``slice`` of datetime64)."""
    start, end = hover_span(conditions)
    margin = np.timedelta64(int(ATMOSPHERE_MARGIN_S * 1e6), "us")
    return slice(start - margin, end + margin)


def atmosphere_record(mast: xr.Dataset, conditions: Mapping[str, Any], where: str = "mast record") -> xr.Dataset:
    """The reference mast's measured record of one flight, as the forward runs' atmosphere.

    Parameters
    ----------
    mast : xarray.Dataset
        The reference sonic's L1 (or L2): ``u_east_ms``, ``v_north_ms``, ``w_up_ms`` and
        optionally ``t_sonic_k`` on a datetime64 ``time`` axis.
    conditions : mapping
        The flight's forward conditions (:func:`forward_conditions`: ``start``,
        ``duration_s``).
    where : str
        Name of the record in errors (its file).

    Returns
    -------
    xarray.Dataset
        Those variables within :data:`ATMOSPHERE_MARGIN_S` of the hover window (a shorter
        record is cut again by the simulator, which mirrors it where the forward flight's
        span reaches beyond it, :func:`dronewind.simulate.payload_wind.measured_constraint`),
        with attributes ``noise_ms`` and ``temperature_noise_k``: the white noise of the
        forward model's CSAT3 (``simulation.mast`` defaults), which the record holds and
        the forward mast does not add again (:func:`forward_manifest`).

    Raises
    ------
    InputError
        Variables or the time axis missing.
    """
    from dronewind.simulate.payload_wind import check_atmosphere_record
    from dronewind.simulate.settings import MAST_DEFAULTS

    check_atmosphere_record(mast, where)
    names = [v for v in ATMOSPHERE_VARIABLES if v in mast]

    cut = mast[names].sel(time=atmosphere_window(conditions))
    cut = cut.drop_vars([c for c in cut.coords if c != "time"])
    cut.attrs = {"noise_ms": MAST_DEFAULTS["noise_ms"][0],
                 "temperature_noise_k": MAST_DEFAULTS["temperature_noise_k"][0]}
    return cut
