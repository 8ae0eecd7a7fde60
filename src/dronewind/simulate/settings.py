"""Validation of a manifest's ``simulation:`` section (payload flights and mast sonics).

The format is documented in :mod:`dronewind.simulate` (package docstring). Every
problem raises :class:`dronewind.errors.InputError` whose ``where`` is the setting's key
path (e.g. ``simulation.payload_flights.s03.mean_speed_ms``) and whose message says what
was expected, with units and the physical range.

Quadrotor and tunnel settings (``simulation.quadrotor_flights``, ``simulation.tunnel``)
belong to other modules and are not checked here; mechanisms of the quadrotor platform
are validated against the catalog but ignored by the payload simulator.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import math
from collections.abc import Mapping
from typing import Any, Protocol, TypedDict, cast

import numpy as np

from dronewind.errors import InputError
from dronewind.mechanisms import ParameterValue, get_mechanism, validate_parameters
from dronewind.simulate.defaults import (
    ATMOSPHERE_DEFAULTS,
    DEFECT_DEFAULTS,
    MAST_DEFAULTS,
    PAYLOAD_DEFAULTS,
    PROCESSING_LAG_STREAM,
    SONIC_INS_LAG_RANGE_S,
    SPECTRA,
    TURBULENCE_DEFAULTS,
)

__all__ = [
    "simulation_manifest",
    "CampaignLike",
    "MechanismEntry",
    "SimulationSettings",
    "PayloadFlightConditions",
    "TurbulenceModel",
    "campaign_dict",
    "parse_time",
    "flight_seed",
    "processing_lag_s",
    "validate_simulation",
    "resolve_payload_flight",
    "check_payload_settings",
    "flight_rate_range_hz",
]


_FLIGHT_KEYS = {
    "mean_speed_ms", "wind_from_deg", "z_over_L", "obukhov_length_m", "z_ref_m", "hover_height_m",
    "start", "duration_s", "flight_duration_s", "hover_offset_enu_m", "sonic_ins_lag_s", *ATMOSPHERE_DEFAULTS,
    "sonic_rate_hz", "ins_rate_hz", "mast_rate_hz",
}

#: Per-flight rate keys of ``simulation.payload_flights.<id>``: the block and key each overrides.
_FLIGHT_RATES = {"sonic_rate_hz": ("payload", "sonic_rate_hz"), "ins_rate_hz": ("payload", "ins_rate_hz"),
                 "mast_rate_hz": ("mast", "rate_hz")}


def flight_rate_range_hz(key: str) -> tuple[float, float]:
    """Range [Hz] of a per-flight rate key (``sonic_rate_hz``, ``ins_rate_hz``, ``mast_rate_hz``):
    that of the ``simulation.payload`` or ``simulation.mast`` setting it overrides."""
    block, name = _FLIGHT_RATES[key]
    _, lo, hi, _ = (PAYLOAD_DEFAULTS if block == "payload" else MAST_DEFAULTS)[name]
    return lo, hi


class ManifestLike(Protocol):
    """An object holding a parsed manifest in ``data`` (such as ``dronewind.manifest.Campaign``)."""

    @property
    def data(self) -> Mapping[str, Any]:
        """The manifest content."""
        ...


#: A parsed manifest (YAML content, hence ``Any`` values) or an object holding one.
CampaignLike = Mapping[str, Any] | ManifestLike


class MechanismEntry(TypedDict):
    """One validated ``simulation.mechanisms`` item."""

    mechanism: str
    #: Catalog parameters (floats; identifiers or tables for some quadrotor mechanisms).
    parameters: dict[str, ParameterValue]
    #: Flight ids it acts on (None: every flight).
    flights: list[str] | None
    platforms: tuple[str, ...]


class TurbulenceModel(TypedDict):
    """The validated turbulence model of ``simulation.atmosphere`` (:data:`TURBULENCE_DEFAULTS`)."""

    #: One of :data:`SPECTRA`.
    spectrum: str
    sigma_u_factor: float
    sigma_v_factor: float
    sigma_w_factor: float
    length_scale_factor: float
    speed_trend_ms_per_h: float
    direction_trend_deg_per_h: float


class SimulationSettings(TypedDict):
    """Output of :func:`validate_simulation` (every number with its default filled in)."""

    seed: int
    atmosphere: dict[str, float]
    #: Spectrum, sigma factors and mean-wind trends (defaults: the similarity model).
    turbulence: TurbulenceModel
    payload: dict[str, float]
    #: ``sonic`` and ``ins`` row-defect rates.
    defects: dict[str, dict[str, float]]
    mast: dict[str, float]
    mechanisms: list[MechanismEntry]
    #: Raw per-flight condition mappings (checked by :func:`resolve_payload_flight`).
    payload_flights: dict[str, Any]


class PayloadFlightConditions(TypedDict):
    """Output of :func:`resolve_payload_flight`: every condition of one payload flight."""

    flight_id: str
    #: The manifest's payload flight entry.
    flight: dict[str, Any]
    #: Id of the reference mast sonic.
    reference: str
    #: Sonic id -> manifest sonic entry plus ``mast_id``, ``latitude``, ``longitude``.
    mast_sonics: dict[str, dict[str, Any]]
    site: dict[str, Any]
    mean_speed_ms: float
    wind_from_deg: float
    z_ref_m: float
    obukhov_length_m: float
    roughness_length_m: float
    boundary_layer_height_m: float
    theta_mean_k: float
    #: Spectrum, sigma factors and mean-wind trends of the campaign.
    turbulence: TurbulenceModel
    hover_height_m: float
    #: Hover-window start (naive UTC).
    start: np.datetime64
    duration_s: float
    payload: dict[str, float]
    defects: dict[str, dict[str, float]]
    mast: dict[str, float]
    #: Payload/mast mechanisms active in this flight: name -> parameters.
    mechanisms: dict[str, dict[str, float]]
    flight_duration_s: float | None
    hover_offset_enu_m: list[float]
    seed: int
    sonic_mount: str
    #: The flight's sonic-INS processing lag [s]: time to add to the sonic's clock to align
    #: it with the INS (its ``sonic_ins_lag_s``, else drawn, :func:`processing_lag_s`).
    sonic_ins_lag_s: float


def campaign_dict(campaign: CampaignLike) -> dict[str, Any]:
    """The manifest content as a dict.

    Parameters
    ----------
    campaign : dict or manifest.Campaign
        Parsed manifest, or an object with a ``data`` mapping.

    Returns
    -------
    dict
        Shallow copy of the manifest mapping.
    """
    data = getattr(campaign, "data", campaign)
    if not isinstance(data, Mapping):
        raise InputError("campaign", f"expected a manifest mapping, got {type(data).__name__}")
    return dict(data)


def parse_time(value: str | _dt.datetime, where: str) -> np.datetime64:
    """Parse a UTC time of the manifest.

    Parameters
    ----------
    value : str or datetime.datetime
        ISO 8601 UTC (trailing ``Z`` or ``+00:00`` optional) or a datetime (YAML).
    where : str
        Setting path for the error message.

    Returns
    -------
    numpy.datetime64
        Naive ``datetime64[us]`` meaning UTC.
    """
    if isinstance(value, _dt.datetime):
        if value.tzinfo is not None:
            value = value.astimezone(_dt.UTC).replace(tzinfo=None)
        return np.datetime64(value, "us")
    text = str(value).strip()
    if text.endswith("Z"):
        text = text[:-1]
    for suffix in ("+00:00", "+0000"):
        if text.endswith(suffix):
            text = text[: -len(suffix)]
    try:
        return np.datetime64(text.replace(" ", "T"), "us")
    except ValueError:
        raise InputError(where, f"{value!r} is not an ISO 8601 UTC time (e.g. 2023-08-21T14:05:32Z)") from None


def flight_seed(campaign_seed: int, flight_id: str) -> int:
    """Seed of one flight: SHA-256 of ``"<campaign seed>:<flight id>"`` (first 8 bytes).

    Parameters
    ----------
    campaign_seed : int
    flight_id : str

    Returns
    -------
    int
        Non-negative 64-bit seed; independent of Python's hash randomisation.
    """
    digest = hashlib.sha256(f"{int(campaign_seed)}:{flight_id}".encode()).digest()
    return int.from_bytes(digest[:8], "little")


def processing_lag_s(seed: int, low_s: float, high_s: float) -> float:
    """A flight's sonic-INS processing lag, drawn uniformly in [low_s, high_s] from its seed.

    Every sonic-INS system has a processing lag of its own, different from flight to flight:
    the lags of minimum TKE of the ten SAMURAI-S validation flights lie between -0.185 s and
    0 s (Ghirardelli et al. 2025, Sect. 3.3, Fig. 4), the defaults of ``low_s`` and
    ``high_s`` (``simulation.payload.sonic_ins_lag_low_s``, ``sonic_ins_lag_high_s``).

    Parameters
    ----------
    seed : int
        The flight's seed (:func:`flight_seed`).
    low_s, high_s : float
        Range [s], ``low_s <= high_s``; equal: that value, nothing drawn.

    Returns
    -------
    float
        Lag [s] (time to add to the sonic's clock to align it with the INS, the data contract's
        ``lag_sonic_ins_s``), rounded to 1 microsecond (the logger's stamp resolution).

    Examples
    --------
    >>> processing_lag_s(1, 0.0, 0.0)
    0.0
    >>> -0.185 <= processing_lag_s(1, -0.185, 0.0) <= 0.0
    True
    """
    if low_s == high_s:
        return float(low_s)
    value = np.random.default_rng([int(seed), PROCESSING_LAG_STREAM]).uniform(low_s, high_s)
    return round(float(value), 6)


def _number(value: object, where: str, lower: float, upper: float, unit: str,
            lower_exclusive: bool = False) -> float:
    """``value`` as a float within [lower, upper] [unit], or an InputError naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(where, f"expected a number [{unit}], got {value!r}")
    x = float(value)
    low_bad = x <= lower if lower_exclusive else x < lower
    if not math.isfinite(x) or low_bad or x > upper:
        br = "(" if lower_exclusive else "["
        raise InputError(where, f"{x!r} outside the physical range {br}{lower}, {upper}] [{unit}]")
    return x


def _block(section: Mapping[str, Any] | None, defaults: dict[str, tuple[float, float, float, str]],
           where: str, exclusive: tuple[str, ...] = ()) -> dict[str, float]:
    """A settings block checked against its defaults table (unknown keys rejected, defaults filled in)."""
    section = dict(section or {})
    if not isinstance(section, dict):
        raise InputError(where, "expected a mapping")
    unknown = sorted(set(section) - set(defaults))
    if unknown:
        raise InputError(f"{where}.{unknown[0]}", f"unknown setting; expected one of {sorted(defaults)}")
    out = {}
    for key, (default, lo, hi, unit) in defaults.items():
        out[key] = _number(section.get(key, default), f"{where}.{key}", lo, hi, unit,
                           lower_exclusive=key in exclusive)
    return out


#: Payload settings whose lower bound is excluded (a line, a mass and a drag area are positive).
PAYLOAD_EXCLUSIVE: tuple[str, ...] = ("pendulum_length_m", "mass_kg", "drag_area_m2")


def check_payload_settings(section: Mapping[str, Any] | None, where: str = "simulation.payload") -> dict[str, float]:
    """Payload settings checked against :data:`~dronewind.simulate.defaults.PAYLOAD_DEFAULTS` (no ``defects``).

    Parameters
    ----------
    section : mapping or None
        Settings to check (keys of ``simulation.payload``).
    where : str
        Name of the section in error messages.

    Returns
    -------
    dict
        The settings given, as floats (defaults not filled in).

    Raises
    ------
    InputError
        An unknown key, or a value that is not a number within its range.
    """
    if section is not None and not isinstance(section, Mapping):
        raise InputError(where, "expected a mapping of payload settings")
    checked = _block(section, PAYLOAD_DEFAULTS, where, exclusive=PAYLOAD_EXCLUSIVE)
    return {key: checked[key] for key in (section or {})}


def _mechanisms(sim: Mapping[str, Any], flight_ids: set[str]) -> list[MechanismEntry]:
    """The ``simulation.mechanisms`` list checked against the catalog and the flight ids."""
    items = sim.get("mechanisms") or []
    if not isinstance(items, list):
        raise InputError("simulation.mechanisms", "expected a list of {mechanism, parameters, flights}")
    out: list[MechanismEntry] = []
    for i, item in enumerate(items):
        where = f"simulation.mechanisms[{i}]"
        if not isinstance(item, Mapping) or "mechanism" not in item:
            raise InputError(where, "expected a mapping with key 'mechanism' (and 'parameters', "
                                    "optional 'flights')")
        unknown = sorted(set(item) - {"mechanism", "parameters", "flights"})
        if unknown:
            raise InputError(f"{where}.{unknown[0]}", "unknown key; expected mechanism, parameters, flights")
        mech = get_mechanism(item["mechanism"], f"{where}.mechanism")
        params = validate_parameters(mech.name, item.get("parameters"), f"{where}.parameters")
        flights = item.get("flights")
        if flights is not None:
            if not isinstance(flights, list) or not all(isinstance(f, str) for f in flights):
                raise InputError(f"{where}.flights", "expected a list of flight ids")
            bad = [f for f in flights if f not in flight_ids]
            if bad:
                raise InputError(f"{where}.flights", f"unknown flight id(s) {bad}; known: {sorted(flight_ids)}")
        out.append(MechanismEntry(mechanism=mech.name, parameters=params,
                                  flights=None if flights is None else list(flights), platforms=mech.platforms))
    return out


def _simulation_section(data: Mapping[str, Any]) -> Mapping[str, Any]:
    """The ``simulation:`` mapping, its keys and its seed checked."""
    sim = data.get("simulation")
    if not isinstance(sim, Mapping) or not sim:
        raise InputError("simulation", "the manifest has no simulation: section (a measured campaign)")
    allowed = {"seed", "atmosphere", "payload", "mast", "payload_flights", "mechanisms",
               "quadrotor_flights", "quadrotor", "tunnel", "description"}
    unknown = sorted(set(sim) - allowed)
    if unknown:
        raise InputError(f"simulation.{unknown[0]}", f"unknown setting; expected one of {sorted(allowed)}")
    seed = sim.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError("simulation.seed", f"expected a non-negative integer, got {seed!r}")
    return sim


def _payload_settings(sim: Mapping[str, Any]) -> tuple[dict[str, float], dict[str, dict[str, float]]]:
    """``simulation.payload`` and its ``defects`` (sonic, ins) with defaults filled in."""
    payload_raw = dict(sim.get("payload") or {})
    defects_raw = payload_raw.pop("defects", None) or {}
    if not isinstance(defects_raw, Mapping):
        raise InputError("simulation.payload.defects", "expected a mapping with keys sonic, ins")
    bad = sorted(set(defects_raw) - {"sonic", "ins"})
    if bad:
        raise InputError(f"simulation.payload.defects.{bad[0]}", "unknown key; expected sonic or ins")
    payload = _block(payload_raw, PAYLOAD_DEFAULTS, "simulation.payload",
                     exclusive=PAYLOAD_EXCLUSIVE)
    if payload["sonic_ins_lag_low_s"] > payload["sonic_ins_lag_high_s"]:
        raise InputError("simulation.payload.sonic_ins_lag_low_s",
                         f"{payload['sonic_ins_lag_low_s']} s is above sonic_ins_lag_high_s = "
                         f"{payload['sonic_ins_lag_high_s']} s (expected low <= high)")
    defects = {k: _block(defects_raw.get(k), DEFECT_DEFAULTS, f"simulation.payload.defects.{k}")
               for k in ("sonic", "ins")}
    return payload, defects


def _atmosphere_settings(sim: Mapping[str, Any]) -> tuple[dict[str, float], TurbulenceModel]:
    """``simulation.atmosphere``: the per-flight defaults and the campaign's turbulence model."""
    where = "simulation.atmosphere"
    raw = sim.get("atmosphere") or {}
    if not isinstance(raw, Mapping):
        raise InputError(where, "expected a mapping")
    known = {*ATMOSPHERE_DEFAULTS, *TURBULENCE_DEFAULTS, "spectrum"}
    unknown = sorted(set(raw) - known)
    if unknown:
        raise InputError(f"{where}.{unknown[0]}", f"unknown setting; expected one of {sorted(known)}")
    atmosphere = _block({k: v for k, v in raw.items() if k in ATMOSPHERE_DEFAULTS}, ATMOSPHERE_DEFAULTS, where,
                        exclusive=("roughness_length_m",))
    factors = _block({k: v for k, v in raw.items() if k in TURBULENCE_DEFAULTS}, TURBULENCE_DEFAULTS, where)
    spectrum = raw.get("spectrum", SPECTRA[0])
    if spectrum not in SPECTRA:
        raise InputError(f"{where}.spectrum", f"expected one of {list(SPECTRA)}, got {spectrum!r}")
    return atmosphere, TurbulenceModel(
        spectrum=str(spectrum), sigma_u_factor=factors["sigma_u_factor"], sigma_v_factor=factors["sigma_v_factor"],
        sigma_w_factor=factors["sigma_w_factor"], length_scale_factor=factors["length_scale_factor"],
        speed_trend_ms_per_h=factors["speed_trend_ms_per_h"],
        direction_trend_deg_per_h=factors["direction_trend_deg_per_h"])


def _check_whole_rates(payload: Mapping[str, float], mast: Mapping[str, float]) -> None:
    """Sonic, INS and mast rates must be whole numbers of Hz."""
    for where, block, key in (("simulation.payload", payload, "sonic_rate_hz"),
                              ("simulation.payload", payload, "ins_rate_hz"), ("simulation.mast", mast, "rate_hz")):
        if not float(block[key]).is_integer():
            raise InputError(f"{where}.{key}", f"expected a whole number of Hz, got {block[key]}")


def _payload_flight_conditions(sim: Mapping[str, Any], payload_ids: list[str]) -> dict[str, Any]:
    """``simulation.payload_flights``: exactly one entry per manifest payload flight."""
    flights_raw = sim.get("payload_flights") or {}
    if not isinstance(flights_raw, Mapping):
        raise InputError("simulation.payload_flights", "expected a mapping flight id -> conditions")
    extra = sorted(set(flights_raw) - set(payload_ids))
    if extra:
        raise InputError(f"simulation.payload_flights.{extra[0]}",
                         f"no payload flight with this id in the manifest (known: {payload_ids})")
    for fid in payload_ids:
        if fid not in flights_raw:
            raise InputError(f"simulation.payload_flights.{fid}",
                             "missing conditions for this payload flight (mean_speed_ms, "
                             "wind_from_deg, z_over_L or obukhov_length_m, ...)")
    return dict(flights_raw)


def validate_simulation(campaign: CampaignLike) -> SimulationSettings:
    """Validate the ``simulation:`` section for payload flights and masts.

    Parameters
    ----------
    campaign : dict or manifest.Campaign
        The manifest content.

    Returns
    -------
    SimulationSettings
        ``seed`` (int), ``atmosphere``, ``turbulence`` (:class:`TurbulenceModel`), ``payload``,
        ``defects`` (``sonic``/``ins``),
        ``mast`` (dicts of floats with defaults filled in), ``mechanisms`` (list of
        ``{mechanism, parameters, flights, platforms}``) and ``payload_flights``
        (raw per-flight mappings, checked by :func:`resolve_payload_flight`).

    Raises
    ------
    InputError
        Naming the setting (key path) and what was expected.
    """
    data = campaign_dict(campaign)
    sim = _simulation_section(data)
    payload, defects = _payload_settings(sim)
    mast = _block(sim.get("mast"), MAST_DEFAULTS, "simulation.mast")
    _check_whole_rates(payload, mast)
    atmosphere, turbulence = _atmosphere_settings(sim)
    payload_ids = [str(f.get("id")) for f in data.get("payload_flights") or []]
    quad_ids = [str(f.get("id")) for f in data.get("quadrotor_flights") or []]
    flights_raw = _payload_flight_conditions(sim, payload_ids)
    mechanisms = _mechanisms(sim, set(payload_ids) | set(quad_ids))
    out = SimulationSettings(seed=int(sim.get("seed", 0)), atmosphere=atmosphere, turbulence=turbulence,
                             payload=payload, defects=defects, mast=mast, mechanisms=mechanisms,
                             payload_flights=flights_raw)
    # check every flight now so that errors surface before any simulation runs
    for fid in payload_ids:
        resolve_payload_flight(data, fid, out)
    return out


def _mast_sonics(data: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """Every mast sonic by id, with its mast's id and position (default: the site's)."""
    site = data.get("site") or {}
    out = {}
    for mast in data.get("masts") or []:
        for sonic in mast.get("sonics") or []:
            entry = dict(sonic)
            entry["mast_id"] = mast.get("id")
            entry["latitude"] = float(mast.get("latitude", site.get("latitude", 0.0)))
            entry["longitude"] = float(mast.get("longitude", site.get("longitude", 0.0)))
            out[str(sonic["id"])] = entry
    return out


def _flight_entry(data: Mapping[str, Any], settings: SimulationSettings,
                  flight_id: str) -> tuple[dict[str, Any], Mapping[str, Any]]:
    """The manifest's payload flight and its ``simulation.payload_flights`` conditions (keys checked)."""
    flights = {str(f.get("id")): f for f in data.get("payload_flights") or []}
    if flight_id not in flights:
        raise InputError("flight_id", f"no payload flight {flight_id!r} (known: {sorted(flights)})")
    where = f"simulation.payload_flights.{flight_id}"
    cond = settings["payload_flights"].get(flight_id)
    if not isinstance(cond, Mapping):
        raise InputError(where, "expected a mapping of conditions")
    unknown = sorted(set(cond) - _FLIGHT_KEYS)
    if unknown:
        raise InputError(f"{where}.{unknown[0]}", f"unknown setting; expected one of {sorted(_FLIGHT_KEYS)}")
    return dict(flights[flight_id]), cond


def _reference_sonic(flight: Mapping[str, Any], sonics: Mapping[str, Any], flight_id: str) -> str:
    """Id of the flight's reference mast sonic (must be a mast sonic of the manifest)."""
    ref = str(flight.get("reference"))
    if ref not in sonics:
        raise InputError(f"payload_flights.{flight_id}.reference", f"{ref!r} is not a mast sonic id ({sorted(sonics)})")
    return ref


def _obukhov_length_m(cond: Mapping[str, Any], where: str, z_ref_m: float) -> float:
    """L [m] from exactly one of ``z_over_L`` (at z_ref_m, 0 = neutral) or ``obukhov_length_m``."""
    has_z, has_l = "z_over_L" in cond, "obukhov_length_m" in cond
    if has_z == has_l:
        raise InputError(f"{where}.z_over_L", "give exactly one of z_over_L (at z_ref_m) or obukhov_length_m")
    if has_z:
        zeta = _number(cond["z_over_L"], f"{where}.z_over_L", -5.0, 5.0, "1")
        return math.inf if zeta == 0 else z_ref_m / zeta
    ol = cond["obukhov_length_m"]
    if isinstance(ol, str) and ol.strip().lower() in ("inf", "+inf", "-inf", ".inf"):
        ol = math.inf
    if isinstance(ol, bool) or not isinstance(ol, (int, float)) or (math.isfinite(ol) and abs(ol) < 1.0) \
            or math.isnan(ol):
        raise InputError(f"{where}.obukhov_length_m", f"expected |L| >= 1 m or inf, got {ol!r}")
    return float(ol)


def _wind_conditions(cond: Mapping[str, Any], where: str, reference_height_m: float) -> dict[str, float]:
    """``mean_speed_ms``, ``wind_from_deg``, ``z_ref_m`` and ``obukhov_length_m`` of a flight."""
    for key in ("mean_speed_ms", "wind_from_deg"):
        if key not in cond:
            raise InputError(f"{where}.{key}", "missing (required)")
    out = {"mean_speed_ms": _number(cond["mean_speed_ms"], f"{where}.mean_speed_ms", 0.0, 40.0, "m s-1",
                                    lower_exclusive=True),
           "wind_from_deg": _number(cond["wind_from_deg"], f"{where}.wind_from_deg", 0.0, 360.0, "degree")}
    out["z_ref_m"] = _number(cond.get("z_ref_m", reference_height_m), f"{where}.z_ref_m", 0.5, 1000.0, "m")
    out["obukhov_length_m"] = _obukhov_length_m(cond, where, out["z_ref_m"])
    return out


def _flight_atmosphere(cond: Mapping[str, Any], where: str, atmosphere: Mapping[str, float]) -> dict[str, float]:
    """Roughness length, boundary-layer depth and temperature: the flight's overrides of the atmosphere block."""
    return {key: _number(cond.get(key, atmosphere[key]), f"{where}.{key}", lo, hi, unit,
                         lower_exclusive=key == "roughness_length_m")
            for key, (_, lo, hi, unit) in ATMOSPHERE_DEFAULTS.items()}


def _hover_window(cond: Mapping[str, Any], flight: Mapping[str, Any], where: str,
                  flight_id: str) -> tuple[np.datetime64, float]:
    """Hover-window start (UTC) and length [s]: the conditions' or the manifest window's."""
    window = flight.get("window") or {}
    if "start" in cond:
        start = parse_time(cond["start"], f"{where}.start")
    elif window.get("start") is not None:
        start = parse_time(window["start"], f"payload_flights.{flight_id}.window.start")
    else:
        raise InputError(f"{where}.start", "missing: give start (or a window in the manifest flight)")
    if "duration_s" in cond:
        duration = _number(cond["duration_s"], f"{where}.duration_s", 0.0, 7200.0, "s", lower_exclusive=True)
    elif window.get("end") is not None:
        end = parse_time(window["end"], f"payload_flights.{flight_id}.window.end")
        duration = float((end - start) / np.timedelta64(1, "us")) * 1e-6
        if duration <= 0:
            raise InputError(f"payload_flights.{flight_id}.window", "end must be after start")
    else:
        raise InputError(f"{where}.duration_s", "missing: give duration_s (or a window end)")
    return start, duration


def _flight_mechanisms(mechanisms: list[MechanismEntry], flight_id: str) -> dict[str, dict[str, float]]:
    """Payload and mast mechanisms acting on one flight: name -> parameters (each at most once)."""
    mechs: dict[str, dict[str, float]] = {}
    for m in mechanisms:
        if ("payload" in m["platforms"] or "mast" in m["platforms"]) and \
                (m["flights"] is None or flight_id in m["flights"]):
            if m["mechanism"] in mechs:
                raise InputError("simulation.mechanisms",
                                 f"mechanism {m['mechanism']!r} given twice for flight {flight_id}")
            # payload and mast mechanisms have float parameters only (catalog)
            mechs[m["mechanism"]] = cast(dict[str, float], dict(m["parameters"]))
    return mechs


def _check_hover_height(hover_height_m: float, mechanisms: Mapping[str, Mapping[str, float]],
                        flight_id: str) -> None:
    """The ``height_offset`` mechanism must leave the payload more than 2 m above ground."""
    dz = mechanisms.get("height_offset", {}).get("dz_m", 0.0)
    if hover_height_m - dz <= 2.0:
        raise InputError("simulation.mechanisms.height_offset.dz_m",
                         f"puts flight {flight_id} at {hover_height_m - dz} m (must stay > 2 m)")


def _flight_duration_s(cond: Mapping[str, Any], where: str, duration_s: float, hover_height_m: float,
                       payload: Mapping[str, float]) -> float | None:
    """``flight_duration_s`` (None if not set); it must hold the hover window and the flight plan."""
    climb = hover_height_m / payload["ascent_rate_ms"] + hover_height_m / payload["descent_rate_ms"]
    needed = duration_s + 2 * payload["hover_margin_s"] + climb + payload["ground_before_s"] + \
        payload["ground_after_s"]
    if "flight_duration_s" not in cond:
        return None
    fd = _number(cond["flight_duration_s"], f"{where}.flight_duration_s", 0.0, 4 * 3600.0, "s",
                 lower_exclusive=True)
    if needed > fd:
        raise InputError(f"{where}.duration_s",
                         f"hover window of {duration_s:.0f} s is longer than the flight: with ascent, descent, "
                         f"margins and ground time it needs {needed:.0f} s > flight_duration_s = {fd:.0f} s")
    return fd


def _hover_offset_enu_m(cond: Mapping[str, Any], where: str, wind_from_deg: float) -> list[float]:
    """Payload position relative to the reference mast [m, m] (default 35 m right, 10 m upwind)."""
    if "hover_offset_enu_m" in cond:
        off = cond["hover_offset_enu_m"]
        if not isinstance(off, (list, tuple)) or len(off) != 2:
            raise InputError(f"{where}.hover_offset_enu_m", f"expected [east_m, north_m], got {off!r}")
        return [_number(v, f"{where}.hover_offset_enu_m", -2000, 2000, "m") for v in off]
    # default: 35 m to the right of the mast looking downwind and 10 m upwind (assumed;
    # Ghirardelli et al. (2025), Fig. 7 shows hovering a few tens of metres from the tower)
    a = math.radians(wind_from_deg)
    e_u = (-math.sin(a), -math.cos(a))
    e_right = (e_u[1], -e_u[0])
    return [35 * e_right[0] - 10 * e_u[0], 35 * e_right[1] - 10 * e_u[1]]


def _flight_lag_s(cond: Mapping[str, Any], where: str, payload: Mapping[str, float], seed: int) -> float:
    """The flight's ``sonic_ins_lag_s`` [s], else drawn in the payload's range (:func:`processing_lag_s`)."""
    if "sonic_ins_lag_s" in cond:
        return _number(cond["sonic_ins_lag_s"], f"{where}.sonic_ins_lag_s", *SONIC_INS_LAG_RANGE_S, "s")
    return processing_lag_s(seed, payload["sonic_ins_lag_low_s"], payload["sonic_ins_lag_high_s"])


def _flight_rates(cond: Mapping[str, Any], where: str, payload: dict[str, float], mast: dict[str, float]
                  ) -> tuple[dict[str, float], dict[str, float]]:
    """The payload and mast settings with the flight's own sonic, INS and mast rates, if it gives them.

    A measured flight's forward model records at the rates the flight was recorded at
    (:func:`dronewind.diagnose.forward_conditions.forward_conditions`): the alignment
    interpolates each record linearly to its common grid, which damps the high frequencies
    of a slower record more. Each rate is checked against the range of the block it
    overrides and must be a whole number of Hz.
    """
    blocks = {"payload": dict(payload), "mast": dict(mast)}
    for key, (block, name) in _FLIGHT_RATES.items():
        if key in cond:
            rate = _number(cond[key], f"{where}.{key}", *flight_rate_range_hz(key), "Hz")
            if not rate.is_integer():
                raise InputError(f"{where}.{key}", f"expected a whole number of Hz, got {rate}")
            blocks[block][name] = rate
    return blocks["payload"], blocks["mast"]


def _sonic_mount(flight: Mapping[str, Any], flight_id: str) -> str:
    """``upside_down`` (default) or ``upright``."""
    mount = str((flight.get("sonic") or {}).get("mount", "upside_down"))
    if mount not in ("upside_down", "upright"):
        raise InputError(f"payload_flights.{flight_id}.sonic.mount", "expected upside_down or upright")
    return mount


def resolve_payload_flight(campaign: CampaignLike, flight_id: str,
                           settings: SimulationSettings | None = None) -> PayloadFlightConditions:
    """All conditions of one payload flight, defaults filled in and checked.

    Parameters
    ----------
    campaign : dict or manifest.Campaign
        Manifest content.
    flight_id : str
        Payload flight id.
    settings : SimulationSettings, optional
        Output of :func:`validate_simulation` (computed if omitted).

    Returns
    -------
    PayloadFlightConditions
        Keys: ``flight_id, seed`` (flight seed), ``mean_speed_ms, wind_from_deg,
        obukhov_length_m, z_ref_m, hover_height_m, start`` (datetime64[us]),
        ``duration_s, flight_duration_s`` (None if not set), ``hover_offset_enu_m``
        (2 floats, relative to the reference sonic's mast), the atmosphere settings,
        ``turbulence`` (the campaign's :class:`TurbulenceModel`),
        ``payload, defects, mast`` (dicts), ``sonic_ins_lag_s`` (the flight's processing
        lag, :func:`processing_lag_s`), ``mechanisms`` (dict name -> parameters of
        the payload/mast mechanisms active for this flight), ``reference`` (sonic id),
        ``mast_sonics`` (dict), ``site`` (dict), ``flight`` (manifest entry).

    Raises
    ------
    InputError
        Naming the setting: negative wind speed, |z/L| too large, hover height not
        positive, a hover window longer than the flight, ...
    """
    data = campaign_dict(campaign)
    if settings is None:
        settings = validate_simulation(data)
    flight, cond = _flight_entry(data, settings, flight_id)
    where = f"simulation.payload_flights.{flight_id}"
    sonics = _mast_sonics(data)
    ref = _reference_sonic(flight, sonics, flight_id)
    wind = _wind_conditions(cond, where, sonics[ref]["height_m"])
    atmosphere = _flight_atmosphere(cond, where, settings["atmosphere"])
    hover = cond.get("hover_height_m", flight.get("target_height_m", sonics[ref]["height_m"]))
    hover_height = _number(hover, f"{where}.hover_height_m", 0.0, 500.0, "m", lower_exclusive=True)
    start, duration = _hover_window(cond, flight, where, flight_id)
    payload, mast = _flight_rates(cond, where, settings["payload"], settings["mast"])
    mechs = _flight_mechanisms(settings["mechanisms"], flight_id)
    _check_hover_height(hover_height, mechs, flight_id)
    seed = flight_seed(settings["seed"], flight_id)
    return PayloadFlightConditions(
        flight_id=flight_id, flight=flight, reference=ref, mast_sonics=sonics, site=dict(data.get("site") or {}),
        mean_speed_ms=wind["mean_speed_ms"], wind_from_deg=wind["wind_from_deg"], z_ref_m=wind["z_ref_m"],
        obukhov_length_m=wind["obukhov_length_m"], roughness_length_m=atmosphere["roughness_length_m"],
        boundary_layer_height_m=atmosphere["boundary_layer_height_m"], theta_mean_k=atmosphere["theta_mean_k"],
        turbulence=settings["turbulence"],
        hover_height_m=hover_height, start=start, duration_s=duration, payload=payload,
        defects=settings["defects"], mast=mast, mechanisms=mechs,
        flight_duration_s=_flight_duration_s(cond, where, duration, hover_height, payload),
        hover_offset_enu_m=_hover_offset_enu_m(cond, where, wind["wind_from_deg"]),
        seed=seed, sonic_mount=_sonic_mount(flight, flight_id),
        sonic_ins_lag_s=_flight_lag_s(cond, where, payload, seed))


def simulation_manifest(campaign_data: Mapping[str, Any]) -> dict[str, Any]:
    """What the payload simulator reads of a manifest: the manifest without the keys it does not use.

    The simulator of a payload flight reads the site, every mast sonic (it writes a record
    for each), the ``simulation:`` settings of payloads and masts and the conditions of every
    payload flight (a mast record is clipped halfway to the neighbouring flights). It does
    not read a flight's ``target_height_m`` when the flight's conditions give
    ``hover_height_m``, nor its ``window`` when they give ``start`` and ``duration_s``, nor
    the quadrotor and tunnel settings or the mechanisms of other platforms. Without those,
    this view is the rerun trigger of the simulate jobs: editing a flight's processing
    window or target height does not rewrite the raw files.

    Parameters
    ----------
    campaign_data : mapping
        Manifest content of a virtual campaign.

    Returns
    -------
    dict
        A manifest that simulates every payload flight exactly as ``campaign_data`` does.
    """
    sim = campaign_data["simulation"]
    conditions = sim.get("payload_flights") or {}
    flights = []
    for flight in campaign_data.get("payload_flights") or []:
        cond = conditions.get(flight["id"]) or {}
        unused = {"target_height_m"} if "hover_height_m" in cond else set()
        unused |= {"window"} if {"start", "duration_s"} <= set(cond) else set()
        flights.append({k: v for k, v in flight.items() if k not in unused})
    mechanisms = [m for m in sim.get("mechanisms") or []
                  if {"payload", "mast"} & set(get_mechanism(m["mechanism"]).platforms)]
    return {
        "name": campaign_data["name"], "site": campaign_data["site"], "masts": campaign_data.get("masts") or [],
        "payload_flights": flights,
        "quadrotor_flights": [{"id": q["id"]} for q in campaign_data.get("quadrotor_flights") or []],
        "simulation": {**{k: v for k, v in sim.items() if k in ("seed", "atmosphere", "payload", "mast")},
                       "payload_flights": conditions, "mechanisms": mechanisms},
    }
