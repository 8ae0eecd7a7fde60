r"""The forward model of a measured payload flight, and its response to each mechanism.

For one flight of a campaign (measured or virtual, it does not matter), the conditions
the simulator needs are taken from the *processed data*: the reference mast's mean wind,
direction, temperature, friction velocity and Obukhov length at its height, the drone's
hover height, position relative to the mast and hover window. Nothing is read from the
campaign's own ``simulation:`` section (for a virtual campaign that would be reading the
answer). The flight is then simulated without any mechanism (the *baseline*, with two
seeds) and with each catalog mechanism at a few *probe levels* (common random numbers:
the first baseline seed), written as raw files, and pushed through the same chain
functions as the measured flight (:mod:`dronewind.payload.chain`,
:mod:`dronewind.mast.chain`, :mod:`dronewind.compare.chain`), ending in the residual
features of :mod:`dronewind.diagnose.features`.

Settings: the functions that run the chain take ``processing``, the ``processing`` section
of the workflow configuration (at least the keys of :data:`CHAIN_SETTINGS`; defaults from
:func:`dronewind.manifest.default_config`), the same as for the measured flight.

Probe levels are chosen inside each mechanism's physical range, large enough to rise above
sampling noise and small enough that the response stays smooth (it is interpolated
piecewise-linearly between levels and the baseline, see
:mod:`dronewind.diagnose.fitting`).
"""

from __future__ import annotations

import logging
import math
import shutil
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import xarray as xr

from dronewind.compare.chain import compute_l3
from dronewind.core.constants import KARMAN
from dronewind.core.progress import Progress
from dronewind.diagnose.features import FlightFeatures, flight_features
from dronewind.errors import InputError
from dronewind.manifest import payload_flight_manifest
from dronewind.mast.chain import compute_mast_l1, compute_mast_l2
from dronewind.payload.chain import compute_payload_l1, compute_payload_l2

__all__ = ["Probe", "PROBES", "MECHANISM_BASELINES", "CHAIN_SETTINGS", "LAG_SETTINGS", "forward_conditions",
           "forward_manifest", "measured_features", "run_forward", "lag_halves", "probe_runs"]

LOG = logging.getLogger("dronewind")

#: Keys of ``processing`` that the chain up to L3 uses (what a forward run depends on).
CHAIN_SETTINGS: tuple[str, ...] = ("despike", "max_missing_fraction", "hover", "sonic_ins_lag", "drone_mast",
                                   "rotation")
#: Keys of ``processing`` that the sonic-INS lag feature uses (:func:`measured_features`).
LAG_SETTINGS: tuple[str, ...] = ("sonic_ins_lag", "hover", "max_missing_fraction")


@dataclass(frozen=True)
class Probe:
    """One parameter of one candidate and the levels at which its response is simulated.

    Attributes
    ----------
    candidate : str
        Candidate name (the catalog name, or ``name@setting`` for a variant with a fixed
        second parameter, e.g. ``downwash@u_scale_ms=3``).
    mechanism : str
        Catalog name.
    parameter : str
        The fitted parameter.
    levels : tuple of float
        Probe levels (the baseline level is added automatically).
    fixed : dict
        Parameters held fixed for this candidate.
    """

    candidate: str
    mechanism: str
    parameter: str
    levels: tuple[float, ...]
    fixed: tuple[tuple[str, float], ...] = ()


#: Level of each fitted parameter at which its mechanism is off.
MECHANISM_BASELINES: dict[tuple[str, str], float] = {
    ("w_gain", "gain"): 1.0,
    ("mast_w_attenuation", "gain"): 1.0,
}

#: The probes of every payload/mast mechanism of the catalog (DESIGN.md). A parameter that can
#: take either sign about its baseline (a lag, an angle, an offset, a gain about 1) is probed on
#: both sides, so that the response of an even (e.g. quadratic) feature is never extrapolated
#: from one side to the other; the fit bounds are the catalog's physical range
#: (:mod:`dronewind.mechanisms`), not the probe span.
PROBES: tuple[Probe, ...] = (
    Probe("sonic_ins_lag", "sonic_ins_lag", "lag_s", (-0.3, 0.3)),
    Probe("clock_drift", "clock_drift", "ppm", (-300.0, 300.0)),
    Probe("mount_misalignment", "mount_misalignment", "roll_deg", (-4.0, 4.0)),
    Probe("mount_misalignment", "mount_misalignment", "pitch_deg", (-4.0, 4.0)),
    Probe("mount_misalignment", "mount_misalignment", "yaw_deg", (-6.0, 6.0)),
    Probe("heading_bias", "heading_bias", "deg", (-8.0, 8.0)),
    Probe("attitude_lag", "attitude_lag", "lag_s", (0.1, 0.3)),
    Probe("lever_arm", "lever_arm", "x_m", (-0.6, 0.6)),
    Probe("lever_arm", "lever_arm", "y_m", (-0.6, 0.6)),
    Probe("lever_arm", "lever_arm", "z_m", (-0.6, 0.6)),
    Probe("w_gain", "w_gain", "gain", (0.85, 1.2)),
    Probe("sonic_noise", "sonic_noise", "sigma_ms", (0.15, 0.35)),
    Probe("height_offset", "height_offset", "dz_m", (-6.0, 6.0, 15.0)),
    Probe("downwash@u_scale_ms=3", "downwash", "w0_ms", (1.0,), (("u_scale_ms", 3.0),)),
    Probe("downwash@u_scale_ms=8", "downwash", "w0_ms", (1.0,), (("u_scale_ms", 8.0),)),
    Probe("mast_w_attenuation", "mast_w_attenuation", "gain", (0.85, 1.1)),
)


def baseline_level(mechanism: str, parameter: str) -> float:
    """Parameter value at which a mechanism is off."""
    return MECHANISM_BASELINES.get((mechanism, parameter), 0.0)


def _psi_m(zeta: float) -> float:
    from dronewind.simulate.atmosphere import psi_m

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
        at least 0.02 m s-1, the Obukhov length (seed 000, Eq. 9) infinite beyond 1e5 m and
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
        :func:`mast_surface_layer`, the roughness length from :func:`roughness_length_m`.
    """
    layer = mast_surface_layer(l3)
    m = list(np.asarray(l3["sensor"].values).astype(str)).index("mast")
    flight = next(f for f in campaign_data["payload_flights"] if f["id"] == flight_id)
    east, north = hover_offset_enu_m(campaign_data, flight, l2_drone)
    times = l2_drone["time"].values
    height = float(l2_drone.attrs.get("height_m", flight.get("target_height_m", layer.z_m)))
    ell = layer.obukhov_length_m
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
    }


def forward_manifest(
    campaign_data: Mapping[str, Any],
    flight_id: str,
    conditions: Mapping[str, Any],
    mechanisms: list[dict[str, Any]] | None = None,
    seed: int = 0,
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

    Returns
    -------
    dict
        Manifest content with one payload flight (without its ``window``), its reference
        mast sonic (:func:`dronewind.manifest.payload_flight_manifest`) and a
        ``simulation:`` section.
    """
    data = payload_flight_manifest(campaign_data, flight_id)
    data["payload_flights"][0].pop("window", None)
    data["name"] = f"{campaign_data['name']}_forward_{flight_id}"
    data["simulation"] = {
        "seed": int(seed),
        "payload_flights": {flight_id: dict(conditions)},
        "mechanisms": [dict(m) for m in (mechanisms or [])],
    }
    return data


def lag_halves(sonic_l1: xr.Dataset, ins_l1: xr.Dataset, l2: xr.Dataset, flight: Mapping[str, Any],
               site_altitude_m: float, *, sonic_ins_lag: Mapping[str, Any], hover: Mapping[str, Any],
               max_missing_fraction: float) -> tuple[float, float]:
    """Sonic-INS lags found on the first and the second half of the hover window [s].

    Each half is processed to L2 as a window of its own, without the minimum hover duration.

    Parameters
    ----------
    sonic_l1, ins_l1, l2 : xarray.Dataset
        The flight's payload sonic and INS L1, and its L2 (the hover window).
    flight : mapping
        The flight's manifest entry.
    site_altitude_m : float
        Ground altitude of the site [m].
    sonic_ins_lag, hover, max_missing_fraction
        ``processing`` settings of :func:`dronewind.payload.chain.compute_payload_l2`.

    Returns
    -------
    tuple of float
        Lags of the two halves [s]; NaN for a half without a hover.
    """
    times = l2["time"].values
    mid = times[0] + (times[-1] - times[0]) / 2
    half_hover = {**hover, "min_duration_s": 0.0}
    out = []
    for a, b in ((times[0], mid), (mid, times[-1])):
        half = dict(flight)
        half["window"] = {"start": np.datetime_as_string(a, unit="us") + "Z",
                          "end": np.datetime_as_string(b, unit="us") + "Z"}
        try:
            ds = compute_payload_l2(sonic_l1, ins_l1, half, site_altitude_m, sonic_ins_lag=sonic_ins_lag,
                                    hover=half_hover, max_missing_fraction=max_missing_fraction)
            out.append(float(ds.attrs["lag_sonic_ins_s"]))
        except Exception as exc:  # a half without a hover: the feature is then missing
            LOG.warning("lag of half window %s-%s failed: %s", a, b, exc)
            out.append(float("nan"))
    return out[0], out[1]


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


def process_forward_flight(manifest: Mapping[str, Any], flight_id: str, folder: Path, paths: list[Path],
                           processing: Mapping[str, Any]) -> tuple[FlightFeatures, dict[str, Any]]:
    """Process the raw files of a simulated forward flight like measured data, up to its features.

    Parameters
    ----------
    manifest : mapping
        The forward manifest (:func:`forward_manifest`).
    flight_id : str
        Payload flight id.
    folder : Path
        Folder of the raw files.
    paths : list of Path
        Files the simulator wrote (sonic, INS, then the mast records).
    processing : mapping
        ``processing`` settings (keys of :data:`CHAIN_SETTINGS`).

    Returns
    -------
    features : FlightFeatures
    products : dict
        ``{"l2": ..., "l3": ...}`` datasets.
    """
    flight = next(f for f in manifest["payload_flights"] if f["id"] == flight_id)
    sonic_file, ins_file = folder / flight["sonic"]["file"], folder / flight["ins"]["file"]
    mast_files = [p for p in paths if p not in (sonic_file, ins_file)]
    sonic_info = next(s for m in manifest["masts"] for s in m["sonics"] if s["id"] == flight["reference"])
    lag = {key: processing[key] for key in LAG_SETTINGS}
    sonic_l1, ins_l1 = compute_payload_l1(sonic_file, ins_file, processing["despike"])
    l2 = compute_payload_l2(sonic_l1, ins_l1, flight, float(manifest["site"]["altitude_m"]), **lag)
    mast_l1 = compute_mast_l1(mast_files, sonic_info, processing["despike"])
    mast_l2 = compute_mast_l2(mast_l1, l2, flight_id, processing["drone_mast"], source="forward mast")
    l3 = compute_l3(l2, mast_l2, flight, processing["drone_mast"], processing["rotation"])
    features = measured_features(manifest, flight_id, sonic_l1, ins_l1, l2, l3, **lag)
    return features, {"l2": l2, "l3": l3}


def run_forward(
    manifest: Mapping[str, Any],
    flight_id: str,
    processing: Mapping[str, Any],
    work_dir: str | Path | None = None,
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
        Folder for the raw files (a temporary folder, removed afterwards, by default).

    Returns
    -------
    features : FlightFeatures
        Residual features of the simulated flight.
    products : dict
        ``{"l2": ..., "l3": ...}`` datasets (for reports).
    """
    from dronewind.simulate.payload import simulate_payload_flight

    own = work_dir is None
    folder = Path(tempfile.mkdtemp(prefix="dronewind_forward_")) if own else Path(str(work_dir))
    try:
        folder.mkdir(parents=True, exist_ok=True)
        paths = simulate_payload_flight(dict(manifest), folder, flight_id, folder)
        return process_forward_flight(manifest, flight_id, folder, paths, processing)
    finally:
        if own:
            shutil.rmtree(folder, ignore_errors=True)


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

    Returns
    -------
    dict
        ``{"baseline": [features per seed], "probes": [{candidate, mechanism,
        parameter, level, fixed, features}]}`` with features as
        :func:`~dronewind.diagnose.features.features_to_dict` dictionaries; probe levels a
        flight cannot take are listed in ``skipped_probes``.
    """
    from dronewind.diagnose.features import features_to_dict

    out: dict[str, Any] = {"flight": flight_id, "conditions": dict(conditions), "seeds": list(seeds),
                           "baseline": [], "probes": []}
    levels = [(probe, level) for probe in probes for level in probe.levels]
    progress = Progress("probe", len(seeds) + len(levels), "run")
    for seed in seeds:
        with progress.item(f"flight {flight_id} baseline seed {seed}"):
            feats, _ = run_forward(forward_manifest(campaign_data, flight_id, conditions, None, seed), flight_id,
                                   processing)
        out["baseline"].append(features_to_dict(feats))
    for probe, level in levels:
        name = f"flight {flight_id} {probe.candidate} {probe.parameter}={level:g}"
        mech = [{"mechanism": probe.mechanism, "parameters": _probe_parameters(probe, level)}]
        try:
            with progress.item(name):
                feats, _ = run_forward(forward_manifest(campaign_data, flight_id, conditions, mech, seeds[0]),
                                       flight_id, processing)
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
    return out


def _other_parameters(mechanism: str, parameter: str) -> list[str]:
    from dronewind.mechanisms import get_mechanism

    return [p for p in get_mechanism(mechanism).parameter_names if p != parameter]
