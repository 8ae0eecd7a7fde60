"""Conditions of a measured payload flight for its forward model, taken from the processed data.

The reference mast's mean wind, direction, temperature, friction velocity and Obukhov
length at its height (:func:`mast_surface_layer`, Monin-Obukhov similarity of
:mod:`dronewind.core.surface_layer`), the drone's hover height, position relative to the
mast and hover window (:func:`forward_conditions`), and the simulator's manifest of one
flight built from them (:func:`forward_manifest`). Nothing is read from the campaign's own
``simulation:`` section (for a virtual campaign that would be reading the answer). What the
user declares of the payload platform (``diagnosis.forward_payload``: its line length, mass,
drag area, how its attitude follows the line; :data:`dronewind.simulate.defaults.PAYLOAD_DEFAULTS`)
travels with the conditions as their ``payload`` entry (:func:`split_payload`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np
import xarray as xr

from dronewind.core.constants import KARMAN
from dronewind.core.timeseries import median_step
from dronewind.diagnose.forward_atmosphere import hover_span
from dronewind.manifest import payload_flight_manifest

__all__ = [
    "forward_conditions",
    "measured_rates_hz",
    "forward_manifest",
    "split_payload",
    "PAYLOAD_KEY",
    "processing_window",
    "measured_span",
    "WINDOW_PAD_S",
]


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


#: Key of the conditions that holds the forward model's payload settings (``simulation.payload``).
PAYLOAD_KEY = "payload"


def split_payload(conditions: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """A flight's conditions without their ``payload`` entry, and that entry (empty without one).

    Parameters
    ----------
    conditions : mapping
        Output of :func:`forward_conditions`.

    Returns
    -------
    flight : dict
        The keys of ``simulation.payload_flights.<id>``.
    payload : dict
        The keys of ``simulation.payload`` (the forward model's payload settings).
    """
    flight = {k: v for k, v in conditions.items() if k != PAYLOAD_KEY}
    return flight, dict(conditions.get(PAYLOAD_KEY) or {})


#: Per-flight rate conditions (keys of ``simulation.payload_flights.<id>``), the product they are
#: read from and its attribute.
_RATES = (("sonic_rate_hz", "l2_drone", "sampling_rate_hz"), ("ins_rate_hz", "ins_l1", "sampling_rate_hz"),
          ("mast_rate_hz", "l3", "mast_sampling_rate_hz"))


def measured_rates_hz(l3: xr.Dataset, l2_drone: xr.Dataset, ins_l1: xr.Dataset | None = None) -> dict[str, float]:
    r"""The rates a flight was recorded at, as the forward model's per-flight conditions [Hz].

    Parameters
    ----------
    l3 : xarray.Dataset
        The flight's L3 (attribute ``mast_sampling_rate_hz``: the reference mast record's rate).
    l2_drone : xarray.Dataset
        The drone's L2 (attribute ``sampling_rate_hz``: the payload sonic's rate).
    ins_l1 : xarray.Dataset, optional
        The payload INS L1 (attribute ``sampling_rate_hz``).

    Returns
    -------
    dict
        ``sonic_rate_hz``, ``ins_rate_hz``, ``mast_rate_hz``, each where its product records
        a finite rate: rounded to a whole number of Hz and brought into the simulator's range
        (the sonic 4-32 Hz, the INS 1-200 Hz, the mast 1-60 Hz).

    Notes
    -----
    The alignment interpolates both records linearly to its 32 Hz grid, which on average
    multiplies the power at frequency :math:`f` of a record sampled at :math:`f_s` by
    :math:`(2 + \cos 2\pi f/f_s)/3` (:func:`dronewind.compare.align.align_drone_mast`):
    over 1.5-3 Hz a 20 Hz mast record keeps about 0.93 of its power (a -5/3 spectrum), a 10 Hz one
    about 0.75.
    A forward model that records its mast at another rate than the measured one predicts
    another drone/mast power ratio there (the ``ln_hf`` features) for that reason alone.
    """
    from dronewind.simulate.settings import flight_rate_range_hz

    products = {"l3": l3, "l2_drone": l2_drone, "ins_l1": ins_l1}
    out = {}
    for key, product, attr in _RATES:
        ds = products[product]
        rate = float(ds.attrs.get(attr, np.nan)) if ds is not None else math.nan
        if math.isfinite(rate) and rate > 0:
            lo, hi = flight_rate_range_hz(key)
            out[key] = float(min(max(round(rate), lo), hi))
    return out


def forward_conditions(
    campaign_data: Mapping[str, Any],
    flight_id: str,
    l3: xr.Dataset,
    l2_drone: xr.Dataset,
    payload: Mapping[str, Any] | None = None,
    ins_l1: xr.Dataset | None = None,
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
        then no evidence of the diagnosis. The rates the flight was recorded at
        (:func:`measured_rates_hz`: ``sonic_rate_hz``, ``ins_rate_hz`` with ``ins_l1``,
        ``mast_rate_hz``), which the forward runs record at. With ``payload`` also
        :data:`PAYLOAD_KEY`.

    Other Parameters
    ----------------
    payload : mapping, optional
        The forward model's payload settings (``diagnosis.forward_payload``, keys of
        ``simulation.payload``), declared by the user for the platform flown; the
        simulator's defaults (SAMURAI-S) where absent. Its rates give way to the measured ones.
    ins_l1 : xarray.Dataset, optional
        The payload INS L1 (its rate).
    """
    from dronewind.simulate.settings import check_payload_settings

    payload = check_payload_settings(payload, "diagnosis.forward_payload")
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
        **measured_rates_hz(l3, l2_drone, ins_l1),
        **({PAYLOAD_KEY: dict(payload)} if payload else {}),
    }


def _measured_lag_s(l2_drone: xr.Dataset) -> float | None:
    """The sonic-INS lag of minimum TKE the chain found (L2 ``lag_tke_min_s``, else ``lag_sonic_ins_s``) [s]."""
    for key in ("lag_tke_min_s", "lag_sonic_ins_s"):
        value = float(l2_drone.attrs.get(key, np.nan))
        if math.isfinite(value):
            return value
    return None


#: Time added to both ends of the measured hover window, beyond the sonic-INS lag, when a
#: forward run is processed over it (:func:`processing_window`) [s].
WINDOW_PAD_S = 1.0


def processing_window(conditions: Mapping[str, Any]) -> dict[str, str]:
    """The flight window of a forward run processed over the measured hover window.

    The chain keeps the sonic samples whose own clock lies in the flight window and whose
    time shifted by the sonic-INS lag lies in the hover window of the INS
    (:func:`dronewind.payload.l2.compute_payload_l2`). The conditions' ``start`` and
    ``duration_s`` are the first and last time of the measured L2, i.e. already shifted:
    that span given again as the window would lose the lag's worth of samples at one end
    (4 at 32 Hz for -0.125 s) and one to the sampling grid's phase at the other. The window
    is therefore the measured span widened at both ends by ``|sonic_ins_lag_s|`` and
    :data:`WINDOW_PAD_S`; :func:`measured_span` then cuts the forward L2 back to the
    measured samples.

    Parameters
    ----------
    conditions : mapping
        :func:`forward_conditions` output (``start``, ``duration_s``, optional
        ``sonic_ins_lag_s`` [s]).

    Returns
    -------
    dict
        ``{"start": ..., "end": ...}`` (UTC ISO strings, microseconds, ``Z``).
    """
    pad = np.timedelta64(int(round((abs(float(conditions.get("sonic_ins_lag_s", 0.0))) + WINDOW_PAD_S) * 1e6)), "us")
    start, end = hover_span(conditions)
    return {"start": np.datetime_as_string(start - pad, unit="us") + "Z",
            "end": np.datetime_as_string(end + pad, unit="us") + "Z"}


def measured_span(l2_drone: xr.Dataset, conditions: Mapping[str, Any]) -> xr.Dataset:
    r"""A forward run's drone L2 cut to the measured L2's span: the same number of samples.

    Parameters
    ----------
    l2_drone : xarray.Dataset
        The forward run's L2 over :func:`processing_window` (datetime64 ``time``).
    conditions : mapping
        :func:`forward_conditions` output: ``start`` (the measured L2's first time) and
        ``duration_s`` (its last minus its first time [s]).

    Returns
    -------
    xarray.Dataset
        The samples whose time lies in [start - dt/2, start + duration + dt/2), dt the L2's
        median sample step: as many as the measured L2 holds ((duration / dt) + 1), whatever
        the phase of the forward run's sampling grid.

    Notes
    -----
    The record lengths of the later products follow from it: the 8 Hz L3 of the chain has
    floor((n_32 - 62) / 4) - 15 samples for n_32 samples on the common 32 Hz grid
    (:func:`dronewind.compare.chain.compute_l3`), n_32 being the L2's samples less 0-3 to
    the phase of the drone-mast lag. The features' Welch spectra take their frequency grid
    from that length, and a band average of few log-frequency bins, as the mast's
    :math:`\langle S_w/S_u\rangle` at low wind speed, changes by its sampling error when
    one Welch ordinate moves between bins (:func:`dronewind.diagnose.features.flight_features`):
    a forward L2 shorter than the measured one by a few samples biases such a feature.
    """
    t = l2_drone["time"].values.astype("datetime64[ns]").astype(np.int64)
    if t.size < 2:
        return l2_drone
    half = median_step(t) / 2
    start, end = (x.astype("datetime64[ns]").astype(np.int64) for x in hover_span(conditions))
    keep = (t >= start - half) & (t < end + half)
    return l2_drone.isel(time=np.flatnonzero(keep))


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
        conditions; the flight window of :func:`processing_window`, the L2 cut to the
        measured samples by :func:`measured_span` in
        :func:`dronewind.diagnose.forward.process_forward_flight`) instead of the window the
        chain would find in the simulated hover (which includes the simulator's hover
        margins): the features of the mast, whose record is the measured one, then cover the
        same samples as the measured features, up to the drone-mast lag the run finds.

    Returns
    -------
    dict
        Manifest content with one payload flight (without its ``window``, or with
        :func:`processing_window` for ``measured_atmosphere``), its reference
        mast sonic (:func:`dronewind.manifest.payload_flight_manifest`) and a
        ``simulation:`` section. The flight's sonic-INS processing lag is the conditions'
        ``sonic_ins_lag_s``, or 0 without one (not the simulator's per-flight draw, which
        would give every seed another lag); the conditions' ``payload`` entry, if any, is
        ``simulation.payload``.
    """
    data = payload_flight_manifest(campaign_data, flight_id)
    flight = data["payload_flights"][0]
    flight.pop("window", None)
    if measured_atmosphere:
        flight["window"] = processing_window(conditions)
    data["name"] = f"{campaign_data['name']}_forward_{flight_id}"
    flight_conditions, payload = split_payload(conditions)
    data["simulation"] = {
        "seed": int(seed),
        "payload_flights": {flight_id: {**flight_conditions,
                                        "sonic_ins_lag_s": float(conditions.get("sonic_ins_lag_s", 0.0))}},
        "mechanisms": [dict(m) for m in (mechanisms or [])],
    }
    if payload:
        data["simulation"]["payload"] = payload
    if measured_atmosphere:
        data["simulation"]["mast"] = {"noise_ms": 0.0, "temperature_noise_k": 0.0}
    return data
