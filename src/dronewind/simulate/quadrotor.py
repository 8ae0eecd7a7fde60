r"""Virtual SWUF-3D quadrotor fleet flights and the tower reference (Wetz et al. 2021).

Forward model of a hovering quadrotor (its physics in :mod:`dronewind.simulate.airframe`,
independent of the processing chain's inversion in :mod:`dronewind.quadrotor`):

1. the wind at the UAV's hover point (from :func:`dronewind.simulate.atmosphere.simulate_wind`,
   or any function with the same signature) minus the vehicle's own velocity gives the
   air velocity relative to the vehicle;
2. ``response_lag``: the attitude follows that relative velocity through a first-order
   lag with time constant ``tau_s`` (the quasi-steady inverse model ignores inertia);
3. the drag balance gives the tilt (Wetz et al. 2021, Eqs. 12-17, ``rayleigh``; or, with the
   ``drag_regime`` mechanism, a power law per speed range as in Kistner et al. (2024), Table 2:
   :math:`a = (U/c_k)^{1/b_k}`, :math:`\sin\gamma = a/g`), leaning into the wind;
4. weather-vane mode: the heading turns towards the (lagged) relative wind direction
   with time constant ``weathervane.tau_s``, but only while the roll exceeds
   ``weathervane.min_roll_deg`` (PX4's threshold, Wetz et al. (2021) Sect. 2: 1 degree);
   roll and pitch follow from tilt and lean direction relative to the nose;
5. logged attitude = true + ``pitch_offset``/``yaw_offset`` (logged minus true) + white
   noise; the hover position wanders (Ornstein-Uhlenbeck, standard deviations of seed
   001 Sect. 4.3) and the logged GNSS velocity carries white noise.

Files written, at ``out_dir`` / the manifest's relative paths (data contract): one
quadrotor CSV per UAV (``time_utc,roll_deg,pitch_deg,yaw_deg,vel_n_ms,vel_e_ms,vel_d_ms,
lat_deg,lon_deg,alt_m``) and the tower reference CSV in long form
(``time_utc,height_m,wind_speed_ms,wind_from_deg``; records stamped at the *start* of
their averaging interval; scalar-mean speed and speed-weighted vector-mean direction of
cup/vane-like samples).

Settings (manifest ``simulation:`` section):

* ``simulation.quadrotor``: fleet settings, keys and defaults in :data:`DEFAULTS`, plus
  ``uavs: {<uav id>: {pitch_offset_deg, yaw_offset_deg}}`` (the hidden truth);
* ``simulation.quadrotor_flights``: ``{<flight id>: {start, end, wind_speed_ms (at
  z_ref_m), wind_from_deg, heights_m: {<uav id>: m}, optional obukhov_length_m,
  z_ref_m, reference_heights_m}}``;
* ``simulation.mechanisms``: quadrotor entries ``{mechanism: pitch_offset | yaw_offset |
  drag_regime | response_lag, parameters: {...}, flights: [...]}`` (catalog of
  :mod:`dronewind.mechanisms`); ``pitch_offset``/``yaw_offset`` override the per-UAV
  values of ``simulation.quadrotor.uavs``.

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (SWUF-3D), Wetz et al. (2021), Sects. 2-5, Tables E1-E2.
.. [2] Wind-tunnel calibration of the SWUF-3D quadrotors, Kistner et al. (2024), Eq. 1, Table 2.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from dronewind.core.cf import atomic_write_text
from dronewind.core.geo import from_local_tangent_plane
from dronewind.errors import InputError
from dronewind.simulate.airframe import (
    AirframeDrag,
    attitude_from_tilt,
    rayleigh_tilt_rad,
    regime_tilt,
    weathervane_heading_deg,
)
from dronewind.simulate.common import first_order_lag, merge_settings, ornstein_uhlenbeck
from dronewind.simulate.settings import flight_seed  # SHA-256 of "<campaign seed>:<flight id>"

__all__ = ["DEFAULTS", "simulate_quadrotor_flight", "simulate_uav_log", "tower_reference_frame",
           "quadrotor_mechanisms", "log_profile_wind"]

#: Default ``simulation.quadrotor`` settings (units in the key names).
DEFAULTS: dict[str, Any] = {
    "fs_hz": 10.0,
    "mass_kg": 0.65,
    "rho_kgm3": 1.2,
    "drag": {"law": "rayleigh", "cd0a0_m2": 0.03, "cp_m2_per_rad": -0.047},
    "weathervane": {"tau_s": 3.0, "min_roll_deg": 1.0},
    "hover_position_sd_m": {"horizontal": 0.19, "vertical": 0.85},
    "position_timescale_s": 5.0,
    "attitude_noise_deg": 0.05,
    "gnss_velocity_noise_ms": 0.05,
    "climb_speed_ms": 3.0,
    "tower_distance_m": 20.0,
    "tower_averaging_s": 60.0,
    "reference_padding_s": 300.0,
    "reference_heights_m": [10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 98.0],
    "z_ref_m": 98.0,
    "obukhov_length_m": -100.0,
    "roughness_length_m": 0.05,
    "uavs": {},
}


def quadrotor_mechanisms(simulation: Mapping | None, flight_id: str | None = None) -> dict[str, Any]:
    """Collect the quadrotor mechanisms of ``simulation.mechanisms`` acting on a flight.

    Parameters
    ----------
    simulation : mapping or None
        The manifest's ``simulation`` section; mechanism entries are
        ``{mechanism: <name>, parameters: {...}, flights: [...]}`` (``flights`` optional:
        all flights when absent; ``name`` is accepted for ``mechanism``).
    flight_id : str, optional
        Only mechanisms whose ``flights`` list is absent or contains this id.

    Returns
    -------
    dict
        ``pitch_offset`` and ``yaw_offset`` (dict uav -> degree), ``drag_regime`` (list of
        ranges or None), ``response_lag_s`` (float). Parameters are validated against the
        catalog (:func:`dronewind.mechanisms.validate_parameters`).
    """
    from dronewind.mechanisms import validate_parameters

    out: dict[str, Any] = {"pitch_offset": {}, "yaw_offset": {}, "drag_regime": None,
                           "response_lag_s": 0.0}
    for i, m in enumerate((simulation or {}).get("mechanisms") or []):
        where = f"simulation.mechanisms[{i}]"
        if not isinstance(m, Mapping) or not ({"mechanism", "name"} & set(m)):
            raise InputError(where, "expected a mapping {mechanism: ..., parameters: {...}}")
        name = m.get("mechanism", m.get("name"))
        flights = m.get("flights")
        if flight_id is not None and flights is not None and flight_id not in flights:
            continue
        if name not in ("pitch_offset", "yaw_offset", "drag_regime", "response_lag"):
            continue
        p = validate_parameters(name, m.get("parameters"), f"{where}.parameters")
        if name in ("pitch_offset", "yaw_offset"):
            out[name][p["uav"]] = p["deg"]
        elif name == "drag_regime":
            out["drag_regime"] = _regime_table(p["coefficients"], f"{where}.parameters.coefficients")
        else:
            out["response_lag_s"] = p["tau_s"]
    return out


def _regime_table(rows: list[Mapping], where: str) -> list[dict[str, float]]:
    table = []
    for j, r in enumerate(rows):
        try:
            e = {"min_speed_ms": float(r["min_speed_ms"]), "max_speed_ms": float(r["max_speed_ms"]),
                 "b": float(r["b"]), "c": float(r["c"])}
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{where}[{j}]", "expected numbers min_speed_ms, max_speed_ms, "
                                              f"b [-], c [m s-1 (m s-2)^-b] ({exc})") from None
        if not (0.1 <= e["b"] <= 3.0 and 0.1 <= e["c"] <= 100.0 and e["max_speed_ms"] > e["min_speed_ms"]):
            raise InputError(f"{where}[{j}]", "b in [0.1, 3], c in [0.1, 100] and "
                                              "max_speed_ms > min_speed_ms expected")
        table.append(e)
    return sorted(table, key=lambda e: e["min_speed_ms"])


# ----------------------------------------------------------------------------- one UAV


def hover_wander(rng: np.random.Generator, n: int, position_sd_m: tuple[float, float],
                 position_timescale_s: float, fs_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """East, north and up excursions of a hovering UAV (Ornstein-Uhlenbeck each) [m].

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source (east, north, up drawn in this order).
    n : int
        Number of samples.
    position_sd_m : (float, float)
        Standard deviation of horizontal (per axis) and vertical wander [m] (Wetz et al. 2021,
        Sect. 4.3: 0.19 m and 0.85 m).
    position_timescale_s : float
        Time scale of the wander [s].
    fs_hz : float
        Sampling rate [Hz].

    Returns
    -------
    dx_east_m, dy_north_m, dz_up_m : numpy.ndarray
    """
    sd_h, sd_v = position_sd_m
    dx = ornstein_uhlenbeck(rng, n, sd_h, position_timescale_s, fs_hz)
    dy = ornstein_uhlenbeck(rng, n, sd_h, position_timescale_s, fs_hz)
    dz = ornstein_uhlenbeck(rng, n, sd_v, position_timescale_s, fs_hz)
    return dx, dy, dz


def platform_velocity(dx: np.ndarray, dy: np.ndarray, dz: np.ndarray, fs_hz: float,
                      prescribed_ms: tuple[np.ndarray, np.ndarray] | None = None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """True east, north and down velocity of the UAV [m s-1]: the wander's derivative, or a
    prescribed horizontal velocity (east, north)."""
    n = dx.size
    dt = 1.0 / fs_hz
    if prescribed_ms is not None:
        ve_true, vn_true = (np.asarray(v, float) for v in prescribed_ms)
    else:
        ve_true = np.gradient(dx, dt) if n > 1 else np.zeros(n)
        vn_true = np.gradient(dy, dt) if n > 1 else np.zeros(n)
    vd_true = -np.gradient(dz, dt) if n > 1 else np.zeros(n)
    return ve_true, vn_true, vd_true


def relative_wind(wind_east_ms: np.ndarray, wind_north_ms: np.ndarray, ve_true: np.ndarray,
                  vn_true: np.ndarray, response_lag_s: float, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Speed [m s-1] and from-direction [degree] of the air relative to the UAV, lagged by
    ``response_lag_s`` (the attitude's response, mechanism ``response_lag``)."""
    rel_e = first_order_lag(wind_east_ms - ve_true, response_lag_s, fs_hz)
    rel_n = first_order_lag(wind_north_ms - vn_true, response_lag_s, fs_hz)
    return np.hypot(rel_e, rel_n), np.degrees(np.arctan2(-rel_e, -rel_n)) % 360.0


def true_attitude_deg(speed_ms: np.ndarray, from_deg: np.ndarray, fs_hz: float, drag: AirframeDrag,
                      regime: list[Mapping] | None = None,
                      weathervane: Mapping | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roll, pitch and yaw (in (-180, 180]) that balance the relative wind [degree].

    The tilt comes from the drag law (``regime`` replaces ``drag``), the lean is towards the
    wind, the heading follows the wind (perfectly when ``weathervane`` is None, else through
    :func:`dronewind.simulate.airframe.weathervane_heading_deg` with ``tau_s`` and
    ``min_roll_deg``).
    """
    if regime:
        tilt = regime_tilt(speed_ms, regime)
    else:
        tilt = rayleigh_tilt_rad(speed_ms, drag.cd0a0_m2, drag.cp_m2_per_rad, drag.mass_kg, drag.rho_kgm3)
    if weathervane is None:
        psi = from_deg.copy()
    else:
        psi = weathervane_heading_deg(from_deg, tilt, float(weathervane.get("tau_s", 3.0)),
                                      float(weathervane.get("min_roll_deg", 1.0)), fs_hz, float(from_deg[0]))
    roll, pitch = attitude_from_tilt(tilt, np.radians(from_deg - psi))
    return np.degrees(roll), np.degrees(pitch), (psi + 180.0) % 360.0 - 180.0


def simulate_uav_log(wind_east_ms: np.ndarray, wind_north_ms: np.ndarray, fs_hz: float,
                     rng: np.random.Generator, *, law: AirframeDrag | None = None,
                     regime: list[Mapping] | None = None, pitch_offset_deg: float = 0.0,
                     yaw_offset_deg: float = 0.0, response_lag_s: float = 0.0,
                     weathervane: Mapping | None = None, attitude_noise_deg: float = 0.0,
                     gnss_velocity_noise_ms: float = 0.0,
                     position_sd_m: tuple[float, float] = (0.0, 0.0),
                     position_timescale_s: float = 5.0,
                     platform_velocity_ms: tuple[np.ndarray, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    r"""Attitude and GNSS signals of a hovering quadrotor in a given wind (forward drag balance).

    Parameters
    ----------
    wind_east_ms, wind_north_ms : numpy.ndarray
        Horizontal wind at the hover point [m s-1] (air moves towards east / north).
    fs_hz : float
        Sampling rate [Hz].
    rng : numpy.random.Generator
        Random source (position wander and noise).
    law : AirframeDrag, optional
        ``rayleigh`` drag law (Wetz et al. 2021, Eqs. 12-17); default Eq. 18.
    regime : list of mapping, optional
        ``drag_regime`` table; replaces ``law`` (see
        :func:`dronewind.simulate.airframe.regime_tilt`).
    pitch_offset_deg, yaw_offset_deg : float
        Logged minus true [degree].
    response_lag_s : float
        First-order lag of the attitude behind the wind [s].
    weathervane : mapping, optional
        ``tau_s`` [s] and ``min_roll_deg`` [degree]; ``None`` for a perfect weather vane
        (heading always into the lagged relative wind).
    attitude_noise_deg : float
        White noise on logged roll, pitch, yaw [degree].
    gnss_velocity_noise_ms : float
        White noise on logged GNSS velocity [m s-1].
    position_sd_m : (float, float)
        Standard deviation of horizontal (per axis) and vertical hover wander [m].
    position_timescale_s : float
        Time scale of the wander [s].
    platform_velocity_ms : (array, array), optional
        Prescribed true vehicle velocity east/north [m s-1] (instead of the wander's).

    Returns
    -------
    dict of numpy.ndarray
        ``roll_deg``, ``pitch_deg``, ``yaw_deg`` (logged, yaw in (-180, 180]),
        ``vel_n_ms``, ``vel_e_ms``, ``vel_d_ms`` (logged), ``dx_east_m``, ``dy_north_m``,
        ``dz_up_m`` (wander), ``true_roll_deg``, ``true_pitch_deg``, ``true_yaw_deg``.

    Notes
    -----
    The relative air velocity :math:`\mathbf{V}_{rel} = \mathbf{V}_{wind} - \dot{\mathbf{x}}`
    is lagged, its magnitude gives the tilt (:func:`dronewind.simulate.airframe.rayleigh_tilt_rad`),
    its from-direction the lean azimuth; roll and pitch follow from tilt and lean relative
    to the heading (:func:`dronewind.simulate.airframe.attitude_from_tilt`). The processing
    chain (:func:`dronewind.quadrotor.wind.wind_from_attitude`) must return the input wind
    to rounding without noise, lag and wander and with a perfect weather vane.
    """
    law = law or AirframeDrag()
    we = np.asarray(wind_east_ms, float)
    wn = np.asarray(wind_north_ms, float)
    n = we.size
    dx, dy, dz = hover_wander(rng, n, position_sd_m, position_timescale_s, fs_hz)
    ve_true, vn_true, vd_true = platform_velocity(dx, dy, dz, fs_hz, platform_velocity_ms)
    speed, from_deg = relative_wind(we, wn, ve_true, vn_true, response_lag_s, fs_hz)
    true_roll, true_pitch, true_yaw = true_attitude_deg(speed, from_deg, fs_hz, law, regime, weathervane)
    noise = (lambda s: rng.standard_normal(n) * s) if attitude_noise_deg > 0 else (lambda s: 0.0)
    vnoise = (lambda: rng.standard_normal(n) * gnss_velocity_noise_ms) if gnss_velocity_noise_ms > 0 \
        else (lambda: 0.0)
    return {  # noise drawn in this order: roll, pitch, yaw, north, east, down
        "roll_deg": true_roll + noise(attitude_noise_deg),
        "pitch_deg": true_pitch + pitch_offset_deg + noise(attitude_noise_deg),
        "yaw_deg": (true_yaw + yaw_offset_deg + noise(attitude_noise_deg) + 180.0) % 360.0 - 180.0,
        "vel_n_ms": vn_true + vnoise(), "vel_e_ms": ve_true + vnoise(), "vel_d_ms": vd_true + vnoise(),
        "dx_east_m": dx, "dy_north_m": dy, "dz_up_m": dz,
        "true_roll_deg": true_roll, "true_pitch_deg": true_pitch, "true_yaw_deg": true_yaw,
    }


# ----------------------------------------------------------------------------- tower and wind


def tower_reference_frame(time: np.ndarray, heights_m: np.ndarray, wind_east_ms: np.ndarray,
                          wind_north_ms: np.ndarray, averaging_s: float) -> pd.DataFrame:
    r"""Tower reference records (long form) from wind series at the tower heights.

    Parameters
    ----------
    time : numpy.ndarray of datetime64[ns]
        Sample times (UTC), shape (n,).
    heights_m : numpy.ndarray
        Heights [m], shape (k,).
    wind_east_ms, wind_north_ms : numpy.ndarray
        Wind, shape (k, n) [m s-1].
    averaging_s : float
        Averaging interval [s] (1 for 1 Hz, 60 for 1-min means as at Falkenberg).

    Returns
    -------
    pandas.DataFrame
        ``time_utc`` (start of each interval, ISO 8601 with Z), ``height_m``,
        ``wind_speed_ms`` (scalar mean, like a cup), ``wind_from_deg`` (vector mean of
        the unit vectors weighted by speed, like a vane).
    """
    t_ns = time.astype("datetime64[ns]").astype(np.int64)
    step = int(round(averaging_s * 1e9))
    bins = (t_ns - t_ns[0]) // step
    rows = []
    speed = np.hypot(wind_east_ms, wind_north_ms)
    for j, h in enumerate(np.asarray(heights_m, float)):
        df = pd.DataFrame({"b": bins, "s": speed[j], "e": wind_east_ms[j], "n": wind_north_ms[j]})
        g = df.groupby("b").mean()
        frm = cast(pd.Series, np.degrees(np.arctan2(-g["e"], -g["n"])) % 360.0)
        rows.append(pd.DataFrame({"t": t_ns[0] + g.index.to_numpy() * step, "height_m": h,
                                  "wind_speed_ms": g["s"].round(3).to_numpy(),
                                  "wind_from_deg": frm.round(2).to_numpy()}))
    out = pd.concat(rows, ignore_index=True).sort_values(["t", "height_m"], kind="stable")
    out.insert(0, "time_utc", _iso(out.pop("t").to_numpy().astype("datetime64[ns]")))
    return out.reset_index(drop=True)


def _iso(t: np.ndarray) -> np.ndarray:
    s = np.datetime_as_string(t.astype("datetime64[ms]"), unit="ms")
    return np.char.add(s.astype(str), "Z")


def _local_to_latlon(east_m: np.ndarray, north_m: np.ndarray, lat0: float,
                     lon0: float) -> tuple[np.ndarray, np.ndarray]:
    """Latitude and longitude of east/north offsets [degree] (WGS84 tangent plane, :mod:`dronewind.core.geo`)."""
    return from_local_tangent_plane(east_m, north_m, lat0, lon0)


def _default_wind_fn():
    try:
        from dronewind.simulate.atmosphere import simulate_wind
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise InputError("dronewind.simulate.atmosphere", f"simulate_wind is not available ({exc}); "
                         "pass wind_fn=log_profile_wind for a simple stand-in") from exc
    return simulate_wind


def log_profile_wind(points_enu_m: np.ndarray, duration_s: float, fs_hz: float,
                     mean_speed_ms: float, wind_from_deg: float, z_ref_m: float,
                     obukhov_length_m: float, roughness_length_m: float = 0.05, seed: int = 0,
                     theta_mean_k: float = 293.15, constraint: Any = None,
                     turbulence_intensity: float = 0.12, timescale_s: float = 20.0):
    r"""Simple stand-in for :func:`dronewind.simulate.atmosphere.simulate_wind` (same signature).

    Neutral logarithmic mean profile (the Obukhov length is ignored) plus turbulence that
    is an Ornstein-Uhlenbeck process per component with standard deviation
    ``turbulence_intensity`` times the local mean speed, shared by all points at the same
    height and independent between heights. For tests and benchmarks only.

    .. math:: U(z) = U_{ref}\,\ln(z/z_0)/\ln(z_{ref}/z_0)

    Returns
    -------
    xarray.Dataset
        Dims (point, time): ``u_east_ms``, ``v_north_ms``, ``w_up_ms``, ``theta_v_k``;
        coord ``time_s``.
    """
    import xarray as xr

    pts = np.asarray(points_enu_m, float)
    n = int(round(duration_s * fs_hz))
    rng = np.random.default_rng(seed)
    z = np.maximum(pts[:, 2], 2 * roughness_length_m)
    u_mean = mean_speed_ms * np.log(z / roughness_length_m) / np.log(z_ref_m / roughness_length_m)
    heights, inv = np.unique(np.round(z, 3), return_inverse=True)
    along = np.empty((len(heights), n))
    cross = np.empty((len(heights), n))
    for j in range(len(heights)):
        along[j] = ornstein_uhlenbeck(rng, n, 1.0, timescale_s, fs_hz)
        cross[j] = ornstein_uhlenbeck(rng, n, 1.0, timescale_s, fs_hz)
    sig = turbulence_intensity * u_mean[:, None]
    ua = u_mean[:, None] + sig * along[inv]
    uc = 0.8 * sig * cross[inv]
    to = np.radians(wind_from_deg + 180.0)
    ue = ua * np.sin(to) + uc * np.cos(to)
    vn = ua * np.cos(to) - uc * np.sin(to)
    return xr.Dataset({"u_east_ms": (("point", "time"), ue), "v_north_ms": (("point", "time"), vn),
                       "w_up_ms": (("point", "time"), np.zeros_like(ue)),
                       "theta_v_k": (("point", "time"), np.full_like(ue, theta_mean_k))},
                      coords={"time_s": ("time", np.arange(n) / fs_hz)})


# ----------------------------------------------------------------------------- one flight


#: Keys of ``simulation.quadrotor_flights.<id>``.
CONDITION_KEYS: tuple[str, ...] = ("start", "end", "wind_speed_ms", "wind_from_deg", "heights_m",
                                   "obukhov_length_m", "z_ref_m", "reference_heights_m")


def fleet_settings(settings: Mapping[str, Any] | None) -> dict[str, Any]:
    """``simulation.quadrotor`` merged into :data:`DEFAULTS` (unknown keys raise InputError)."""
    unknown = sorted(set(settings or {}) - set(DEFAULTS))
    if unknown:
        raise InputError(f"simulation.quadrotor.{unknown[0]}", f"unknown setting; expected one of {sorted(DEFAULTS)}")
    return merge_settings(DEFAULTS, settings or {})


def flight_conditions(simulation: Mapping[str, Any], flight_id: str) -> Mapping[str, Any]:
    """``simulation.quadrotor_flights.<flight_id>``, checked (InputError names the key)."""
    cond = (simulation.get("quadrotor_flights") or {}).get(flight_id)
    where = f"simulation.quadrotor_flights.{flight_id}"
    unknown = sorted(set(cond or {}) - set(CONDITION_KEYS))
    if unknown:
        raise InputError(f"{where}.{unknown[0]}", "unknown setting; expected start, end, wind_speed_ms, "
                                                  "wind_from_deg, heights_m, obukhov_length_m, z_ref_m, "
                                                  "reference_heights_m")
    if not cond:
        raise InputError(where, "missing flight conditions (start, end, wind_speed_ms, "
                                "wind_from_deg, heights_m)")
    for key in ("start", "end", "wind_speed_ms", "wind_from_deg"):
        if key not in cond:
            raise InputError(f"{where}.{key}", "required")
    return cond


def flight_span(cond: Mapping[str, Any], cfg: Mapping[str, Any],
                where: str) -> tuple[np.datetime64, np.datetime64, float, float]:
    """Start and end of the flight, the tower's padding on both sides [s] and the total simulated time [s]."""
    start = np.datetime64(str(cond["start"]).rstrip("Z"), "ns")
    end = np.datetime64(str(cond["end"]).rstrip("Z"), "ns")
    if end <= start:
        raise InputError(f"{where}.end", "end must be after start")
    pad = float(cfg["reference_padding_s"])
    dur_s = (end - start).astype(np.int64) / 1e9
    return start, end, pad, dur_s + 2 * pad


def sample_points(cond: Mapping[str, Any], cfg: Mapping[str, Any], uav_ids: list[str],
                  where: str) -> tuple[dict[str, float], np.ndarray, tuple[float, float], np.ndarray]:
    """Where the wind is simulated: the UAVs ``tower_distance_m`` upwind of the tower, the tower heights.

    Returns
    -------
    heights : dict
        UAV id -> hover height [m] (the flight's ``heights_m``, else the reference heights in turn).
    reference_heights_m : numpy.ndarray
        Tower heights [m].
    hover_en_m : (float, float)
        East and north of the UAVs from the tower [m].
    points : numpy.ndarray
        ``(n_uav + n_tower, 3)`` east, north, up [m]: the UAVs, then the tower heights.
    """
    heights = dict(cond.get("heights_m") or {})
    extra = sorted(set(heights) - set(uav_ids))
    if extra:
        raise InputError(f"{where}.heights_m.{extra[0]}", f"not a UAV of this flight (UAVs: {uav_ids})")
    default_h = list(cfg["reference_heights_m"])
    for k, u in enumerate(uav_ids):
        heights.setdefault(u, default_h[k % len(default_h)])
    ref_h = np.asarray(cond.get("reference_heights_m", cfg["reference_heights_m"]), float)
    frm = float(cond["wind_from_deg"])
    dist = float(cfg["tower_distance_m"])
    ux, uy = dist * np.sin(np.radians(frm)), dist * np.cos(np.radians(frm))
    points = np.array([[ux, uy, float(heights[u])] for u in uav_ids] + [[0.0, 0.0, h] for h in ref_h])
    return heights, ref_h, (ux, uy), points


def wind_at_points(wind_fn: Callable, points: np.ndarray, total_s: float, fs_hz: float, cond: Mapping[str, Any],
                   cfg: Mapping[str, Any], seed: int) -> tuple[np.ndarray, np.ndarray]:
    """East and north wind ``(point, time)`` [m s-1] from ``wind_fn`` (signature of
    :func:`dronewind.simulate.atmosphere.simulate_wind`) for the flight's conditions."""
    ds = wind_fn(points, total_s, fs_hz, float(cond["wind_speed_ms"]), float(cond["wind_from_deg"]),
                 float(cond.get("z_ref_m", cfg["z_ref_m"])),
                 float(cond.get("obukhov_length_m", cfg["obukhov_length_m"])),
                 roughness_length_m=float(cfg["roughness_length_m"]), seed=seed)
    return np.asarray(ds["u_east_ms"].values, float), np.asarray(ds["v_north_ms"].values, float)


def _uav_settings(uav: str, mech: Mapping[str, Any], cfg: Mapping[str, Any]) -> dict[str, Any]:
    """Keyword arguments of :func:`simulate_uav_log` for one UAV (mechanisms override ``uavs``)."""
    ucfg = (cfg.get("uavs") or {}).get(uav) or {}
    return {"regime": mech["drag_regime"],
            "pitch_offset_deg": float(mech["pitch_offset"].get(uav, ucfg.get("pitch_offset_deg", 0.0))),
            "yaw_offset_deg": float(mech["yaw_offset"].get(uav, ucfg.get("yaw_offset_deg", 0.0))),
            "response_lag_s": mech["response_lag_s"], "weathervane": cfg["weathervane"],
            "attitude_noise_deg": float(cfg["attitude_noise_deg"]),
            "gnss_velocity_noise_ms": float(cfg["gnss_velocity_noise_ms"]),
            "position_sd_m": (float(cfg["hover_position_sd_m"]["horizontal"]),
                              float(cfg["hover_position_sd_m"]["vertical"])),
            "position_timescale_s": float(cfg["position_timescale_s"])}


def climb_and_descent(height_m: float, n: int, fs_hz: float, climb_ms: float,
                      signals: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Height above ground [m] and logged downward velocity [m s-1] of a flight that climbs at
    ``climb_ms``, hovers (with the wander of ``signals``) and descends; the hover selection of the
    chain excludes climb and descent."""
    tt = np.arange(n) / fs_hz
    t_climb = height_m / climb_ms
    z = np.minimum(np.minimum(tt / t_climb, (tt[-1] - tt) / t_climb), 1.0) * height_m
    vd = np.where(tt < t_climb, -climb_ms, np.where(tt[-1] - tt < t_climb, climb_ms, 0.0))
    hovering = z >= height_m
    return z + np.where(hovering, signals["dz_up_m"], 0.0), np.where(hovering, signals["vel_d_ms"], vd)


def uav_log_frame(time: np.ndarray, signals: Mapping[str, np.ndarray], z_m: np.ndarray, vel_d_ms: np.ndarray,
                  hover_en_m: tuple[float, float], site: Mapping[str, Any]) -> pd.DataFrame:
    """The quadrotor CSV of the data contract (values rounded as a logger writes them)."""
    lat0, lon0, alt0 = float(site["latitude"]), float(site["longitude"]), float(site["altitude_m"])
    lat, lon = _local_to_latlon(hover_en_m[0] + signals["dx_east_m"], hover_en_m[1] + signals["dy_north_m"],
                                lat0, lon0)
    return pd.DataFrame({
        "time_utc": _iso(time),
        "roll_deg": np.round(signals["roll_deg"], 4), "pitch_deg": np.round(signals["pitch_deg"], 4),
        "yaw_deg": np.round(signals["yaw_deg"], 4),
        "vel_n_ms": np.round(signals["vel_n_ms"], 4), "vel_e_ms": np.round(signals["vel_e_ms"], 4),
        "vel_d_ms": np.round(vel_d_ms, 4),
        "lat_deg": np.round(lat, 8), "lon_deg": np.round(lon, 8), "alt_m": np.round(alt0 + z_m, 3),
    })


def _write_csv(frame: pd.DataFrame, path: Path) -> Path:
    return atomic_write_text(path, frame.to_csv(index=False))


def _flight_entry(campaign: Mapping[str, Any], flight_id: str) -> Mapping[str, Any]:
    flights = {f["id"]: f for f in campaign.get("quadrotor_flights") or []}
    if flight_id not in flights:
        raise InputError("quadrotor_flights", f"no quadrotor flight {flight_id!r}; "
                                              f"known: {sorted(flights)}")
    return flights[flight_id]


def simulate_quadrotor_flight(campaign: Mapping[str, Any], manifest_dir: Path, flight_id: str, out_dir: Path,
                              *, wind_fn: Callable | None = None) -> list[Path]:
    r"""Write the L0 files of one virtual quadrotor "drone tower" flight.

    Parameters
    ----------
    campaign : mapping
        Parsed manifest with ``site``, ``quadrotor_flights`` and ``simulation`` (seed,
        ``quadrotor`` settings, ``quadrotor_flights`` conditions, ``mechanisms``); a
        :class:`dronewind.manifest.Campaign` works too.
    manifest_dir : Path
        Folder of the manifest (kept for symmetry with the other simulators; paths are
        written under ``out_dir``).
    flight_id : str
        Id of the quadrotor flight.
    out_dir : Path
        Root for the manifest's relative paths.
    wind_fn : callable, optional
        Function with the signature of
        :func:`dronewind.simulate.atmosphere.simulate_wind` (default: that function).

    Returns
    -------
    list of Path
        The UAV CSVs (manifest order) and the tower reference CSV.

    Raises
    ------
    InputError
        Unknown flight, missing flight conditions or bad settings.

    Notes
    -----
    The UAVs hover ``tower_distance_m`` upwind of the tower at their ``heights_m``; the
    tower reports at ``reference_heights_m`` with ``tower_averaging_s`` means over the
    flight plus ``reference_padding_s`` on both sides. Wind speed ``wind_speed_ms`` is the
    mean at ``z_ref_m`` (98 m, as in Tables E1-E2). Random numbers come from a generator
    seeded by SHA-256 of the campaign seed and the flight id, so each flight is
    reproducible on its own.
    """
    out_dir = Path(out_dir)
    campaign = getattr(campaign, "data", campaign)
    flight = _flight_entry(campaign, flight_id)
    sim = campaign.get("simulation") or {}
    cfg = fleet_settings(sim.get("quadrotor"))
    cond = flight_conditions(sim, flight_id)
    mech = quadrotor_mechanisms(sim, flight_id)
    seed = flight_seed(int(sim.get("seed", 0)), flight_id)
    rng = np.random.default_rng(seed)
    fs = float(cfg["fs_hz"])
    start, end, pad, total_s = flight_span(cond, cfg, f"simulation.quadrotor_flights.{flight_id}")
    uav_ids = [u["id"] for u in flight["uavs"]]
    heights, ref_h, hover_en, points = sample_points(cond, cfg, uav_ids, f"simulation.quadrotor_flights.{flight_id}")
    ue, vn = wind_at_points(wind_fn or _default_wind_fn(), points, total_s, fs, cond, cfg, seed)
    offsets_ns = np.round(np.arange(ue.shape[1]) / fs * 1e9).astype("int64").astype("timedelta64[ns]")
    t_all = start - np.timedelta64(int(pad * 1e9), "ns") + offsets_ns
    law = AirframeDrag.from_settings({**cfg["drag"], "mass_kg": cfg["mass_kg"], "rho_kgm3": cfg["rho_kgm3"]})
    inflight = (t_all >= start) & (t_all < end)
    paths: list[Path] = []
    for k, u in enumerate(uav_ids):
        sig = simulate_uav_log(ue[k, inflight], vn[k, inflight], fs, rng, law=law, **_uav_settings(u, mech, cfg))
        z, vel_d = climb_and_descent(float(heights[u]), int(inflight.sum()), fs, float(cfg["climb_speed_ms"]), sig)
        frame = uav_log_frame(t_all[inflight], sig, z, vel_d, hover_en, campaign["site"])
        paths.append(_write_csv(frame, out_dir / next(x["file"] for x in flight["uavs"] if x["id"] == u)))
    nu = len(uav_ids)
    ref = tower_reference_frame(t_all, ref_h, ue[nu:], vn[nu:], float(cfg["tower_averaging_s"]))
    paths.append(_write_csv(ref, out_dir / flight["reference"]))
    return paths
