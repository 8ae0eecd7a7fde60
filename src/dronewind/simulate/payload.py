"""Virtual SAMURAI-S flight: sling-load payload, INS, sonic, and the mast sonics.

Physics (Ghirardelli et al. 2025, Sects 2-3):

* Flight plan: payload on the ground (held) for ``ground_before_s``, vertical ascent at
  ``ascent_rate_ms``, hover from ``hover_margin_s`` before the hover window to
  ``hover_margin_s`` after it, descent at ``descent_rate_ms``, ground time. Corners are
  smoothed over 2 s.
* Drone: hovers ``pendulum_length_m`` above the payload with smooth position jitter
  (second-order low-passed noise, ``hover_jitter_m``, ``hover_jitter_time_s``).
* Payload: a simple pendulum (Sect. 2.3: "treated as a simple pendulum", period
  2 pi sqrt(l/g) = 8.5 s for l = 18 m) hanging from the drone, forced by the moving
  pivot and by the drag of the turbulent wind, linearised about the mean wind U:

  .. math::
      \\ddot p_a + \\frac{\\rho C_dA U}{m}\\dot p_a + \\omega_0^2 (p_a - d_a - \\delta) =
          \\frac{\\rho C_dA U}{m} u',\\qquad
      \\ddot p_c + \\frac{\\rho C_dA U}{2m}\\dot p_c + \\omega_0^2 (p_c - d_c) =
          \\frac{\\rho C_dA U}{2m} v'

  (a along, c across the wind; omega_0^2 = g/l; delta = l rho C_dA U^2 / (2 m g) the
  mean downwind trail; damping at least ``min_damping_ratio``). Its height is
  z_drone - sqrt(l^2 - r^2).
* Attitude: roll transferred from the drone, which banks into lateral gusts
  (phi = rho C_dA,drone U v' / (m_drone g), 0.5 s lag) plus jitter; pitch = balance trim
  plus jitter; yaw weathervanes to the direction the relative air comes from
  (first order, ``yaw_time_constant_s``) plus jitter (Sect. 2.3).
* Sonic (RM Young 81000, 32 Hz, Table 2): air velocity relative to the sensor in the
  sensor frame, the exact inverse of DESIGN.md's correction
  V_wind = R(phi, theta, psi) V_body + V_ins, V_body = M_mount V_sensor; white noise
  ``sonic_noise_ms`` and resolution 0.01 m/s (0.01 K).
* INS (Ellipse-D EKF, 50 Hz, Table 3): velocity of the sonic volume (NED), attitude,
  lat/lon (WGS84 local tangent plane of :mod:`dronewind.core.geo`, the chain's own Earth
  model) and alt MSL with Gauss-Markov errors of the Table 3 accuracies; GNSS time valid
  only ``gnss_acquisition_s`` after logging starts, with one blink of
  ``gnss_blink_s`` (< 10 s) halfway before; EKF valid after ``ekf_init_s``.
* Sonic-INS processing lag: the sonic's rows are stamped ``sonic_ins_lag_s`` late against
  the INS's (the time the chain must add to the sonic clock, DESIGN.md's
  ``lag_sonic_ins_s``), per flight: its ``simulation.payload_flights.<id>.sonic_ins_lag_s``,
  else drawn from the flight's seed in [``sonic_ins_lag_low_s``, ``sonic_ins_lag_high_s``],
  by default [-0.185, 0] s, the range of the ten validation flights' lags (Ghirardelli et
  al. 2025, Sect. 3.3, Fig. 4; :func:`dronewind.simulate.settings.processing_lag_s`). The
  ``sonic_ins_lag`` mechanism adds to it.
* Logger clock: ``rpi_time_us`` = (UTC + ``logger_clock_offset_s``) with
  ``logger_clock_drift_ppm``, shared by both files.
* Row defects (missing, duplicated, swapped, out-of-range) at the ``defects`` rates.

The turbulent field comes from :mod:`dronewind.simulate.atmosphere` at the mast sonics
(generated first, so they do not depend on the payload's position) and at the hover
point, with the campaign's turbulence model (``simulation.atmosphere``: spectral shape
and sigma factors, :func:`~dronewind.simulate.departures.reshape_field`; mean-wind
trends about the hover-window centre, :func:`~dronewind.simulate.departures.mean_wind_trend`)
seen alike by the payload and the masts. During ascent and descent the payload sees the hover point's fluctuations with
the mean wind of its current height (an approximation: only hover data are analysed);
the payload's own swing (about a metre) is not used to re-sample the field.

Mechanisms act inside this measurement model (see :mod:`dronewind.mechanisms`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from scipy import signal
from scipy.interpolate import CubicSpline

from dronewind.core import surface_layer
from dronewind.core.angles import deg2rad, rad2deg
from dronewind.core.constants import AIR_DENSITY_KGM3, GRAVITY_MS2, ZERO_CELSIUS_K
from dronewind.core.geo import from_local_tangent_plane, local_tangent_plane_m
from dronewind.core.raw import RawRecord, content_digest
from dronewind.core.reuse import reused
from dronewind.core.timeseries import unwrap_rad
from dronewind.errors import InputError
from dronewind.simulate import atmosphere as atm
from dronewind.simulate import constraint, departures, spectral_model
from dronewind.simulate.mast import mast_measurement
from dronewind.simulate.settings import (
    CampaignLike,
    PayloadFlightConditions,
    SimulationSettings,
    campaign_dict,
    resolve_payload_flight,
    validate_simulation,
)
from dronewind.simulate.writers import ins_record, payload_sonic_record, toa5_record, write_record

__all__ = [
    "body_to_ned",
    "pendulum_period_s",
    "flight_timeline",
    "simulate_payload_flight",
    "payload_records",
    "payload_truth",
    "PayloadTruth",
    "measured_constraint",
    "check_atmosphere_record",
    "atmosphere_digest",
]

_G = GRAVITY_MS2
_Z_GROUND_M = 0.5  # payload height while on the ground [m]
_MOUNTS = {"upside_down": np.eye(3), "upright": np.diag([1.0, -1.0, -1.0])}
# random streams (fixed purpose numbers so that switching one mechanism leaves the others' draws)
_STREAM = {"turbulence": 0, "motion": 1, "ins_noise": 2, "sonic_noise": 3, "noise_mechanism": 4,
           "sonic_defects": 5, "ins_defects": 6, "spectral_sampling": 7, "mast": 100}


def body_to_ned(roll_deg: np.ndarray | float, pitch_deg: np.ndarray | float,
                yaw_deg: np.ndarray | float) -> np.ndarray:
    """Body-to-NED rotation R(phi, theta, psi) = [R3(phi) R2(theta) R1(psi)]^T.

    Parameters
    ----------
    roll_deg, pitch_deg, yaw_deg : numpy.ndarray or float
        Euler angles [degree], same shape s.

    Returns
    -------
    numpy.ndarray
        Shape s + (3, 3).

    Notes
    -----
    Ghirardelli et al. (2025), Appendix A; written independently of the processing chain's
    ``dronewind.payload.motion`` (the simulator must not use it).
    """
    f, t, p = (deg2rad(np.asarray(a, float)) for a in (roll_deg, pitch_deg, yaw_deg))
    cf, sf, ct, st, cp, sp = np.cos(f), np.sin(f), np.cos(t), np.sin(t), np.cos(p), np.sin(p)
    r = np.empty(np.shape(f) + (3, 3))
    r[..., 0, 0] = ct * cp
    r[..., 0, 1] = sf * st * cp - cf * sp
    r[..., 0, 2] = cf * st * cp + sf * sp
    r[..., 1, 0] = ct * sp
    r[..., 1, 1] = sf * st * sp + cf * cp
    r[..., 1, 2] = cf * st * sp - sf * cp
    r[..., 2, 0] = -st
    r[..., 2, 1] = sf * ct
    r[..., 2, 2] = cf * ct
    return r


def pendulum_period_s(length_m: float) -> float:
    """Small-amplitude period of a simple pendulum, T = 2 pi sqrt(l/g) (Ghirardelli et al. 2025, Sect. 2.3).

    Parameters
    ----------
    length_m : float
        Rope length [m].

    Returns
    -------
    float
        Period [s] (8.51 s for 18 m).
    """
    return 2 * math.pi * math.sqrt(length_m / _G)


def flight_timeline(cond: PayloadFlightConditions) -> dict[str, float]:
    """Phase boundaries of a flight in seconds relative to the hover-window start.

    Parameters
    ----------
    cond : dict
        Output of :func:`dronewind.simulate.settings.resolve_payload_flight`.

    Returns
    -------
    dict
        ``log_start, takeoff, hover_start, hover_end, landing, log_end`` [s]. The
        nominal hover height (without ``height_offset``) sets the climb times so that
        the timeline does not depend on that mechanism.
    """
    p = cond["payload"]
    h = cond["hover_height_m"]
    margin = p["hover_margin_s"]
    climb_up, climb_down = h / p["ascent_rate_ms"], h / p["descent_rate_ms"]
    needed = cond["duration_s"] + 2 * margin + climb_up + climb_down + p["ground_before_s"] + p["ground_after_s"]
    flight_duration_s = cond.get("flight_duration_s")
    if flight_duration_s:
        margin += 0.5 * (flight_duration_s - needed)
    hover_start = -margin
    hover_end = cond["duration_s"] + margin
    takeoff = hover_start - climb_up
    landing = hover_end + climb_down
    return {"log_start": takeoff - p["ground_before_s"], "takeoff": takeoff, "hover_start": hover_start,
            "hover_end": hover_end, "landing": landing, "log_end": landing + p["ground_after_s"]}


@functools.lru_cache(maxsize=64)
def _butter_sos(order: int, cutoff_hz: float, fs_hz: float) -> np.ndarray:
    """Butterworth low-pass sections (read-only), designed once per order, cut-off and rate.

    A flight's noise streams use a few filters again and again (every forward run draws
    the INS errors anew): a flight's forward runs designed 3 filters 240 times, 2 % of
    their profiled time (``benchmarks/results/profile_forward_s02_s26_before.json``). The
    same arguments give the same sections, so nothing else changes.
    """
    sos = signal.butter(order, cutoff_hz, fs=fs_hz, output="sos")
    sos.setflags(write=False)
    return sos


def _lowpass_noise(rng: np.random.Generator, n: int, fs_hz: float, time_s: float, sigma: float,
                   order: int = 2) -> np.ndarray:
    """Smooth random signal: white noise through a Butterworth low-pass at 1/(2 pi tau), scaled."""
    if sigma == 0 or n == 0:
        return np.zeros(n)
    fc = min(1.0 / (2 * np.pi * time_s), 0.45 * fs_hz)
    sos = _butter_sos(order, fc, fs_hz).copy()  # sosfilt wants a writable array
    pad = int(min(10 * time_s * fs_hz, 20 * fs_hz * 60))
    x = signal.sosfilt(sos, rng.standard_normal(n + pad))[pad:]
    sd = np.std(x)
    return x * (sigma / sd) if sd > 0 else x


def _oscillator(force: np.ndarray, omega0: float, damping: float, fs_hz: float) -> np.ndarray:
    """Response p of p'' + c p' + w0^2 p = force (bilinear-discretised, starts at rest)."""
    b, a = signal.bilinear([1.0], [1.0, damping, omega0**2], fs=fs_hz)
    return signal.lfilter(b, a, force)


def _first_order(x: np.ndarray, tau_s: float, fs_hz: float, x0: float | None = None) -> np.ndarray:
    """First-order low-pass (time constant tau) starting at x0 (default x[0])."""
    alpha = 1.0 - math.exp(-1.0 / (tau_s * fs_hz))
    zi = [(1 - alpha) * (x[0] if x0 is None else x0)]
    y, _ = signal.lfilter([alpha], [1.0, -(1 - alpha)], x, zi=zi)
    return y


def _smooth_path(t: np.ndarray, knots_t: list[float], knots_z: list[float], fs_hz: float,
                 width_s: float = 2.0) -> np.ndarray:
    z = np.interp(t, knots_t, knots_z)
    n = max(int(width_s * fs_hz), 1)
    kernel = np.ones(n) / n
    zp = np.concatenate([np.full(n, z[0]), z, np.full(n, z[-1])])
    return np.convolve(zp, kernel, mode="same")[n:-n]


def _defects(rng: np.random.Generator, n: int, rates: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """Row order as logged (missing, duplicated, swapped rows) and out-of-range rows."""
    u = rng.random((4, n))
    keep = u[0] >= rates["missing_rate"]
    idx = np.flatnonzero(keep)
    dup = u[1][idx] < rates["duplicate_rate"]
    idx = np.repeat(idx, np.where(dup, 2, 1))
    swap = np.flatnonzero(u[2][: idx.size - 1] < rates["out_of_order_rate"])
    swap = swap[np.concatenate([[True], np.diff(swap) > 1])] if swap.size else swap
    idx[swap], idx[swap + 1] = idx[swap + 1].copy(), idx[swap].copy()
    oor = u[3] < rates["out_of_range_rate"]
    return idx, oor


def _mast_offsets_enu(site: Mapping[str, Any], sonic: Mapping[str, Any]) -> tuple[float, float]:
    """East, north offset [m] of a mast sonic from the site position (WGS84 local tangent plane)."""
    lat0 = float(site.get("latitude", sonic["latitude"]))
    lon0 = float(site.get("longitude", sonic["longitude"]))
    de, dn = local_tangent_plane_m(sonic["latitude"], sonic["longitude"], lat0, lon0)
    return float(de), float(dn)


def _log_span_utc(cond: PayloadFlightConditions) -> tuple[np.datetime64, np.datetime64]:
    """UTC of the first and last logged sample of a flight."""
    tl = flight_timeline(cond)
    us = np.timedelta64(1, "us")
    return (cond["start"] + int(round(tl["log_start"] * 1e6)) * us,
            cond["start"] + int(round(tl["log_end"] * 1e6)) * us)


def _mast_span(data: Mapping[str, Any], settings: SimulationSettings,
               cond: PayloadFlightConditions) -> tuple[np.datetime64, np.datetime64]:
    """Mast record span: the flight's log span plus margin, clipped halfway to neighbours."""
    t0, t1 = _log_span_utc(cond)
    margin = np.timedelta64(int(settings["mast"]["margin_s"] * 1e6), "us")
    lo, hi = t0 - margin, t1 + margin
    for f in data.get("payload_flights") or []:
        fid = str(f["id"])
        if fid == cond["flight_id"]:
            continue
        other = resolve_payload_flight(data, fid, settings)
        o0, o1 = _log_span_utc(other)
        if o0 < t1 and o1 > t0:
            raise InputError(f"simulation.payload_flights.{fid}",
                             f"flight overlaps flight {cond['flight_id']} ({o0}..{o1} vs {t0}..{t1})")
        if o1 <= t0:
            lo = max(lo, o1 + (t0 - o1) // 2)
        else:
            hi = min(hi, t1 + (o0 - t1) // 2)
    return lo, hi


def _mast_file(pattern_list: list[str], flight_id: str, sonic_id: str) -> str:
    """A mast sonic's file of one flight: its first files glob with '*' replaced by the flight id."""
    for pattern in pattern_list:
        if "*" in pattern:
            return pattern.replace("*", flight_id)
    raise InputError(f"masts.sonics.{sonic_id}.files",
                     "a simulated campaign needs a glob with '*' (replaced by the flight id), "
                     f"got {pattern_list}")


# --------------------------------------------------------------------------------------
# One flight, step by step
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Streams:
    """The flight's named random streams: ``streams(name, k)`` is a fresh generator of stream name + k.

    With a truth's ``memo``, :meth:`once` keeps what a stream gave, so that the probes of one
    truth draw it once, and the truths of the same seed at other hover heights find it inside a
    forward flight's runs (:mod:`dronewind.core.reuse`): a fresh generator gives the same
    numbers every time, so this changes no record.
    """

    seed: int
    memo: dict[tuple[str, str], Any] | None = field(default=None, compare=False, repr=False)

    def __call__(self, name: str, k: int = 0) -> np.random.Generator:
        return np.random.default_rng([self.seed, _STREAM[name] + k])

    def normal(self, name: str, shape: int | tuple[int, ...], k: int = 0) -> np.ndarray:
        """``self(name, k).standard_normal(shape)`` (read-only; drawn once per truth with a memo)."""
        return self.once(("normal", name, k, shape), lambda: self(name, k).standard_normal(shape))

    def once(self, key: tuple[Any, ...], make: Callable[[], Any]) -> Any:
        """``make()``, made once per truth and key with a memo; its arrays read-only."""
        if self.memo is None:
            return make()
        return _remembered(self.memo, ("stream draws", repr(key)),
                           lambda: reused("stream draws", {}, repr((self.seed, key)), make))


@dataclass(frozen=True)
class _FlightClock:
    """Time axes of one flight.

    Field time is seconds from ``field_t0``, a whole UTC second before the mast span, so
    that mast stamps fall on round 1/fs_mast; flight time (``t_s`` elsewhere) is seconds
    from the hover-window start ``start``.
    """

    timeline: dict[str, float]
    start: np.datetime64
    field_t0: np.datetime64
    #: hover-window start in field time [s]
    hover_start_field_s: float
    #: first sonic sample in field time [s]
    log_start_field_s: float
    n_sonic: int
    mast_lo: np.datetime64
    #: end of the mast span in field time [s]
    mast_end_field_s: float
    #: the field period is a whole multiple of this [s] (common sample spacing of sonic and mast)
    period_unit_s: float
    #: field time the field must cover [s] (before the Taylor-delay padding)
    span_s: float


def _flight_clock(data: Mapping[str, Any], settings: SimulationSettings, cond: PayloadFlightConditions,
                  fs_sonic_hz: float, fs_mast_hz: float) -> _FlightClock:
    """Flight timeline, sonic grid and mast span of one flight in field time."""
    tl = flight_timeline(cond)
    start = cond["start"]
    us = np.timedelta64(1, "us")
    mast_lo, mast_hi = _mast_span(data, settings, cond)
    # the field period starts on a whole second, so mast stamps fall on round 1/fs_m
    epoch_day = start.astype("datetime64[D]").astype("datetime64[us]")
    lo_s = math.floor((mast_lo - epoch_day) / us * 1e-6)
    field_t0 = epoch_day + int(lo_s * 1e6) * us               # UTC of field time 0
    rel0 = (start - field_t0) / us * 1e-6                     # hover start in field time
    log_start_f = math.ceil((rel0 + tl["log_start"]) * fs_sonic_hz) / fs_sonic_hz
    n_son = int(math.floor((tl["log_end"] - tl["log_start"]) * fs_sonic_hz))
    mast_end_f = (mast_hi - field_t0) / us * 1e-6
    whole = float(fs_sonic_hz).is_integer() and float(fs_mast_hz).is_integer()
    unit = 1.0 / math.gcd(int(fs_sonic_hz), int(fs_mast_hz)) if whole else 1.0
    span = max(mast_end_f, log_start_f + n_son / fs_sonic_hz + 1.0)
    return _FlightClock(tl, start, field_t0, rel0, log_start_f, n_son, mast_lo, mast_end_f, unit, span)


@dataclass(frozen=True)
class _FieldPoints:
    """Points of the turbulent field: the mast sonics first, the hover point last (ENU from the site)."""

    mast_ids: list[str]
    points_enu_m: np.ndarray
    hover_e_m: float
    hover_n_m: float
    hover_z_m: float


def _field_points(cond: PayloadFlightConditions) -> _FieldPoints:
    """Mast sonic positions and the hover point (reference mast + hover offset, lowered by ``height_offset``)."""
    sonics = cond["mast_sonics"]
    ref = sonics[cond["reference"]]
    ref_e, ref_n = _mast_offsets_enu(cond["site"], ref)
    dz = cond["mechanisms"].get("height_offset", {}).get("dz_m", 0.0)
    z_hover = cond["hover_height_m"] - dz
    hover_e, hover_n = ref_e + cond["hover_offset_enu_m"][0], ref_n + cond["hover_offset_enu_m"][1]
    mast_ids = list(sonics)
    points = [[*_mast_offsets_enu(cond["site"], sonics[s]), float(sonics[s]["height_m"])] for s in mast_ids]
    points.append([hover_e, hover_n, z_hover])
    return _FieldPoints(mast_ids, np.asarray(points), hover_e, hover_n, z_hover)


def _turbulence(cond: PayloadFlightConditions, clock: _FlightClock, field: _FieldPoints, fs_sonic_hz: float,
                fs_mast_hz: float, rng: np.random.Generator,
                atmosphere: xr.Dataset | None = None,
                sampling: np.random.Generator | None = None) -> tuple[atm.FieldSpec, dict[str, Any]]:
    """Fourier coefficients of the field at all points over the flight and mast span (Taylor delays padded).

    With ``atmosphere`` (the reference mast sonic's measured record, L1 names) the field is
    constrained by that record at the reference sonic's position and takes its spectral
    amplitudes (:func:`measured_constraint`); the second return value describes the record
    used (empty without one). With ``sampling`` (the seed's own stream) those amplitudes are
    the record's smoothed spectra drawn again from their sampling distribution
    (:func:`dronewind.simulate.constraint.spectral_sampling_factors`): the seeds of a forward
    flight then resample the record's spectral sampling error as well as the remainder of
    the field that the record leaves free, while the record itself is reproduced at the
    mast by every seed. The draws depend on the seed and the field's frequencies only, so
    the probes of a seed (and a record read through a mechanism) share them.
    """
    points = field.points_enu_m
    e_u0, _ = spectral_model.wind_frame_unit_vectors(cond["wind_from_deg"])
    s_down = points[:, :2] @ e_u0
    pad = (s_down.max() - s_down.min()) / max(cond["mean_speed_ms"], 0.5)  # Taylor delays must not wrap
    period = math.ceil((clock.span_s + pad) / clock.period_unit_s) * clock.period_unit_s
    fs_max = max(fs_sonic_hz, fs_mast_hz)
    con: constraint.ConstraintLatents | None = None
    info: dict[str, Any] = {}
    if atmosphere is not None:
        ref = field.mast_ids.index(cond["reference"])
        names = [v for v in ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k") if v in atmosphere]
        # the same record, point and clock for every seed and height of a forward flight: the
        # constraint is made once inside its runs (dronewind.core.reuse; read-only)
        con, info = reused(
            "measured constraint", {"time": atmosphere["time"].values, "point": points[ref],
                                    **{v: atmosphere[v].values for v in names}},
            repr((clock, period, fs_max, cond["wind_from_deg"], cond["duration_s"],
                  float(atmosphere.attrs.get("noise_ms", 0.0)),
                  float(atmosphere.attrs.get("temperature_noise_k", 0.0)))),
            lambda: measured_constraint(atmosphere, clock, points[ref], period, fs_max, cond["wind_from_deg"],
                                        cond["duration_s"]))
        info = dict(info)  # each truth its own description
    spec = atm.field_coefficients(points, period, fs_max, cond["mean_speed_ms"],
                                  cond["wind_from_deg"], cond["z_ref_m"], cond["obukhov_length_m"],
                                  cond["roughness_length_m"], rng, cond["theta_mean_k"],
                                  cond["boundary_layer_height_m"], con,
                                  "model" if con is None else "constraint", sampling)
    # the campaign's turbulence model (simulation.atmosphere) shapes a model field only: a field
    # constrained by a measured record takes that record's spectra
    return (_turbulence_model(cond, field, spec) if con is None else spec), info


def measured_constraint(record: xr.Dataset, clock: _FlightClock, point_enu_m: np.ndarray, period_s: float,
                        fs_hz: float, wind_from_deg: float, hover_duration_s: float
                        ) -> tuple[constraint.ConstraintLatents, dict[str, Any]]:
    """The reference mast's measured record as the constraint of a flight's field.

    Parameters
    ----------
    record : xarray.Dataset
        The reference sonic's measured record: ``u_east_ms``, ``v_north_ms``, ``w_up_ms``
        (and ``t_sonic_k``) on a datetime64 ``time`` axis (a mast L1 or L2); optional
        attributes ``noise_ms`` and ``temperature_noise_k``: its white measurement noise,
        removed from its spectra (:func:`dronewind.simulate.constraint.constraint_from_record`).
    clock : _FlightClock
        The flight's time axes (field time 0 is ``clock.field_t0``).
    point_enu_m : numpy.ndarray
        (3,) the reference sonic's position [m].
    period_s : float
        Period of the field [s].
    fs_hz : float
        Highest sampling rate of the field [Hz].
    wind_from_deg : float
        Mean wind direction of the field [degree].
    hover_duration_s : float
        Length of the hover window [s]: the record's means are taken over it
        (:func:`dronewind.simulate.constraint.constraint_from_record`).

    Returns
    -------
    constraint : ConstraintLatents
    info : dict
        ``record_covered_s`` (field time the record covers), ``mirrored_s`` (field time
        outside the record, filled by mirroring the record at its ends),
        ``interpolated_samples`` (missing samples inside it, interpolated linearly).

    Raises
    ------
    InputError
        A record without the variables, shorter than half the field period or not covering
        the hover window.

    Notes
    -----
    The record is put on the field's grid at its own rate from ``field_t0``; where the field
    period reaches beyond the record (the forward flight's log span plus mast margin may be
    wider than what was recorded around the measured flight), it is mirrored at the record's
    ends, which keeps its spectrum and continuity. Only the hover window enters the
    features; that part must be measured.
    """
    where = "atmosphere record"
    check_atmosphere_record(record, where)
    us = np.timedelta64(1, "us")
    t_rec = np.asarray((record["time"].values - clock.field_t0) / us, float) * 1e-6  # field time [s]
    finite = np.isfinite(record["u_east_ms"].values) & np.isfinite(record["v_north_ms"].values) \
        & np.isfinite(record["w_up_ms"].values)
    if finite.sum() < 2:
        raise InputError(where, "fewer than 2 valid samples")
    dt = float(np.median(np.diff(t_rec)))
    n = int(round(period_s / dt))
    grid = np.arange(n) * dt
    lo, hi = float(t_rec[finite][0]), float(t_rec[finite][-1])
    hover = (clock.hover_start_field_s, clock.hover_start_field_s + hover_duration_s)
    if lo > hover[0] + dt or hi < hover[1] - dt:
        raise InputError(where, f"the record covers field time {lo:.1f}..{hi:.1f} s, not the hover window "
                                f"{hover[0]:.1f}..{hover[1]:.1f} s")
    if 2 * (hi - lo) < period_s:
        raise InputError(where, f"the record covers {hi - lo:.1f} s, less than half the field period {period_s:.1f} s")
    # mirror at the ends: t < lo -> 2 lo - t, t > hi -> 2 hi - t
    mirrored = np.where(grid < lo, 2 * lo - grid, np.where(grid > hi, 2 * hi - grid, grid))
    inside = (t_rec >= lo) & (t_rec <= hi)
    data = {}
    n_interp = 0
    names = [v for v in ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k") if v in record]
    for var in names:
        x = np.asarray(record[var].values, float)
        good = np.isfinite(x)
        n_interp += int((~good & inside).sum())
        data[var] = (("time",), np.interp(mirrored, t_rec[good], x[good]))
    ds = xr.Dataset(data, coords={"time_s": ("time", grid)},
                    attrs={"height_m": float(point_enu_m[2]), "x_m": float(point_enu_m[0]),
                           "y_m": float(point_enu_m[1])})
    con = constraint.constraint_from_record(ds, period_s, fs_hz, wind_from_deg, mean_window_s=hover,
                                     noise_ms=float(record.attrs.get("noise_ms", 0.0)),
                                     temperature_noise_k=float(record.attrs.get("temperature_noise_k", 0.0)))
    covered = max(0.0, min(hi, grid[-1]) - max(lo, 0.0))
    return con, {"record_covered_s": covered, "mirrored_s": float(n * dt - covered),
                 "interpolated_samples": n_interp, "record_rate_hz": 1.0 / dt}


def check_atmosphere_record(record: xr.Dataset, where: str) -> None:
    """Check that a measured record can be a field's atmosphere (:func:`measured_constraint`).

    Parameters
    ----------
    record : xarray.Dataset
        The record.
    where : str
        Name of the record in errors (its file).

    Raises
    ------
    InputError
        The wind variables (mast L1 names ``u_east_ms``, ``v_north_ms``, ``w_up_ms``) or the
        datetime64 ``time`` axis missing.
    """
    missing = sorted({"u_east_ms", "v_north_ms", "w_up_ms"} - set(record.data_vars))
    if missing:
        raise InputError(where, f"missing variable(s) {missing} (mast L1 names expected)")
    if "time" not in record.dims or not np.issubdtype(record["time"].dtype, np.datetime64):
        raise InputError(where, "needs a datetime64 'time' axis")


def _turbulence_model(cond: PayloadFlightConditions, field: _FieldPoints, spec: atm.FieldSpec) -> atm.FieldSpec:
    """The campaign's spectral shape and sigma factors (``simulation.atmosphere``) on the field."""
    tm = cond["turbulence"]
    return departures.reshape_field(spec, field.points_enu_m[:, 2], tm["spectrum"],
                             (tm["sigma_u_factor"], tm["sigma_v_factor"], tm["sigma_w_factor"]),
                             tm["length_scale_factor"])


def _with_trend(cond: PayloadFlightConditions, clock: _FlightClock, spec: atm.FieldSpec, series: np.ndarray,
                points: list[int], t_field_s: np.ndarray) -> np.ndarray:
    """Synthesised series of some points with the campaign's mean-wind trends, zero at the hover-window centre."""
    tm = cond["turbulence"]
    centre = clock.hover_start_field_s + 0.5 * cond["duration_s"]
    return departures.mean_wind_trend(series, spec.mean_enu[points], t_field_s - centre, cond["mean_speed_ms"],
                               tm["speed_trend_ms_per_h"], tm["direction_trend_deg_per_h"])


@dataclass(frozen=True)
class _AirAtPayload:
    """True air at the payload on the sonic grid (flight time ``t_s``)."""

    t_s: np.ndarray
    #: planned payload height [m] and the 0..1 ramp of being airborne
    z_nominal_m: np.ndarray
    airborne: np.ndarray
    #: mean wind speed at the hover point [m s-1]
    mean_hover_ms: float
    wind_e_ms: np.ndarray
    wind_n_ms: np.ndarray
    wind_up_ms: np.ndarray
    theta_k: np.ndarray
    #: along- and across-wind fluctuations at the hover point [m s-1]
    u_fluct_ms: np.ndarray
    v_fluct_ms: np.ndarray


def _nominal_height_m(t_s: np.ndarray, tl: Mapping[str, float], z_hover_m: float, fs_hz: float) -> np.ndarray:
    """Flight plan: on the ground (0.5 m), climb, hover, descent, ground; corners smoothed over 2 s."""
    return _smooth_path(t_s, [tl["log_start"], tl["takeoff"], tl["hover_start"], tl["hover_end"],
                              tl["landing"], tl["log_end"]],
                        [_Z_GROUND_M, _Z_GROUND_M, z_hover_m, z_hover_m, _Z_GROUND_M, _Z_GROUND_M], fs_hz)


def _air_at_payload(cond: PayloadFlightConditions, clock: _FlightClock, field: _FieldPoints,
                    spec: atm.FieldSpec, fs_hz: float) -> _AirAtPayload:
    """Wind and temperature along the flight: hover-point fluctuations with the mean of the current height.

    The true air, without the drone's rotor ``downwash`` (see :func:`_wind_up_at_sonic`).
    """
    i0 = int(round(clock.log_start_field_s * fs_hz))
    hover = [len(field.mast_ids)]
    series = atm.synthesize(spec, fs_hz, hover, start_s=i0 / fs_hz, n_samples=clock.n_sonic)
    air = _with_trend(cond, clock, spec, series, hover, (i0 + np.arange(clock.n_sonic)) / fs_hz)[0]
    t = clock.log_start_field_s - clock.hover_start_field_s + np.arange(clock.n_sonic) / fs_hz  # s from hover start
    ustar = spec.friction_velocity_ms
    z_hover = field.hover_z_m
    z_pay_nom = _nominal_height_m(t, clock.timeline, z_hover, fs_hz)
    airborne = np.clip((z_pay_nom - _Z_GROUND_M) / 2.0, 0.0, 1.0)  # ramps in over the first 2 m
    # mean wind at the current height replaces the hover point's mean
    mean_h = surface_layer.mean_speed_profile(z_hover, ustar, cond["roughness_length_m"], cond["obukhov_length_m"])
    mean_z = surface_layer.mean_speed_profile(z_pay_nom, ustar, cond["roughness_length_m"], cond["obukhov_length_m"])
    e_u, e_v = spec.e_u, spec.e_v
    wind_e = air[0] + (mean_z - mean_h) * e_u[0]
    wind_n = air[1] + (mean_z - mean_h) * e_u[1]
    wind_up = air[2].copy()
    theta_h = float(spec.theta_mean_k[-1])
    theta = air[3] + surface_layer.theta_profile(z_pay_nom, z_hover, theta_h, ustar, cond["obukhov_length_m"]) - theta_h
    u_fl = (air[0] - spec.mean_enu[-1, 0]) * e_u[0] + (air[1] - spec.mean_enu[-1, 1]) * e_u[1]
    v_fl = (air[0] - spec.mean_enu[-1, 0]) * e_v[0] + (air[1] - spec.mean_enu[-1, 1]) * e_v[1]
    return _AirAtPayload(t, z_pay_nom, airborne, float(mean_h), wind_e, wind_n, wind_up, theta, u_fl, v_fl)


def _wind_up_at_sonic(cond: PayloadFlightConditions, air: _AirAtPayload) -> np.ndarray:
    """Vertical wind the payload sonic sees: the true w, minus the rotors' ``downwash`` while airborne.

    The downdraft changes only what the sonic measures (the payload's motion follows the
    horizontal wind), so it belongs to the measurement stage.
    """
    if "downwash" not in cond["mechanisms"]:
        return air.wind_up_ms
    dw = cond["mechanisms"]["downwash"]
    w_dw = dw["w0_ms"] * np.exp(-np.hypot(air.wind_e_ms, air.wind_n_ms) / dw["u_scale_ms"])
    return air.wind_up_ms - air.airborne * w_dw


@dataclass(frozen=True)
class _Motion:
    """True path (cubic splines of flight time) and attitude of the payload on the sonic grid."""

    t_s: np.ndarray
    east_m: CubicSpline
    north_m: CubicSpline
    up_m: CubicSpline
    roll_deg: np.ndarray
    pitch_deg: np.ndarray
    yaw_deg: np.ndarray
    #: body-to-NED rotation R(roll, pitch, yaw), (n, 3, 3)
    rotation: np.ndarray


class _Jitter(NamedTuple):
    """The drone's random jitter (:func:`_jitter`): hover position [m] and attitude [degree]."""

    along_m: np.ndarray
    across_m: np.ndarray
    vertical_m: np.ndarray
    roll_deg: np.ndarray
    pitch_deg: np.ndarray
    yaw_deg: np.ndarray


#: Payload settings the jitter depends on (:func:`_jitter`).
_JITTER_KEYS: tuple[str, ...] = ("hover_jitter_time_s", "hover_jitter_m", "attitude_jitter_time_s",
                                 "drone_roll_jitter_deg", "pitch_jitter_deg", "yaw_jitter_deg")


def _jitter(p: Mapping[str, float], rng: np.random.Generator, n: int, fs_hz: float) -> _Jitter:
    """The drone's hover and attitude jitter: low-passed noise drawn from ``rng`` (the motion stream).

    Drawn in the order hover jitter along, across and vertical, then roll, pitch and yaw
    jitter (Ghirardelli et al. 2025, Sect. 2.3). It depends on the stream, the settings of
    :data:`_JITTER_KEYS`, ``n`` and ``fs_hz`` only, not on the air: the truths of one seed
    at other hover heights (``height_offset``) draw the same (:func:`_truth`).
    """
    hover, attitude = p["hover_jitter_time_s"], p["attitude_jitter_time_s"]
    return _Jitter(_lowpass_noise(rng, n, fs_hz, hover, p["hover_jitter_m"]),
                   _lowpass_noise(rng, n, fs_hz, hover, p["hover_jitter_m"]),
                   _lowpass_noise(rng, n, fs_hz, hover, 0.5 * p["hover_jitter_m"]),
                   _lowpass_noise(rng, n, fs_hz, attitude, p["drone_roll_jitter_deg"]),
                   _lowpass_noise(rng, n, fs_hz, attitude, p["pitch_jitter_deg"]),
                   _lowpass_noise(rng, n, fs_hz, attitude, p["yaw_jitter_deg"]))


def _pendulum(p: Mapping[str, float], air: _AirAtPayload, field: _FieldPoints, e_u: np.ndarray,
              e_v: np.ndarray, jitter: _Jitter,
              fs_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Payload position: linearised pendulum under a jittering drone, forced by the turbulent drag.

    Ghirardelli et al. (2025), Sect. 2.3 (see the module docstring); the drone's hover jitter is ``jitter``'s.

    Returns
    -------
    east_m, north_m, up_m : numpy.ndarray
        Payload position (ENU from the site) [m].
    """
    airborne = air.airborne
    l_m = p["pendulum_length_m"]
    omega0 = math.sqrt(_G / l_m)
    u_mean = max(air.mean_hover_ms, 0.1)
    k_drag = AIR_DENSITY_KGM3 * p["drag_area_m2"] * u_mean / p["mass_kg"]
    c_a = max(k_drag, 2 * p["min_damping_ratio"] * omega0)
    c_c = max(0.5 * k_drag, 2 * p["min_damping_ratio"] * omega0)
    trail = l_m * 0.5 * AIR_DENSITY_KGM3 * p["drag_area_m2"] * u_mean**2 / (p["mass_kg"] * _G)
    jit_a, jit_c, jit_z = jitter.along_m, jitter.across_m, jitter.vertical_m
    d_a, d_c = airborne * jit_a, airborne * jit_c
    p_a = _oscillator(omega0**2 * (d_a + airborne * trail) + airborne * k_drag * air.u_fluct_ms, omega0, c_a, fs_hz)
    p_c = _oscillator(omega0**2 * d_c + airborne * 0.5 * k_drag * air.v_fluct_ms, omega0, c_c, fs_hz)
    r_h = np.hypot(p_a - d_a, p_c - d_c)
    z_pay = air.z_nominal_m + airborne * (jit_z + l_m - np.sqrt(np.maximum(l_m**2 - r_h**2, 0.0)))
    pos_e = field.hover_e_m + p_a * e_u[0] + p_c * e_v[0]
    pos_n = field.hover_n_m + p_a * e_u[1] + p_c * e_v[1]
    return pos_e, pos_n, z_pay


def _slope_at_knots(spline: CubicSpline) -> np.ndarray:
    r"""``spline(spline.x, 1)`` bit for bit: the first derivative at the spline's own knots.

    At knot :math:`x_i` of interval :math:`i` scipy evaluates the derivative as
    :math:`0 + c_{1,i} + c_{2,i} \cdot 0 \cdot 2 + c_{3,i} \cdot 0 \cdot 3 = c_{1,i}` (``0.0 +``
    keeps the sign of a zero as that sum does); the last knot, the end of the last interval,
    is evaluated. The payload's velocity on its own grid (the motion's time axis) is taken
    five times per truth: over the 46 calls of sample s01's published-numbers forward job,
    1.4 against 66.8 ms (``benchmarks/bench_exact_shortcuts.py``,
    ``results/exact_shortcuts_s32.json``).
    """
    out = np.empty(spline.x.size)
    out[:-1] = 0.0 + spline.c[-2]
    out[-1:] = spline(spline.x[-1:], 1)
    return out


def _payload_motion(p: Mapping[str, float], air: _AirAtPayload, field: _FieldPoints, spec: atm.FieldSpec,
                    jitter: _Jitter, fs_hz: float) -> _Motion:
    """Pendulum path and attitude (Ghirardelli et al. 2025, Sect. 2.3).

    Roll: the drone banks into lateral gusts (0.5 s lag) plus jitter; pitch: trim plus
    jitter; yaw weathervanes to the direction the relative air comes from (first order)
    plus jitter (:func:`_jitter`).
    """
    t = air.t_s
    pos_e, pos_n, z_pay = _pendulum(p, air, field, spec.e_u, spec.e_v, jitter, fs_hz)
    u_mean = max(air.mean_hover_ms, 0.1)
    roll_k = AIR_DENSITY_KGM3 * p["drone_drag_area_m2"] * u_mean / (p["drone_mass_kg"] * _G)
    roll = rad2deg(_first_order(roll_k * air.v_fluct_ms, 0.5, fs_hz)) * air.airborne + jitter.roll_deg
    pitch = p["pitch_trim_deg"] + jitter.pitch_deg
    spl_e, spl_n, spl_z = (CubicSpline(t, x) for x in (pos_e, pos_n, z_pay))
    rel_e, rel_n = air.wind_e_ms - _slope_at_knots(spl_e), air.wind_n_ms - _slope_at_knots(spl_n)
    from_dir = unwrap_rad(np.arctan2(-rel_e, -rel_n))          # direction the relative air comes from
    yaw = rad2deg(_first_order(from_dir, p["yaw_time_constant_s"], fs_hz)) + jitter.yaw_deg
    return _Motion(t, spl_e, spl_n, spl_z, roll, pitch, yaw, body_to_ned(roll, pitch, yaw))


def _air_in_body(cond: PayloadFlightConditions, air: _AirAtPayload, motion: _Motion) -> np.ndarray:
    """The air relative to the payload in its body frame, R^T (V_wind - V_ins) [m s-1], (n, 3), read-only.

    Depends on the true state and ``downwash`` (the w the sonic sees) only, so a truth's
    other sonic probes share it (:func:`payload_records`).
    """
    vel_e, vel_n, vel_up = (_slope_at_knots(spl) for spl in (motion.east_m, motion.north_m, motion.up_m))
    rel_ned = np.stack([air.wind_n_ms - vel_n, air.wind_e_ms - vel_e, -(_wind_up_at_sonic(cond, air) - vel_up)],
                       axis=-1)
    v_body = np.einsum("tji,tj->ti", motion.rotation, rel_ned)
    v_body.setflags(write=False)
    return v_body


def _remembered(memo: dict[tuple[str, str], Any], key: tuple[str, str], make: Callable[[], Any]) -> Any:
    """``memo[key]``, made by ``make()`` the first time."""
    if key not in memo:
        memo[key] = make()
    return memo[key]


def _sonic_sensor_frame(cond: PayloadFlightConditions, air: _AirAtPayload, v_body: np.ndarray,
                        streams: _Streams) -> tuple[np.ndarray, np.ndarray]:
    """What the payload sonic measures: relative air in the sensor frame and sonic temperature.

    The exact inverse of the correction V_wind = R V_body + V_ins, V_body = M V_sensor,
    with the ``mount_misalignment``, ``w_gain`` and ``sonic_noise`` mechanisms, white
    noise and the sensor's resolution (Ghirardelli et al. 2025, Table 2). ``v_body`` is the air in the
    body frame (:func:`_air_in_body`).

    Returns
    -------
    v_sensor_ms : numpy.ndarray
        (n, 3) u, v, w [m s-1].
    t_sonic_c : numpy.ndarray
        Sonic temperature [degree C].
    """
    p, mech = cond["payload"], cond["mechanisms"]
    m_sb = _MOUNTS[cond["sonic_mount"]]
    if "mount_misalignment" in mech:
        mm = mech["mount_misalignment"]
        m_sb = m_sb @ body_to_ned(mm["roll_deg"], mm["pitch_deg"], mm["yaw_deg"])
    v_sensor = v_body @ m_sb                                   # (M^T v) row-wise
    if "w_gain" in mech:
        v_sensor[:, 2] *= mech["w_gain"]["gain"]
    v_sensor += p["sonic_noise_ms"] * streams.normal("sonic_noise", v_sensor.shape)
    if "sonic_noise" in mech:
        v_sensor += mech["sonic_noise"]["sigma_ms"] * streams.normal("noise_mechanism", v_sensor.shape)
    t_c = air.theta_k - ZERO_CELSIUS_K + p["temperature_offset_k"] + p["temperature_noise_k"] * \
        streams.normal("sonic_noise", v_body.shape[0], 10)
    res = p["sonic_resolution_ms"]
    if res > 0:
        v_sensor = np.round(v_sensor / res) * res
    if p["temperature_resolution_k"] > 0:
        t_c = np.round(t_c / p["temperature_resolution_k"]) * p["temperature_resolution_k"]
    return v_sensor, t_c


def _logger_clock_us(t_s: np.ndarray, log_t0_s: float, start: np.datetime64, p: Mapping[str, float]) -> np.ndarray:
    """Logger clock ``rpi_time_us`` of flight times: UTC + ``logger_clock_offset_s``, drifting by the ppm."""
    us = np.timedelta64(1, "us")
    clock = (t_s - log_t0_s) * (1 + p["logger_clock_drift_ppm"] * 1e-6)
    base = (start - np.datetime64("1970-01-01T00:00:00", "us")) / us * 1e-6 + log_t0_s + p["logger_clock_offset_s"]
    return np.round((base + clock) * 1e6).astype(np.int64)


def _sonic_stamps_us(cond: PayloadFlightConditions, t_s: np.ndarray) -> np.ndarray:
    """Logger stamps of the sonic rows: shifted by the flight's processing lag (``sonic_ins_lag_s``)
    and the ``sonic_ins_lag`` and ``clock_drift`` mechanisms.

    A sample of true time t is stamped t - lag: the chain adds lag to the sonic's clock to
    align it with the INS (DESIGN.md's ``lag_sonic_ins_s``).
    """
    mech, log_t0 = cond["mechanisms"], t_s[0]
    t_stamp = t_s - cond["sonic_ins_lag_s"]
    if "sonic_ins_lag" in mech:
        t_stamp = t_stamp - mech["sonic_ins_lag"]["lag_s"]
    if "clock_drift" in mech:
        t_stamp = t_stamp + mech["clock_drift"]["ppm"] * 1e-6 * (t_s - log_t0)
    return _logger_clock_us(t_stamp, log_t0, cond["start"], cond["payload"])


@dataclass(frozen=True)
class _InsRecord:
    """INS rows on the INS-rate grid of flight time ``t_s`` (ENU position from the site, NED velocity)."""

    t_s: np.ndarray
    east_m: np.ndarray
    north_m: np.ndarray
    up_m: np.ndarray
    vel_n_ms: np.ndarray
    vel_e_ms: np.ndarray
    vel_d_ms: np.ndarray
    roll_deg: np.ndarray
    pitch_deg: np.ndarray
    yaw_deg: np.ndarray


def _ins_track(motion: _Motion, fs_hz: float) -> tuple[np.ndarray, ...]:
    """The INS clock's times and the payload's true position and velocity at them (read-only).

    Returns ``(ti, east, north, up, v_east, v_north, v_up)`` [s, m, m s-1]; no mechanism
    changes them (``lever_arm`` adds to them in :func:`_ins_truth`), so a truth's INS
    probes share one evaluation of the motion's splines (:func:`payload_records`).
    """
    t = motion.t_s
    n_ins = int(math.floor((t[-1] - t[0]) * fs_hz)) + 1
    ti = t[0] + np.arange(n_ins) / fs_hz
    ti = ti[ti <= t[-1]]
    track = (ti, motion.east_m(ti), motion.north_m(ti), motion.up_m(ti),
             motion.east_m(ti, 1), motion.north_m(ti, 1), motion.up_m(ti, 1))
    for arr in track:
        arr.setflags(write=False)
    return track


def _ins_truth(cond: PayloadFlightConditions, motion: _Motion, track: tuple[np.ndarray, ...]) -> _InsRecord:
    """What a perfect INS would log: attitude (``attitude_lag``), position and velocity (``lever_arm``).

    ``track`` is :func:`_ins_track`'s. The yaw is not yet wrapped to (-180, 180].
    """
    mech, t = cond["mechanisms"], motion.t_s
    ti, pe, pn, pz, ve, vn, vu = track
    att_t = ti - mech.get("attitude_lag", {}).get("lag_s", 0.0)
    att_t = np.clip(att_t, t[0], t[-1])
    roll_i = np.interp(att_t, t, motion.roll_deg)
    pitch_i = np.interp(att_t, t, motion.pitch_deg)
    yaw_unw = np.interp(att_t, t, motion.yaw_deg)
    if "lever_arm" in mech:  # INS refers to sonic + R r_body: adds R r and d(R r)/dt
        la = mech["lever_arm"]
        r_ned = motion.rotation @ np.array([la["x_m"], la["y_m"], la["z_m"]])   # (n, 3) NED offset
        offs = [CubicSpline(t, r_ned[:, k]) for k in range(3)]
        pn, pe, pz = pn + offs[0](ti), pe + offs[1](ti), pz - offs[2](ti)
        vn, ve, vu = vn + offs[0](ti, 1), ve + offs[1](ti, 1), vu - offs[2](ti, 1)
    return _InsRecord(ti, pe, pn, pz, vn, ve, -vu, roll_i, pitch_i, yaw_unw)


#: Payload settings the INS errors depend on (:func:`_ins_noise`).
_INS_NOISE_KEYS: tuple[str, ...] = ("ins_noise_time_s", "ins_velocity_noise_ms", "ins_roll_pitch_noise_deg",
                                    "ins_heading_noise_deg", "ins_horizontal_position_noise_m",
                                    "ins_vertical_position_noise_m")


def _ins_noise(p: Mapping[str, Any], n: int, rng: np.random.Generator, fs_hz: float) -> tuple[np.ndarray, ...]:
    """Gauss-Markov errors of the Table 3 accuracies (Ghirardelli et al. 2025) for ``n`` INS rows.

    ``rng`` (the INS-noise stream) is drawn in the order vel N, E, D, roll, pitch, yaw,
    position E, N, up; the arrays are returned in that order, read-only. They depend on the
    stream, the payload's noise settings, ``n`` and ``fs_hz`` only, so every INS probe of a
    truth shares them (:func:`payload_records`).
    """
    tau = p["ins_noise_time_s"]

    def gm(sigma: float) -> np.ndarray:
        if tau > 0:
            return _lowpass_noise(rng, n, fs_hz, tau, sigma, order=1)
        return sigma * rng.standard_normal(n)

    sigmas = (p["ins_velocity_noise_ms"],) * 3 + (p["ins_roll_pitch_noise_deg"],) * 2 + (
        p["ins_heading_noise_deg"], p["ins_horizontal_position_noise_m"], p["ins_horizontal_position_noise_m"],
        p["ins_vertical_position_noise_m"])
    noise = tuple(gm(sigma) for sigma in sigmas)
    for arr in noise:
        arr.setflags(write=False)
    return noise


def _add_ins_errors(cond: PayloadFlightConditions, ins: _InsRecord, noise: Sequence[np.ndarray]) -> _InsRecord:
    """The INS errors (:func:`_ins_noise`) and ``heading_bias`` added; yaw wrapped to (-180, 180]."""
    mech = cond["mechanisms"]
    n_vn, n_ve, n_vd, n_roll, n_pitch, n_yaw, n_e, n_n, n_up = noise
    vn = ins.vel_n_ms + n_vn
    ve = ins.vel_e_ms + n_ve
    vd = ins.vel_d_ms + n_vd
    roll_i = ins.roll_deg + n_roll
    pitch_i = ins.pitch_deg + n_pitch
    yaw_unw = ins.yaw_deg + n_yaw + mech.get("heading_bias", {}).get("deg", 0.0)
    yaw_i = (yaw_unw + 180.0) % 360.0 - 180.0  # unwrapped over the turns: seldom in range for wrap_180
    yaw_i = np.where(yaw_i == -180.0, 180.0, yaw_i)
    pe = ins.east_m + n_e
    pn = ins.north_m + n_n
    pz = ins.up_m + n_up
    return _InsRecord(ins.t_s, pe, pn, pz, vn, ve, vd, roll_i, pitch_i, yaw_i)


def _ins_lat_lon(cond: PayloadFlightConditions, east_m: np.ndarray,
                 north_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Latitude and longitude of ENU offsets from the site (the reference mast's position by default; WGS84)."""
    ref = cond["mast_sonics"][cond["reference"]]
    site = cond["site"]
    lat0 = float(site.get("latitude", ref["latitude"]))
    lon0 = float(site.get("longitude", ref["longitude"]))
    return from_local_tangent_plane(east_m, north_m, lat0, lon0)


def _ins_validity(cond: PayloadFlightConditions, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``time_valid`` (GNSS time, with one blink before it is stable) and ``ekf_valid`` flags of INS rows."""
    p, tl = cond["payload"], flight_timeline(cond)
    since_log = t_s - t_s[0]
    acq, blink = p["gnss_acquisition_s"], p["gnss_blink_s"]
    time_valid = (since_log >= acq).astype(np.int64)
    if blink > 0 and acq > 2 * blink + 10:
        b0 = 0.5 * acq
        time_valid[(since_log >= b0) & (since_log < b0 + blink)] = 1
    if tl["log_start"] + acq + 10.0 > tl["hover_start"]:
        raise InputError("simulation.payload.gnss_acquisition_s",
                         f"GNSS time would become stable after the hover starts in flight {cond['flight_id']}")
    ekf_valid = (since_log >= p["ekf_init_s"]).astype(np.int64)
    return time_valid, ekf_valid


def _sonic_log(source: str, cond: PayloadFlightConditions, stamps_us: np.ndarray, v_sensor_ms: np.ndarray,
               t_sonic_c: np.ndarray, streams: _Streams) -> RawRecord:
    """Sonic CSV with row defects (missing, duplicated, swapped rows; out-of-range values)."""
    rates = cond["defects"]["sonic"]
    order, oor = streams.once(("defects", "sonic_defects", stamps_us.size, sorted(rates.items())),
                              lambda: _defects(streams("sonic_defects"), stamps_us.size, rates))
    r_def = streams("sonic_defects", 1)
    cols = np.column_stack([v_sensor_ms, t_sonic_c])
    bad_rows = np.flatnonzero(oor)
    bad_cols = r_def.integers(0, 4, bad_rows.size)
    bad_vals = np.where(r_def.random(bad_rows.size) < 0.5, -99.99, 99.99)  # beyond 40 m/s and 50 C
    cols[bad_rows, bad_cols] = bad_vals
    return payload_sonic_record(source, stamps_us[order], cols[order, 0], cols[order, 1], cols[order, 2],
                                cols[order, 3])


def _ins_log(source: str, cond: PayloadFlightConditions, ins: _InsRecord, valid: tuple[np.ndarray, np.ndarray],
             log_t0_s: float, streams: _Streams) -> RawRecord:
    """INS CSV (lat/lon/alt, ``valid`` = time_valid and ekf_valid flags, logger and UTC times) with row defects."""
    us = np.timedelta64(1, "us")
    lat, lon = _ins_lat_lon(cond, ins.east_m, ins.north_m)
    alt = float(cond["site"].get("altitude_m", 0.0)) + ins.up_m
    time_valid, ekf_valid = valid
    utc = cond["start"] + np.round(ins.t_s * 1e6).astype(np.int64) * us
    ins_rpi = _logger_clock_us(ins.t_s, log_t0_s, cond["start"], cond["payload"])
    rates = cond["defects"]["ins"]
    o, oor_i = streams.once(("defects", "ins_defects", ins.t_s.size, sorted(rates.items())),
                            lambda: _defects(streams("ins_defects"), ins.t_s.size, rates))
    ins_cols = np.column_stack([ins.vel_n_ms, ins.vel_e_ms, ins.vel_d_ms, ins.roll_deg, ins.pitch_deg])
    bad_rows = np.flatnonzero(oor_i)
    bad_cols = streams("ins_defects", 1).integers(0, 5, bad_rows.size)
    ins_cols[bad_rows, bad_cols] = 999.0
    return ins_record(source, ins_rpi[o], utc[o], time_valid[o], ekf_valid[o], lat[o], lon[o], alt[o],
                      ins_cols[o, 0], ins_cols[o, 1], ins_cols[o, 2], ins_cols[o, 3], ins_cols[o, 4], ins.yaw_deg[o])


@dataclass(frozen=True)
class _MastTruth:
    """True wind and temperature at every mast sonic over the mast span (at the mast rate)."""

    #: (n_sonics, 4, n): east, north, up [m s-1], sonic temperature [K]
    series: np.ndarray
    times: np.ndarray
    first_record: int


def _mast_truth(settings: SimulationSettings, clock: _FlightClock, field: _FieldPoints,
                spec: atm.FieldSpec) -> _MastTruth:
    """The field at the mast sonics on the logger's grid (RECORD counted from 2020-01-01)."""
    us = np.timedelta64(1, "us")
    fs_m = settings["mast"]["rate_hz"]
    m0 = int(math.ceil((clock.mast_lo - clock.field_t0) / us * 1e-6 * fs_m))
    m1 = int(math.floor(clock.mast_end_field_s * fs_m))
    masts = list(range(len(field.mast_ids)))
    # the field at the masts, made again by a truth of the same seed at another hover height
    # (whose points differ after the masts only): inside a forward flight's runs, found by
    # its coefficients (dronewind.core.reuse; read-only)
    series = reused("mast series", {"coeffs": spec.coeffs[masts], "mean": spec.mean_enu[masts],
                                    "theta": spec.theta_mean_k[masts], "e_u": spec.e_u, "e_v": spec.e_v},
                    repr((spec.period_s, fs_m, m0, m1)),
                    lambda: atm.synthesize(spec, fs_m, masts, start_s=m0 / fs_m, n_samples=m1 - m0))
    times = clock.field_t0 + np.round((m0 + np.arange(m1 - m0)) / fs_m * 1e6).astype(np.int64) * us
    rec0 = int(round((clock.field_t0 - np.datetime64("2020-01-01T00:00:00", "us")) / us * 1e-6 * fs_m)) + m0
    return _MastTruth(series, times, rec0)


def _mast_logs(cond: PayloadFlightConditions, settings: SimulationSettings, field: _FieldPoints,
               mast: _MastTruth, streams: _Streams) -> list[RawRecord]:
    """One TOA5 per mast sonic over the mast span (CSAT3 measurement model)."""
    out = []
    for k, sid in enumerate(field.mast_ids):
        sonic = cond["mast_sonics"][sid]
        meas = mast_measurement(mast.series[k, 0], mast.series[k, 1], mast.series[k, 2], mast.series[k, 3],
                                float(sonic["azimuth_deg"]), settings["mast"], streams("mast", k),
                                cond["mechanisms"], mast.first_record)
        keep = meas.keep
        out.append(toa5_record(_mast_file(list(sonic["files"]), cond["flight_id"], sid), mast.times[keep],
                               meas.record[keep], meas.ux_ms[keep], meas.uy_ms[keep], meas.uz_ms[keep],
                               meas.ts_c[keep], meas.diag_csat[keep], table=f"ts_{sid}"))
    return out


@dataclass(frozen=True)
class PayloadTruth:
    """The true state of one payload flight: everything the instruments see, before they measure it.

    Computed once per flight, seed and hover height (:func:`payload_truth`); every mechanism
    of the measurement stage (all but ``height_offset``, which moves the hover point in the
    field) is applied to it by :func:`payload_records`, so the forward model's probes of
    those mechanisms reuse one truth instead of re-drawing the turbulence and the motion.

    Attributes
    ----------
    flight_id : str
    seed : int
        The flight's seed (:func:`dronewind.simulate.settings.flight_seed`).
    hover_offset_dz_m : float
        ``height_offset.dz_m`` the truth was made with [m].
    atmosphere_digest : str
        Digest of the measured record that constrained the field (:func:`atmosphere_digest`;
        empty for the model atmosphere).
    atmosphere_info : dict
        What was used of that record (:func:`measured_constraint`).
    """

    flight_id: str
    seed: int
    hover_offset_dz_m: float
    clock: _FlightClock
    field: _FieldPoints
    air: _AirAtPayload
    motion: _Motion
    mast: _MastTruth
    #: the measured record the field was constrained by (:func:`measured_constraint`): its
    #: digest ("" without one) and what was used of it
    atmosphere_digest: str = ""
    atmosphere_info: dict[str, Any] = dataclasses.field(default_factory=dict, compare=False)
    #: records already measured from this truth without a mechanism on their instrument
    #: (:func:`payload_records`): a probe that leaves an instrument alone gets the same record
    memo: dict[tuple[str, str], Any] = dataclasses.field(default_factory=dict, compare=False, repr=False)
    #: the campaign's turbulence model the truth was made with (``simulation.atmosphere``)
    turbulence: str = ""


def _dz_m(cond: PayloadFlightConditions) -> float:
    return float(cond["mechanisms"].get("height_offset", {}).get("dz_m", 0.0))


def atmosphere_digest(record: xr.Dataset | None) -> str:
    """Digest of a measured atmosphere record's wind, temperature and time values ("" for none)."""
    if record is None:
        return ""
    arrays = {var: record[var].values for var in ("time", "u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k")
              if var in record.variables}
    # every run of a forward flight checks its truth against the record: inside the flight's runs
    # the same record is found by comparing it (dronewind.core.reuse), not hashed again
    return str(reused("atmosphere digest", arrays, "", lambda: content_digest(arrays)))


def payload_truth(campaign: CampaignLike, flight_id: str, atmosphere: xr.Dataset | None = None) -> PayloadTruth:
    """Turbulence at the hover point and the masts, and the payload's true motion, of one flight.

    Parameters
    ----------
    campaign : dict or manifest.Campaign
        Manifest content with a ``simulation:`` section (format in :mod:`dronewind.simulate`).
    flight_id : str
        Payload flight id.
    atmosphere : xarray.Dataset, optional
        The reference mast sonic's measured record (mast L1 names, datetime64 ``time``):
        the field is constrained by it and takes its spectra (:func:`measured_constraint`);
        by default the similarity model's field.

    Returns
    -------
    PayloadTruth
        Depends on the flight's conditions, the payload settings, the seed, the
        ``height_offset`` mechanism and the atmosphere record only.

    Raises
    ------
    InputError
        Invalid settings (named).
    """
    data = campaign_dict(campaign)
    settings = validate_simulation(data)
    cond = resolve_payload_flight(data, flight_id, settings)
    return _truth(data, settings, cond, atmosphere)


def _truth(data: Mapping[str, Any], settings: SimulationSettings, cond: PayloadFlightConditions,
           atmosphere: xr.Dataset | None = None) -> PayloadTruth:
    p, streams = cond["payload"], _Streams(cond["seed"])
    fs_s, fs_m = p["sonic_rate_hz"], settings["mast"]["rate_hz"]
    clock = _flight_clock(data, settings, cond, fs_s, fs_m)
    field = _field_points(cond)  # turbulence at the mast sonics (first) and the hover point
    spec, info = _turbulence(cond, clock, field, fs_s, fs_m, streams("turbulence"), atmosphere,
                             streams("spectral_sampling"))
    air = _air_at_payload(cond, clock, field, spec, fs_s)
    # what depends on the seed's streams but not on the hover point (the jitter; the field at
    # the masts, which comes first in the field's construction) is the same for the truths of
    # one seed at other hover heights (height_offset): inside a forward flight's runs, they find
    # it made (dronewind.core.reuse; read-only)
    jitter_settings = {k: p[k] for k in _JITTER_KEYS}
    jitter = reused("payload jitter", {}, repr((int(cond["seed"]), jitter_settings, clock.n_sonic, fs_s)),
                    lambda: _jitter(jitter_settings, streams("motion"), clock.n_sonic, fs_s))
    motion = _payload_motion(p, air, field, spec, jitter, fs_s)
    mast = _mast_truth(settings, clock, field, spec)
    masts = list(range(len(field.mast_ids)))
    t_mast = (mast.times - clock.field_t0) / np.timedelta64(1, "us") * 1e-6
    mast = dataclasses.replace(mast, series=_with_trend(cond, clock, spec, mast.series, masts, t_mast))
    return PayloadTruth(cond["flight_id"], int(cond["seed"]), _dz_m(cond), clock, field, air, motion, mast,
                        atmosphere_digest(atmosphere), info, turbulence=repr(sorted(cond["turbulence"].items())))


def payload_records(campaign: CampaignLike, flight_id: str, truth: PayloadTruth | None = None,
                    atmosphere: xr.Dataset | None = None) -> tuple[list[RawRecord], PayloadTruth]:
    """The raw records of one virtual payload flight and of every mast sonic, in memory.

    Parameters
    ----------
    campaign : dict or manifest.Campaign
        Manifest content with a ``simulation:`` section.
    flight_id : str
        Payload flight id.
    truth : PayloadTruth, optional
        The flight's true state from an earlier call (same conditions and seed, same
        ``height_offset``); computed when not given.
    atmosphere : xarray.Dataset, optional
        The reference mast's measured record (see :func:`payload_truth`).

    Returns
    -------
    records : list of RawRecord
        Sonic, INS, then one TOA5 per mast sonic: exactly what
        :func:`simulate_payload_flight` writes (its files are these records printed), with
        the sources the manifest names (relative to the campaign's data root).
    truth : PayloadTruth
        The true state used (to pass to further calls).

    Raises
    ------
    InputError
        Invalid settings (named); GNSS time not stable before the hover.
    ValueError
        A ``truth`` of another flight, seed, height offset, turbulence model or atmosphere record.
    """
    data = campaign_dict(campaign)
    settings = validate_simulation(data)
    cond = resolve_payload_flight(data, flight_id, settings)
    if truth is None:
        truth = _truth(data, settings, cond, atmosphere)
    elif (truth.flight_id, truth.seed, truth.hover_offset_dz_m, truth.atmosphere_digest) != (
            cond["flight_id"], int(cond["seed"]), _dz_m(cond), atmosphere_digest(atmosphere)):
        raise ValueError(f"truth of flight {truth.flight_id} seed {truth.seed} dz {truth.hover_offset_dz_m} m "
                         f"atmosphere {truth.atmosphere_digest or 'model'} does not belong to flight {flight_id} seed "
                         f"{cond['seed']} dz {_dz_m(cond)} m atmosphere {atmosphere_digest(atmosphere) or 'model'}")
    elif truth.turbulence != repr(sorted(cond["turbulence"].items())):
        raise ValueError(f"truth made with turbulence model {truth.turbulence} does not belong to a campaign with "
                         f"{sorted(cond['turbulence'].items())}")
    unknown = sorted(set(cond["mechanisms"]) - set().union(*INSTRUMENT_MECHANISMS.values(), {"height_offset"}))
    if unknown:  # a mechanism added to the simulator must be assigned to the instrument it acts on
        raise ValueError(f"mechanism(s) {unknown} act on no instrument of INSTRUMENT_MECHANISMS")
    p, streams, motion, flight = cond["payload"], _Streams(cond["seed"], truth.memo), truth.motion, cond["flight"]

    def sonic() -> RawRecord:
        v_body = _remembered(truth.memo, ("sonic air in body frame", repr(cond["mechanisms"].get("downwash"))),
                             lambda: _air_in_body(cond, truth.air, motion))
        v_sensor, t_c = _sonic_sensor_frame(cond, truth.air, v_body, streams)
        stamps = _sonic_stamps_us(cond, motion.t_s)
        return _sonic_log(str(flight["sonic"]["file"]), cond, stamps, v_sensor, t_c, streams)

    def ins() -> RawRecord:
        track = _remembered(truth.memo, ("ins track", repr(p["ins_rate_hz"])),
                            lambda: _ins_track(motion, p["ins_rate_hz"]))
        noise_settings = {k: p[k] for k in _INS_NOISE_KEYS}
        noise_key = repr((int(cond["seed"]), noise_settings, p["ins_rate_hz"], track[0].size))
        # the same for the truths of one seed at other hover heights (dronewind.core.reuse)
        noise = _remembered(truth.memo, ("ins noise", noise_key),
                            lambda: reused("INS noise", {}, noise_key, lambda: _ins_noise(
                                noise_settings, track[0].size, streams("ins_noise"), p["ins_rate_hz"])))
        rec = _add_ins_errors(cond, _ins_truth(cond, motion, track), noise)
        return _ins_log(str(flight["ins"]["file"]), cond, rec, _ins_validity(cond, rec.t_s), motion.t_s[0], streams)

    records = [_measured(truth, cond, settings, "sonic", sonic), _measured(truth, cond, settings, "ins", ins)]
    return records + _measured(truth, cond, settings, "mast",
                               lambda: _mast_logs(cond, settings, truth.field, truth.mast, streams)), truth


#: The mechanisms that act on each instrument's record (all others act on the true state).
INSTRUMENT_MECHANISMS: dict[str, frozenset[str]] = {
    "sonic": frozenset({"sonic_ins_lag", "clock_drift", "mount_misalignment", "w_gain", "sonic_noise", "downwash"}),
    "ins": frozenset({"heading_bias", "attitude_lag", "lever_arm"}),
    "mast": frozenset({"mast_w_attenuation"}),
}


def _measured(truth: PayloadTruth, cond: PayloadFlightConditions, settings: SimulationSettings, instrument: str,
              measure: Callable[[], Any]) -> Any:
    """An instrument's record from a truth: measured once where no mechanism acts on the instrument.

    The record without a mechanism on the instrument is the one every probe of another
    instrument reads again (a sonic probe reads the INS and mast records of the baseline), so
    it is kept in the truth's memo. The key holds everything the record depends on besides the
    truth: the payload, defect and mast settings, the times and, for the sonic, the flight's
    processing lag. A record with a mechanism on
    the instrument (a probe level, an extended model) is read by one run only: it is measured
    and not kept, which would hold every probe's records as long as the truth (with them and
    each run's products kept until the next run, a published-numbers job of sample s05 held
    168.5 MB once its runs were made, 74.9 MB without: ``benchmarks/bench_job_memory.py``,
    ``results/job_memory_s31_{start,new}.json``).
    """
    if any(name in cond["mechanisms"] for name in INSTRUMENT_MECHANISMS[instrument]):
        return measure()
    lag = (cond["sonic_ins_lag_s"],) if instrument == "sonic" else ()
    key = (instrument, repr((cond["payload"], cond["defects"], settings["mast"], str(cond["start"]),
                             str(flight_timeline(cond)), *lag)))
    return _remembered(truth.memo, key, measure)


def simulate_payload_flight(campaign: CampaignLike, manifest_dir: Path, flight_id: str,
                            out_dir: Path) -> list[Path]:
    """Write the L0 files of one virtual payload flight and of every mast sonic.

    Parameters
    ----------
    campaign : dict or manifest.Campaign
        Manifest content with a ``simulation:`` section (format in
        :mod:`dronewind.simulate`).
    manifest_dir : Path
        Folder of the manifest (kept for symmetry with measured campaigns; the output
        paths are relative to ``out_dir``).
    flight_id : str
        Payload flight id.
    out_dir : Path
        Root of the simulated campaign's files: the sonic and INS files go to
        ``out_dir / <manifest path>``, each mast sonic to ``out_dir / <its files glob
        with '*' replaced by the flight id>`` (TOA5 covering the flight with margin).

    Returns
    -------
    list of Path
        Written files: sonic CSV, INS CSV, then one TOA5 per mast sonic.

    Raises
    ------
    InputError
        Invalid settings (named), overlapping flights, a mast glob without ``*``.

    Notes
    -----
    Deterministic: the flight's seed is SHA-256 of ``"<simulation.seed>:<flight id>"``;
    separate random streams serve turbulence, motion, INS noise, sonic noise, each
    noise mechanism and the defects, so switching one mechanism leaves the other draws
    unchanged. Reruns are bit-identical.

    References
    ----------
    Ghirardelli et al. (2025), Sects 2.3, 3.1-3.2, 4, Tables 2-4 and Appendix A.
    """
    records, _ = payload_records(campaign, flight_id)  # raises before anything is written
    return [write_record(Path(out_dir) / rec.source, rec) for rec in records]
