"""The wind the simulated payload and the mast sonics see.

The turbulent field comes from :mod:`dronewind.simulate.atmosphere` at the mast sonics
(generated first, so they do not depend on the payload's position) and at the hover
point, with the campaign's turbulence model (``simulation.atmosphere``: spectral shape
and sigma factors, :func:`~dronewind.simulate.departures.reshape_field`; mean-wind
trends about the hover-window centre, :func:`~dronewind.simulate.departures.mean_wind_trend`)
seen alike by the payload and the masts. A measured mast record may constrain the field
(:func:`measured_constraint`). During ascent and descent the payload sees the hover
point's fluctuations with the mean wind of its current height (an approximation: only
hover data are analysed); the payload's own swing (about a metre) is not used to
re-sample the field.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core import surface_layer
from dronewind.core.reuse import reused
from dronewind.errors import InputError
from dronewind.simulate import atmosphere as atm
from dronewind.simulate import constraint, departures, spectral_model
from dronewind.simulate.payload_flight import _Z_GROUND_M, _FlightClock, _mast_offsets_enu, _smooth_path
from dronewind.simulate.settings import (
    PayloadFlightConditions,
)

__all__ = [
    "measured_constraint",
    "recorded_span_s",
    "MAX_BRIDGED_GAP_S",
    "check_atmosphere_record",
]


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
        ``interpolated_samples`` (missing samples inside it, interpolated linearly),
        ``record_rate_hz``, ``gaps_cut`` (gaps that ended the span, :func:`recorded_span_s`).

    Raises
    ------
    InputError
        A record without the variables, shorter than half the field period or not covering
        the hover window.

    Notes
    -----
    The record is put on the field's grid at its own rate from ``field_t0``; where the field
    period reaches beyond the record (the forward flight's log span plus mast margin may be
    wider than what was recorded around the measured flight) or beyond a gap of more than
    :data:`MAX_BRIDGED_GAP_S` outside the hover window (:func:`recorded_span_s`), it is
    mirrored at the span's ends, which keeps its spectrum and continuity. Only the hover
    window enters the features; that part must be measured.
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
    hover = (clock.hover_start_field_s, clock.hover_start_field_s + hover_duration_s)
    lo, hi, n_cut = recorded_span_s(t_rec[finite], hover, dt)
    if lo > hover[0] + dt or hi < hover[1] - dt:
        raise InputError(where, f"the record covers field time {lo:.1f}..{hi:.1f} s, not the hover window "
                                f"{hover[0]:.1f}..{hover[1]:.1f} s")
    if 2 * (hi - lo) < period_s:
        raise InputError(where, f"the record covers {hi - lo:.1f} s without a gap of more than "
                                f"{MAX_BRIDGED_GAP_S:g} s around the hover, less than half the field period "
                                f"{period_s:.1f} s")
    # mirror at the ends: t < lo -> 2 lo - t, t > hi -> 2 hi - t (reflected again, should
    # that leave the span: a triangle wave of period 2 (hi - lo), which stays in it)
    span = hi - lo
    u = np.mod(grid - lo, 2 * span)
    mirrored = lo + np.where(u <= span, u, 2 * span - u)
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
                 "interpolated_samples": n_interp, "record_rate_hz": 1.0 / dt, "gaps_cut": n_cut}


#: Longest gap of a measured record bridged by linear interpolation outside the hover window
#: [s] (:func:`recorded_span_s`).
MAX_BRIDGED_GAP_S = 1.0


def recorded_span_s(t_finite_s: np.ndarray, hover_s: tuple[float, float], dt_s: float) -> tuple[float, float, int]:
    """The span of a record around the hover window without a gap longer than :data:`MAX_BRIDGED_GAP_S`.

    Parameters
    ----------
    t_finite_s : numpy.ndarray
        Times of the record's valid samples [s], increasing.
    hover_s : tuple of float
        Start and end of the hover window [s].
    dt_s : float
        The record's sample step [s].

    Returns
    -------
    lo, hi : float
        First and last valid time of the span [s]: the record's ends, or the last valid
        sample before the first longer gap on either side of the hover window.
    n_cut : int
        Gaps that ended the span (0-2).

    Notes
    -----
    A measured mast record seldom runs without a break from before a flight to after it: its
    files may stop between flights, the logger may drop out. Linear interpolation across a
    gap of seconds to minutes is a straight line without fluctuations; in a forward flight's
    field period it would lower the record's spectral level, which the constraint carries to
    the hover point (:func:`dronewind.simulate.constraint.constraint_from_record`), by the
    share of the period the gap fills (a 110 s gap in a 19 min period: about 10 % of the
    power at every frequency). The span therefore ends at such a gap, and
    :func:`measured_constraint` mirrors the record beyond it. Gaps inside the hover window
    are bridged whatever their length: the hover is what the forward runs reproduce, and the
    chain bridges them alike.
    """
    t = np.asarray(t_finite_s, float)
    long = np.flatnonzero(np.diff(t) > max(MAX_BRIDGED_GAP_S, 1.5 * dt_s))  # gap between t[k] and t[k+1]
    before = long[t[long + 1] <= hover_s[0] + dt_s]
    after = long[t[long] >= hover_s[1] - dt_s]
    lo = float(t[before[-1] + 1]) if before.size else float(t[0])
    hi = float(t[after[0]]) if after.size else float(t[-1])
    return lo, hi, int(before.size > 0) + int(after.size > 0)


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
