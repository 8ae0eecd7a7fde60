r"""The catalog of discrepancy mechanisms (``docs/data-contract.md``, "Mechanisms").

A *mechanism* is a named physical or instrumental cause that makes a measured (or
simulated) record differ from the truth. The simulator switches mechanisms on in its
measurement model (``simulation.mechanisms`` of a campaign manifest); the diagnosis
fits them to processed data and names the significant ones. This module only
*describes* them: names, parameters with units and physical ranges, and which platform
each one acts on. It contains no processing code.

Platforms: ``payload`` (SAMURAI-S sling-load sonic + INS), ``rigid_mount`` (a sonic bolted to
a multicopter, platform state from the vehicle's log), ``mast`` (mast sonics), ``quadrotor``
(SWUF-3D drag-balance quadrotors, incl. their wind-tunnel calibration) and ``any``
(``none``).

Where each payload/mast mechanism acts in the simulator (``dronewind.simulate``):

============================ =====================================================================
sonic_ins_lag                sonic rows are stamped ``rpi(t) - lag_s``: ``lag_s`` is the time that
                             must be ADDED to the sonic clock to align it with the INS (same sign
                             as ``lag_sonic_ins_s``); a sonic processing delay d gives lag_s = -d
clock_drift                  the sonic's stamps run ``ppm`` 1e-6 fast: stamp = rpi(t) + ppm 1e-6
                             (t - t_hover_centre), about the centre of the hover window,
                             where the flight's own lag (and the chain's lag search) holds
mount_misalignment           true sensor-to-body rotation = M_mount . R(roll, pitch, yaw) (App. A)
heading_bias                 logged INS yaw = true yaw + deg
attitude_lag                 logged INS attitude at t = true attitude at t - lag_s
lever_arm                    logged INS velocity/position refer to sonic + R . (x, y, z)_body
w_gain                       sensor-frame z component of the payload sonic multiplied by gain
                             (flow distortion around the head)
sonic_noise                  white Gaussian noise (sigma_ms, each sensor component) on the
                             payload sonic, before quantisation
height_offset                the payload hovers dz_m lower (positive = lower) than the settings'
                             hover height; it then samples the field (mean shear, sigma's,
                             spectra) at that height
downwash                     the air at the payload sonic gets a downdraft
                             w_dw = -w0_ms . exp(-U_h / u_scale_ms), U_h the instantaneous
                             horizontal wind speed at the payload
mast_w_attenuation           mast CSAT3 Uz = gain . true vertical wind
platform_velocity_response   rigid mount (:mod:`dronewind.simulate.rigid`): the sonic measures
                             :math:`V_{sensor} = (R M)^{-1} (V_{wind} - G V_{platform})` with
                             :math:`G = \mathrm{diag}(g_h, g_h, g_v)` in east/north/up (``gain_h``,
                             ``gain_v``); ``G = I`` is the present model. The motion-corrected wind
                             :math:`R M V_{sensor} + V_{platform}` then keeps
                             :math:`(I - G) V_{platform}`
============================ =====================================================================
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from dronewind.errors import InputError

__all__ = [
    "ParameterValue",
    "Parameter",
    "Mechanism",
    "CATALOG",
    "PLATFORMS",
    "get_mechanism",
    "mechanisms_for",
    "validate_parameters",
]

#: Platforms a mechanism can act on.
PLATFORMS: tuple[str, ...] = ("payload", "rigid_mount", "mast", "quadrotor", "any")

#: A validated parameter value: a number (``float`` parameters), an identifier (``str``) or a
#: table of YAML mappings (``table``).
ParameterValue = float | str | list[dict[str, Any]]


@dataclass(frozen=True)
class Parameter:
    """One parameter of a mechanism.

    Attributes
    ----------
    name : str
        Key in the settings (e.g. ``lag_s``); the suffix carries the unit.
    units : str
        UDUNITS-style unit (``s``, ``m``, ``degree``, ``m s-1``, ``1``, ``ppm``).
    lower, upper : float
        Physically plausible range (inclusive unless ``lower_exclusive``).
    description : str
        Meaning and sign convention.
    kind : str
        ``"float"`` (default), ``"str"`` (an identifier) or ``"table"`` (a list of
        mappings, e.g. drag coefficients per speed range).
    lower_exclusive : bool
        Whether ``lower`` itself is excluded (e.g. a strictly positive scale).
    """

    name: str
    units: str
    lower: float
    upper: float
    description: str
    kind: str = "float"
    lower_exclusive: bool = False


@dataclass(frozen=True)
class Mechanism:
    """A catalog entry.

    Attributes
    ----------
    name : str
        Catalog name (``docs/data-contract.md``).
    parameters : tuple of Parameter
        Its parameters (empty for ``none``).
    platforms : tuple of str
        Platforms it acts on (subset of :data:`PLATFORMS`).
    meaning : str
        One-line meaning, as in ``docs/data-contract.md``.
    """

    name: str
    parameters: tuple[Parameter, ...]
    platforms: tuple[str, ...]
    meaning: str

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the parameters in catalog order."""
        return tuple(p.name for p in self.parameters)


def _p(name: str, units: str, lower: float, upper: float, description: str, kind: str = "float",
       lower_exclusive: bool = False) -> Parameter:
    """Shorthand for a catalog :class:`Parameter`."""
    return Parameter(name, units, lower, upper, description, kind, lower_exclusive)


_ENTRIES: tuple[Mechanism, ...] = (
    Mechanism("none", (), ("any",), "no discrepancy beyond sampling error"),
    Mechanism(
        "sonic_ins_lag",
        (_p("lag_s", "s", -2.0, 2.0,
            "time to ADD to the sonic clock to align it with the INS (lag_sonic_ins_s)"),),
        ("payload",),
        "sonic clock offset from the INS",
    ),
    Mechanism(
        "clock_drift",
        (_p("ppm", "ppm", -1000.0, 1000.0,
            "sonic stamps gain ppm*1e-6 s per second against the INS (positive: fast)"),),
        ("payload",),
        "sonic clock runs fast or slow against the INS",
    ),
    Mechanism(
        "mount_misalignment",
        (
            _p("roll_deg", "degree", -20.0, 20.0, "roll of the extra sensor-to-body rotation"),
            _p("pitch_deg", "degree", -20.0, 20.0, "pitch of the extra sensor-to-body rotation"),
            _p("yaw_deg", "degree", -20.0, 20.0, "yaw of the extra sensor-to-body rotation"),
        ),
        ("payload",),
        "true sensor-to-body rotation differs from `mount`: M_mount . R(roll, pitch, yaw)",
    ),
    Mechanism(
        "heading_bias",
        (_p("deg", "degree", -30.0, 30.0, "INS yaw = true yaw + deg"),),
        ("payload",),
        "INS yaw = true yaw + bias",
    ),
    Mechanism(
        "attitude_lag",
        (_p("lag_s", "s", 0.0, 1.0, "INS attitude at t is the true attitude at t - lag_s"),),
        ("payload",),
        "INS attitude lags the true attitude",
    ),
    Mechanism(
        "lever_arm",
        (
            _p("x_m", "m", -2.0, 2.0, "body-frame forward offset of the INS reference point"),
            _p("y_m", "m", -2.0, 2.0, "body-frame right offset of the INS reference point"),
            _p("z_m", "m", -2.0, 2.0, "body-frame down offset of the INS reference point"),
        ),
        ("payload",),
        "INS velocity refers to a point offset from the sonic (body frame); the w x r term is missing",
    ),
    Mechanism(
        "w_gain",
        (_p("gain", "1", 0.5, 1.5, "multiplies the sensor-frame vertical component"),),
        ("payload",),
        "payload sonic w scaled by flow distortion",
    ),
    Mechanism(
        "sonic_noise",
        (_p("sigma_ms", "m s-1", 0.0, 1.0, "standard deviation of white noise per component"),),
        ("payload",),
        "white noise on the payload sonic",
    ),
    Mechanism(
        "height_offset",
        (_p("dz_m", "m", -20.0, 40.0, "payload hovers dz_m below the set height (positive = lower)"),),
        ("payload",),
        "drone below the reference height (shear)",
    ),
    Mechanism(
        "downwash",
        (
            _p("w0_ms", "m s-1", 0.0, 5.0, "downdraft at zero horizontal wind"),
            _p("u_scale_ms", "m s-1", 0.0, 20.0, "e-folding horizontal wind speed",
               lower_exclusive=True),
        ),
        ("payload",),
        "propeller-induced downdraft reaching the payload, decaying with wind speed",
    ),
    Mechanism(
        "mast_w_attenuation",
        (_p("gain", "1", 0.5, 1.2, "mast sonic Uz = gain * true w"),),
        ("mast",),
        "mast sonic w attenuated by tower or sensor-head distortion",
    ),
    Mechanism(
        "platform_velocity_response",
        (
            _p("gain_h", "1", 0.0, 1.5,
               "fraction of the platform's horizontal (east, north) velocity the sonic sees; 1: none lost"),
            _p("gain_v", "1", 0.0, 1.5,
               "fraction of the platform's vertical velocity the sonic sees; 1: none lost"),
        ),
        ("rigid_mount",),
        "the sonic sees the platform's own velocity scaled by gain_h (horizontal) and gain_v (vertical) "
        "instead of 1 (airframe and rotor flow distortion)",
    ),
    Mechanism(
        "pitch_offset",
        (
            _p("uav", "1", 0.0, 0.0, "UAV id", kind="str"),
            _p("deg", "degree", -10.0, 10.0, "logged minus true pitch"),
        ),
        ("quadrotor",),
        "quadrotor IMU pitch misalignment",
    ),
    Mechanism(
        "yaw_offset",
        (
            _p("uav", "1", 0.0, 0.0, "UAV id", kind="str"),
            _p("deg", "degree", -180.0, 180.0, "logged minus true yaw"),
        ),
        ("quadrotor",),
        "quadrotor heading (magnetometer) misalignment",
    ),
    Mechanism(
        "drag_regime",
        (_p("coefficients", "1", 0.0, 0.0,
            "list of {min_speed_ms, max_speed_ms, ...coefficients} per speed range", kind="table"),),
        ("quadrotor",),
        "quadrotor drag law changes with speed (Kistner et al. 2024, Table 2)",
    ),
    Mechanism(
        "response_lag",
        (_p("tau_s", "s", 0.0, 5.0, "first-order time constant of the attitude response"),),
        ("quadrotor",),
        "quadrotor attitude responds to wind with a lag",
    ),
)

#: Read-only mapping name -> :class:`Mechanism` (the catalog of ``docs/data-contract.md``).
CATALOG: Mapping[str, Mechanism] = MappingProxyType({m.name: m for m in _ENTRIES})


def get_mechanism(name: str, where: str = "mechanism") -> Mechanism:
    """Look a mechanism up by name.

    Parameters
    ----------
    name : str
        Catalog name.
    where : str
        Setting path for the error message.

    Returns
    -------
    Mechanism

    Raises
    ------
    InputError
        If the name is not in the catalog (the message lists the known names).
    """
    try:
        return CATALOG[str(name)]
    except KeyError:
        raise InputError(where, f"unknown mechanism {name!r}; expected one of "
                                f"{', '.join(CATALOG)}") from None


def mechanisms_for(platform: str) -> list[Mechanism]:
    """Mechanisms that act on a platform.

    Parameters
    ----------
    platform : {"payload", "rigid_mount", "mast", "quadrotor"}

    Returns
    -------
    list of Mechanism
        Catalog order; ``none`` is not included.
    """
    if platform not in PLATFORMS:
        raise InputError("platform", f"{platform!r} is not one of {PLATFORMS}")
    return [m for m in _ENTRIES if platform in m.platforms]


def validate_parameters(name: str, parameters: Mapping[str, object] | None,
                        where: str = "mechanism") -> dict[str, Any]:
    """Check a mechanism's parameters against the catalog.

    Parameters
    ----------
    name : str
        Mechanism name.
    parameters : mapping or None
        Parameter values; every catalog parameter is required, no other key allowed.
    where : str
        Setting path used in error messages (e.g.
        ``simulation.mechanisms[2].parameters``).

    Returns
    -------
    dict
        Parameter values (:data:`ParameterValue`: floats for ``float`` parameters, the
        identifier for ``str``, a list of dicts for ``table``).

    Raises
    ------
    InputError
        Unknown mechanism, missing or unknown parameter, non-numeric value, value out
        of the physical range.
    """
    mech = get_mechanism(name, where)
    params = dict(parameters or {})
    unknown = sorted(set(params) - set(mech.parameter_names))
    if unknown:
        raise InputError(where, f"unknown parameter(s) {unknown} for mechanism {name!r}; "
                                f"expected {list(mech.parameter_names)}")
    # values are ParameterValue; typed Any so that a caller knowing a parameter's kind from the
    # catalog (e.g. a quadrotor drag table) needs no cast
    out: dict[str, Any] = {}
    for p in mech.parameters:
        key = f"{where}.{p.name}"
        if p.name not in params:
            raise InputError(key, f"missing parameter of mechanism {name!r} [{p.units}]")
        value = params[p.name]
        if p.kind == "str":
            if not isinstance(value, str) or not value:
                raise InputError(key, f"expected a non-empty identifier, got {value!r}")
            out[p.name] = value
            continue
        if p.kind == "table":
            if not isinstance(value, list) or not all(isinstance(v, Mapping) for v in value):
                raise InputError(key, f"expected a list of mappings, got {value!r}")
            out[p.name] = [dict(v) for v in value]
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(key, f"expected a number [{p.units}], got {value!r}")
        x = float(value)
        too_low = x <= p.lower if p.lower_exclusive else x < p.lower
        if not math.isfinite(x) or too_low or x > p.upper:
            bracket = "(" if p.lower_exclusive else "["
            raise InputError(key, f"{x!r} outside the physical range {bracket}{p.lower}, {p.upper}] "
                                  f"[{p.units}] ({p.description})")
        out[p.name] = x
    return out
