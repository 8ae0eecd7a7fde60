"""Flight plan and clock of a simulated SAMURAI-S payload flight.

Flight plan (Ghirardelli et al. 2025, Sects. 2-3): payload on the ground (held) for
``ground_before_s``, vertical ascent at ``ascent_rate_ms``, hover from ``hover_margin_s``
before the hover window to ``hover_margin_s`` after it, descent at ``descent_rate_ms``,
ground time; corners are smoothed over 2 s (:func:`flight_timeline`, :func:`_smooth_path`).
The random streams of a flight have fixed purpose numbers (``_STREAM``), so that switching
one mechanism leaves the others' draws unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dronewind.core.constants import GRAVITY_MS2
from dronewind.core.geo import local_tangent_plane_m
from dronewind.core.reuse import reused
from dronewind.errors import InputError
from dronewind.simulate.settings import (
    PayloadFlightConditions,
    SimulationSettings,
    resolve_payload_flight,
)

__all__ = [
    "flight_timeline",
]


_G = GRAVITY_MS2


_Z_GROUND_M = 0.5  # payload height while on the ground [m]


_MOUNTS = {"upside_down": np.eye(3), "upright": np.diag([1.0, -1.0, -1.0])}


# random streams (fixed purpose numbers so that switching one mechanism leaves the others' draws)
_STREAM = {"turbulence": 0, "motion": 1, "ins_noise": 2, "sonic_noise": 3, "noise_mechanism": 4,
           "sonic_defects": 5, "ins_defects": 6, "spectral_sampling": 7, "mast": 100}


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


def _mast_offsets_enu(site: Mapping[str, Any], sonic: Mapping[str, Any]) -> tuple[float, float]:
    """East, north offset [m] of a mast sonic from the site position (WGS84 local tangent plane)."""
    lat0 = float(site.get("latitude", sonic["latitude"]))
    lon0 = float(site.get("longitude", sonic["longitude"]))
    de, dn = local_tangent_plane_m(sonic["latitude"], sonic["longitude"], lat0, lon0)
    return float(de), float(dn)


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


def _smooth_path(t: np.ndarray, knots_t: list[float], knots_z: list[float], fs_hz: float,
                 width_s: float = 2.0) -> np.ndarray:
    z = np.interp(t, knots_t, knots_z)
    n = max(int(width_s * fs_hz), 1)
    kernel = np.ones(n) / n
    zp = np.concatenate([np.full(n, z[0]), z, np.full(n, z[-1])])
    return np.convolve(zp, kernel, mode="same")[n:-n]


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


def _remembered(memo: dict[tuple[str, str], Any], key: tuple[str, str], make: Callable[[], Any]) -> Any:
    """``memo[key]``, made by ``make()`` the first time."""
    if key not in memo:
        memo[key] = make()
    return memo[key]
