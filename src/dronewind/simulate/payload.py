"""Virtual SAMURAI-S flight: sling-load payload, INS, sonic, and the mast sonics.

Physics (Ghirardelli et al. 2025, Sects 2-3), by module:

* flight plan, flight clock and random streams: :mod:`dronewind.simulate.payload_flight`;
* the wind at the payload and at the mast sonics: :mod:`dronewind.simulate.payload_wind`;
* drone jitter, the payload's pendulum and its attitude: :mod:`dronewind.simulate.payload_motion`;
* the instrument records, here.

Instruments:

* Sonic (RM Young 81000, 32 Hz, Table 2): air velocity relative to the sensor in the
  sensor frame, the exact inverse of the chain's motion correction
  (``docs/data-contract.md``) V_wind = R(phi, theta, psi) V_body + V_ins,
  V_body = M_mount V_sensor; white noise ``sonic_noise_ms`` and resolution 0.01 m/s (0.01 K).
* INS (Ellipse-D EKF, 50 Hz, Table 3): velocity of the sonic volume (NED), attitude,
  lat/lon (WGS84 local tangent plane of :mod:`dronewind.core.geo`, the chain's own Earth
  model) and alt MSL with Gauss-Markov errors of the Table 3 accuracies; GNSS time valid
  only ``gnss_acquisition_s`` after logging starts, with one blink of
  ``gnss_blink_s`` (< 10 s) halfway before; EKF valid after ``ekf_init_s``.
* Sonic-INS processing lag: the sonic's rows are stamped ``sonic_ins_lag_s`` late against
  the INS's (the time the chain must add to the sonic clock, ``lag_sonic_ins_s`` of
  ``docs/data-contract.md``), per flight: its ``simulation.payload_flights.<id>.sonic_ins_lag_s``,
  else drawn from the flight's seed in [``sonic_ins_lag_low_s``, ``sonic_ins_lag_high_s``],
  by default [-0.185, 0] s, the range of the ten validation flights' lags (Ghirardelli et
  al. 2025, Sect. 3.3, Fig. 4; :func:`dronewind.simulate.settings.processing_lag_s`). The
  ``sonic_ins_lag`` mechanism adds to it; the lag holds at the centre of the hover window,
  the ``clock_drift`` mechanism moves it about there.
* Logger clock: ``rpi_time_us`` = (UTC + ``logger_clock_offset_s``) with
  ``logger_clock_drift_ppm``, shared by both files.
* Row defects (missing, duplicated, swapped, out-of-range) at the ``defects`` rates.

Mechanisms act inside this measurement model (see :mod:`dronewind.mechanisms`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from scipy.interpolate import CubicSpline

from dronewind.core.constants import ZERO_CELSIUS_K
from dronewind.core.geo import from_local_tangent_plane
from dronewind.core.raw import RawRecord, content_digest
from dronewind.core.reuse import reused
from dronewind.errors import InputError
from dronewind.simulate import atmosphere as atm
from dronewind.simulate.mast import mast_measurement
from dronewind.simulate.payload_flight import (
    _MOUNTS,
    _flight_clock,
    _FlightClock,
    _remembered,
    _Streams,
    flight_timeline,
)
from dronewind.simulate.payload_motion import (
    _JITTER_KEYS,
    _air_in_body,
    _jitter,
    _lowpass_noise,
    _Motion,
    _payload_motion,
    body_to_ned,
)
from dronewind.simulate.payload_wind import (
    _air_at_payload,
    _AirAtPayload,
    _field_points,
    _FieldPoints,
    _turbulence,
    _with_trend,
)
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
    "simulate_payload_flight",
    "payload_records",
    "payload_truth",
    "PayloadTruth",
    "atmosphere_digest",
]


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


def _mast_file(pattern_list: list[str], flight_id: str, sonic_id: str) -> str:
    """A mast sonic's file of one flight: its first files glob with '*' replaced by the flight id."""
    for pattern in pattern_list:
        if "*" in pattern:
            return pattern.replace("*", flight_id)
    raise InputError(f"masts.sonics.{sonic_id}.files",
                     "a simulated campaign needs a glob with '*' (replaced by the flight id), "
                     f"got {pattern_list}")


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
    align it with the INS (the data contract's ``lag_sonic_ins_s``). The flight's lag holds
    at the centre of the hover window (flight time ``duration_s / 2``) and a clock drift moves
    the lag about it: the chain's lag search finds the lag over the hover, and the forward
    runs of a measured flight take that lag as a condition, so a drift about any other time
    would shift the forward's mean lag away from the measured one by the drift's share
    (300 ppm over half a 12-min hover and its margins: about 0.15 s) and penalise the drift
    in every feature that the sonic-INS alignment moves.
    """
    mech, log_t0 = cond["mechanisms"], t_s[0]
    t_stamp = t_s - cond["sonic_ins_lag_s"]
    if "sonic_ins_lag" in mech:
        t_stamp = t_stamp - mech["sonic_ins_lag"]["lag_s"]
    if "clock_drift" in mech:
        t_stamp = t_stamp + mech["clock_drift"]["ppm"] * 1e-6 * (t_s - 0.5 * cond["duration_s"])
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
                                    "ins_vertical_position_noise_m", "ins_heading_offset_deg")


def _ins_noise(p: Mapping[str, Any], n: int, rng: np.random.Generator, fs_hz: float) -> tuple[np.ndarray, ...]:
    """Gauss-Markov errors of the Table 3 accuracies (Ghirardelli et al. 2025) for ``n`` INS rows.

    ``rng`` (the INS-noise stream) is drawn in the order vel N, E, D, roll, pitch, yaw,
    position E, N, up, then (only when ``ins_heading_offset_deg`` is not 0, so that the other
    errors do not depend on it) the heading offset held over the flight; the arrays are
    returned in that order, read-only, the offset as a 0-d array (0 when not drawn). They
    depend on the stream, the payload's noise settings, ``n`` and ``fs_hz`` only, so every INS
    probe of a truth shares them (:func:`payload_records`).
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
    sigma_offset = float(p["ins_heading_offset_deg"])
    noise += (np.asarray(sigma_offset * rng.standard_normal() if sigma_offset > 0 else 0.0),)
    for arr in noise:
        arr.setflags(write=False)
    return noise


def _add_ins_errors(cond: PayloadFlightConditions, ins: _InsRecord, noise: Sequence[np.ndarray]) -> _InsRecord:
    """The INS errors (:func:`_ins_noise`) and ``heading_bias`` added; yaw wrapped to (-180, 180]."""
    mech = cond["mechanisms"]
    n_vn, n_ve, n_vd, n_roll, n_pitch, n_yaw, n_e, n_n, n_up, yaw_offset = noise
    vn = ins.vel_n_ms + n_vn
    ve = ins.vel_e_ms + n_ve
    vd = ins.vel_d_ms + n_vd
    roll_i = ins.roll_deg + n_roll
    pitch_i = ins.pitch_deg + n_pitch
    # the offset held over the flight last: where none is drawn, adding 0.0 leaves every yaw as it was
    yaw_unw = ins.yaw_deg + n_yaw + mech.get("heading_bias", {}).get("deg", 0.0) + float(yaw_offset)
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


def _mast_truth(mast_settings: Mapping[str, float], clock: _FlightClock, field: _FieldPoints,
                spec: atm.FieldSpec) -> _MastTruth:
    """The field at the mast sonics on the logger's grid (RECORD counted from 2020-01-01).

    ``mast_settings`` is the flight's ``mast`` block (its rate, :func:`resolve_payload_flight`).
    """
    us = np.timedelta64(1, "us")
    fs_m = mast_settings["rate_hz"]
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


def _mast_logs(cond: PayloadFlightConditions, field: _FieldPoints, mast: _MastTruth,
               streams: _Streams) -> list[RawRecord]:
    """One TOA5 per mast sonic over the mast span (CSAT3 measurement model)."""
    out = []
    for k, sid in enumerate(field.mast_ids):
        sonic = cond["mast_sonics"][sid]
        meas = mast_measurement(mast.series[k, 0], mast.series[k, 1], mast.series[k, 2], mast.series[k, 3],
                                float(sonic["azimuth_deg"]), cond["mast"], streams("mast", k),
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
    fs_s, fs_m = p["sonic_rate_hz"], cond["mast"]["rate_hz"]
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
    mast = _mast_truth(cond["mast"], clock, field, spec)
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

    records = [_measured(truth, cond, "sonic", sonic), _measured(truth, cond, "ins", ins)]
    return records + _measured(truth, cond, "mast",
                               lambda: _mast_logs(cond, truth.field, truth.mast, streams)), truth


#: The mechanisms that act on each instrument's record (all others act on the true state).
INSTRUMENT_MECHANISMS: dict[str, frozenset[str]] = {
    "sonic": frozenset({"sonic_ins_lag", "clock_drift", "mount_misalignment", "w_gain", "sonic_noise", "downwash"}),
    "ins": frozenset({"heading_bias", "attitude_lag", "lever_arm"}),
    "mast": frozenset({"mast_w_attenuation"}),
}


def _measured(truth: PayloadTruth, cond: PayloadFlightConditions, instrument: str,
              measure: Callable[[], Any]) -> Any:
    """An instrument's record from a truth: measured once where no mechanism acts on the instrument.

    The record without a mechanism on the instrument is the one every probe of another
    instrument reads again (a sonic probe reads the INS and mast records of the baseline), so
    it is kept in the truth's memo. The key holds everything the record depends on besides the
    truth: the payload, defect and mast settings, the times and, for the sonic, the flight's
    processing lag. A record with a mechanism on
    the instrument (a probe level, an extended model) is read by one run only: it is measured
    and not kept, which would hold every probe's records as long as the truth (with them,
    a published-numbers job holds about twice the memory once its runs are made).
    """
    if any(name in cond["mechanisms"] for name in INSTRUMENT_MECHANISMS[instrument]):
        return measure()
    lag = (cond["sonic_ins_lag_s"],) if instrument == "sonic" else ()
    key = (instrument, repr((cond["payload"], cond["defects"], cond["mast"], str(cond["start"]),
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
