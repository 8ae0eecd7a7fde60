r"""The forward model of a measured payload flight, and its response to each mechanism.

For one flight of a campaign (measured or virtual, it does not matter), the conditions
the simulator needs are taken from the *processed data*: the reference mast's mean wind,
direction, temperature, friction velocity and Obukhov length at its height, the drone's
hover height, position relative to the mast and hover window. Nothing is read from the
campaign's own ``simulation:`` section (for a virtual campaign that would be reading the
answer). The flight is then simulated without any mechanism (the *baseline*, with two
seeds) and with each catalog mechanism at a few *probe levels* (common random numbers:
the first baseline seed), written as raw files, and pushed through the same processing
functions as the measured flight (:mod:`dronewind.steps.payload`), ending in the
residual features of :mod:`dronewind.diagnose.features`.

Probe levels are chosen inside each mechanism's physical range, large enough to rise above
sampling noise and small enough that the response stays smooth (it is interpolated
piecewise-linearly between levels and the baseline, see
:mod:`dronewind.diagnose.fitting`).
"""

from __future__ import annotations

import copy
import math
import shutil
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dronewind.diagnose.features import FlightFeatures, flight_features
from dronewind.errors import InputError
from dronewind.steps import payload as chain
from dronewind.steps.common import LOG

__all__ = ["Probe", "PROBES", "MECHANISM_BASELINES", "forward_conditions", "forward_manifest",
           "measured_features", "run_forward", "lag_halves", "probe_runs"]

KARMAN = 0.40


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

#: The probes of every payload/mast mechanism of the catalog (DESIGN.md).
PROBES: tuple[Probe, ...] = (
    Probe("sonic_ins_lag", "sonic_ins_lag", "lag_s", (-0.3, 0.3)),
    Probe("clock_drift", "clock_drift", "ppm", (300.0,)),
    Probe("mount_misalignment", "mount_misalignment", "roll_deg", (4.0,)),
    Probe("mount_misalignment", "mount_misalignment", "pitch_deg", (4.0,)),
    Probe("mount_misalignment", "mount_misalignment", "yaw_deg", (6.0,)),
    Probe("heading_bias", "heading_bias", "deg", (6.0,)),
    Probe("attitude_lag", "attitude_lag", "lag_s", (0.1, 0.3)),
    Probe("lever_arm", "lever_arm", "x_m", (0.6,)),
    Probe("lever_arm", "lever_arm", "y_m", (0.6,)),
    Probe("lever_arm", "lever_arm", "z_m", (0.6,)),
    Probe("w_gain", "w_gain", "gain", (0.85, 1.2)),
    Probe("sonic_noise", "sonic_noise", "sigma_ms", (0.15, 0.35)),
    Probe("height_offset", "height_offset", "dz_m", (6.0, 15.0)),
    Probe("downwash@u_scale_ms=3", "downwash", "w0_ms", (1.0,), (("u_scale_ms", 3.0),)),
    Probe("downwash@u_scale_ms=8", "downwash", "w0_ms", (1.0,), (("u_scale_ms", 8.0),)),
    Probe("mast_w_attenuation", "mast_w_attenuation", "gain", (0.85,)),
)


def baseline_level(mechanism: str, parameter: str) -> float:
    """Parameter value at which a mechanism is off."""
    return MECHANISM_BASELINES.get((mechanism, parameter), 0.0)


def _psi_m(zeta: float) -> float:
    from dronewind.simulate.atmosphere import psi_m

    return float(psi_m(zeta))


def forward_conditions(
    campaign_data: Mapping[str, Any],
    flight_id: str,
    l3: Any,
    l2_drone: Any,
) -> dict[str, Any]:
    """Simulator conditions of one flight, estimated from its processed data.

    Parameters
    ----------
    campaign_data : mapping
        Manifest content of the campaign.
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
        ``roughness_length_m``, ``theta_mean_k``.

    Notes
    -----
    The roughness length follows from Monin-Obukhov similarity at the mast height,

    .. math:: z_0 = z \\exp\\left(-\\frac{\\kappa \\bar u}{u_*} - \\psi_m(z/L)\\right),

    clipped to [0.001, 2] m; the Obukhov length is Eq. 9 of seed 000 with the mast's
    fluxes, limited to :math:`|L| \\ge 1` m and :math:`|z/L| \\le 5`.
    """
    from dronewind.core import stats
    from dronewind.core.geo import local_tangent_plane_m

    sensors = list(np.asarray(l3["sensor"].values).astype(str))
    m = sensors.index("mast")
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
    z0 = z * math.exp(-(KARMAN * speed / ustar) - _psi_m(zeta))
    z0 = float(min(max(z0, 1e-3), 2.0))

    site = campaign_data["site"]
    flight = next(f for f in campaign_data["payload_flights"] if f["id"] == flight_id)
    mast_lat, mast_lon = site["latitude"], site["longitude"]
    for mast in campaign_data.get("masts") or []:
        if any(s["id"] == flight["reference"] for s in mast["sonics"]):
            mast_lat, mast_lon = mast.get("latitude", mast_lat), mast.get("longitude", mast_lon)
    lat = float(np.nanmedian(l2_drone["lat_deg"].values))
    lon = float(np.nanmedian(l2_drone["lon_deg"].values))
    east, north = local_tangent_plane_m(np.array([lat]), np.array([lon]), mast_lat, mast_lon)
    times = l2_drone["time"].values
    height = float(l2_drone.attrs.get("height_m", flight.get("target_height_m", z)))
    return {
        "mean_speed_ms": float(min(max(speed, 0.05), 40.0)),
        "wind_from_deg": float(l3["wind_from_deg"].values[m]) % 360.0,
        "obukhov_length_m": "inf" if math.isinf(ell) else float(ell),
        "z_ref_m": z,
        "hover_height_m": float(max(height, 3.0)),
        "start": np.datetime_as_string(times[0], unit="us") + "Z",
        "duration_s": float((times[-1] - times[0]) / np.timedelta64(1, "us") * 1e-6),
        "hover_offset_enu_m": [float(east[0]), float(north[0])],
        "roughness_length_m": z0,
        "theta_mean_k": float(min(max(theta_mean, 221.0), 329.0)),
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
        Manifest content of the measured campaign (its ``simulation:`` section, if any,
        is dropped).
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
        Manifest content with one payload flight, its reference mast sonic and a
        ``simulation:`` section.
    """
    data = {k: copy.deepcopy(v) for k, v in campaign_data.items() if k not in ("simulation", "quadrotor_flights",
                                                                              "tunnel")}
    flight = copy.deepcopy(next(f for f in campaign_data["payload_flights"] if f["id"] == flight_id))
    flight.pop("window", None)
    data["payload_flights"] = [flight]
    masts = []
    for mast in campaign_data.get("masts") or []:
        sonics = [copy.deepcopy(s) for s in mast["sonics"] if s["id"] == flight["reference"]]
        if sonics:
            masts.append({**copy.deepcopy(mast), "sonics": sonics})
    data["masts"] = masts
    data["name"] = f"{campaign_data['name']}_forward_{flight_id}"
    data["simulation"] = {
        "seed": int(seed),
        "payload_flights": {flight_id: dict(conditions)},
        "mechanisms": [dict(m) for m in (mechanisms or [])],
    }
    return data


def lag_halves(sonic_l1: Any, ins_l1: Any, l2: Any, flight: Mapping[str, Any], site_altitude_m: float,
               config: Mapping[str, Any]) -> tuple[float, float]:
    """Sonic-INS lags found on the first and the second half of the hover window [s]."""
    times = l2["time"].values
    mid = times[0] + (times[-1] - times[0]) / 2
    cfg = copy.deepcopy(dict(config))
    cfg.setdefault("processing", {}).setdefault("hover", {})["min_duration_s"] = 0.0
    out = []
    for a, b in ((times[0], mid), (mid, times[-1])):
        half = dict(flight)
        half["window"] = {"start": np.datetime_as_string(a, unit="us") + "Z",
                          "end": np.datetime_as_string(b, unit="us") + "Z"}
        try:
            ds = chain.compute_payload_l2(sonic_l1, ins_l1, half, site_altitude_m, cfg)
            out.append(float(ds.attrs["lag_sonic_ins_s"]))
        except Exception as exc:  # a half without a hover: the feature is then missing
            LOG.warning("lag of half window %s-%s failed: %s", a, b, exc)
            out.append(float("nan"))
    return out[0], out[1]


def measured_features(campaign_data: Mapping[str, Any], flight_id: str, sonic_l1: Any, ins_l1: Any, l2: Any,
                      l3: Any, config: Mapping[str, Any]) -> FlightFeatures:
    """Residual features of one flight from its processed products (in memory)."""
    flight = next(f for f in campaign_data["payload_flights"] if f["id"] == flight_id)
    step = float(config.get("processing", {}).get("sonic_ins_lag", {}).get("step_s", 1 / 32))
    halves = lag_halves(sonic_l1, ins_l1, l2, flight, float(campaign_data["site"]["altitude_m"]), config)
    return flight_features(l3, l2, lag_halves_s=halves, lag_step_s=step)


def run_forward(
    manifest: Mapping[str, Any],
    flight_id: str,
    config: Mapping[str, Any],
    work_dir: str | Path | None = None,
) -> tuple[FlightFeatures, dict[str, Any]]:
    """Simulate one flight of a forward manifest, process it as measured data, return its features.

    Parameters
    ----------
    manifest : mapping
        Output of :func:`forward_manifest`.
    flight_id : str
        Payload flight id.
    config : mapping
        Workflow configuration (processing options, the same as for the measured data).
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
    folder = Path(tempfile.mkdtemp(prefix="dronewind_forward_")) if own else Path(work_dir)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        paths = simulate_payload_flight(dict(manifest), folder, flight_id, folder)
        flight = next(f for f in manifest["payload_flights"] if f["id"] == flight_id)
        sonic_file, ins_file = folder / flight["sonic"]["file"], folder / flight["ins"]["file"]
        mast_files = [p for p in paths if p not in (sonic_file, ins_file)]
        sonic_info = next(s for m in manifest["masts"] for s in m["sonics"] if s["id"] == flight["reference"])
        sonic_l1, ins_l1 = chain.compute_payload_l1(sonic_file, ins_file, config)
        l2 = chain.compute_payload_l2(sonic_l1, ins_l1, flight, float(manifest["site"]["altitude_m"]), config)
        mast_l1 = chain.compute_mast_l1(mast_files, sonic_info, config)
        mast_l2 = chain.compute_mast_l2(mast_l1, l2, flight_id, config, source="forward mast")
        l3 = chain.compute_l3(l2, mast_l2, flight, config)
        features = measured_features(manifest, flight_id, sonic_l1, ins_l1, l2, l3, config)
        return features, {"l2": l2, "l3": l3}
    finally:
        if own:
            shutil.rmtree(folder, ignore_errors=True)


def probe_runs(
    campaign_data: Mapping[str, Any],
    flight_id: str,
    conditions: Mapping[str, Any],
    config: Mapping[str, Any],
    seeds: tuple[int, ...] = (101, 202),
    probes: tuple[Probe, ...] = PROBES,
) -> dict[str, Any]:
    """Baseline and probe runs of the forward model for one flight.

    Parameters
    ----------
    campaign_data : mapping
        Manifest content of the measured campaign.
    flight_id : str
        Payload flight id.
    conditions : mapping
        Output of :func:`forward_conditions`.
    config : mapping
        Workflow configuration.
    seeds : tuple of int
        Baseline seeds; the first one is also used for every probe run (common random
        numbers, so a probe's difference to that baseline is the mechanism's effect).
    probes : tuple of Probe
        Probes to run.

    Returns
    -------
    dict
        ``{"baseline": [features per seed], "probes": [{candidate, mechanism,
        parameter, level, fixed, features}]}`` with features as
        :func:`~dronewind.diagnose.features.features_to_dict` dictionaries.
    """
    from dronewind.diagnose.features import features_to_dict

    out: dict[str, Any] = {"flight": flight_id, "conditions": dict(conditions), "seeds": list(seeds),
                           "baseline": [], "probes": []}
    for seed in seeds:
        feats, _ = run_forward(forward_manifest(campaign_data, flight_id, conditions, None, seed), flight_id, config)
        out["baseline"].append(features_to_dict(feats))
        LOG.info("flight %s: baseline seed %d done", flight_id, seed)
    for probe in probes:
        for level in probe.levels:
            params = {probe.parameter: float(level)}
            for name in _other_parameters(probe.mechanism, probe.parameter):
                params[name] = dict(probe.fixed).get(name, baseline_level(probe.mechanism, name))
            mech = [{"mechanism": probe.mechanism, "parameters": params}]
            try:
                feats, _ = run_forward(forward_manifest(campaign_data, flight_id, conditions, mech, seeds[0]),
                                       flight_id, config)
            except InputError as exc:
                # a level outside what this flight allows (e.g. a height offset deeper than
                # the measured hover height): recorded and left out; the candidate's response
                # for this flight then has fewer levels (NaN where missing)
                LOG.warning("flight %s: probe %s %s=%g skipped: %s", flight_id, probe.candidate, probe.parameter,
                            level, exc)
                out.setdefault("skipped_probes", []).append({"candidate": probe.candidate,
                                                             "parameter": probe.parameter, "level": float(level),
                                                             "reason": str(exc)})
                continue
            out["probes"].append({"candidate": probe.candidate, "mechanism": probe.mechanism,
                                  "parameter": probe.parameter, "level": float(level),
                                  "fixed": dict(probe.fixed), "features": features_to_dict(feats)})
            LOG.info("flight %s: %s %s=%g done", flight_id, probe.candidate, probe.parameter, level)
    return out


def _other_parameters(mechanism: str, parameter: str) -> list[str]:
    from dronewind.mechanisms import get_mechanism

    return [p for p in get_mechanism(mechanism).parameter_names if p != parameter]
