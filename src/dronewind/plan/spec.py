"""The plan file: site, expected conditions, platform, mast and targets of a campaign to plan.

A plan is one YAML file checked against ``workflow/schemas/plan.schema.json`` (shipped as
``dronewind/schemas/plan.schema.json``); every error names the file, the key path and what was
expected. Example (``docs`` of :func:`load_plan`)::

    name: lannemezan_plan
    site: {name: P2OA Lannemezan, latitude: 43.1247, longitude: 0.3628, altitude_m: 603}
    conditions:
      wind_speed_ms: [4.0, 9.0]      # at the hover height; one value or the range of the flights
      wind_from_deg: 290
      stability: {obukhov_length_m: -150}   # or {class: near_neutral_unstable}
      roughness_length_m: 0.3
      boundary_layer_height_m: 1000
    platform: {kind: sling_load, max_hover_min: 25}
    mast: {heights_m: [30, 60], hover_height_m: 30, hover_distance_m: 36}
    targets:
      relative_uncertainty: {sigma_w: 0.1, u_star: 0.15, w_theta: 0.3}
      detect:
        - {mechanism: w_gain, parameters: {gain: 1.1}}
        - {mechanism: heading_bias, parameters: {deg: 3}}
      power: 0.8
      max_flights: 6
"""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from dronewind.errors import InputError

__all__ = ["PlanSpec", "Detect", "plan_schema", "load_plan", "parse_plan", "STABILITY_CLASSES", "PLATFORMS",
           "QUANTITIES"]

#: Representative Obukhov length of each stability class [m]: the geometric middle of the
#: classes of Gryning et al. (2007, Bound.-Layer Meteorol. 124, 251-268, Table 1): very
#: unstable -100 < L < -50, unstable -200 < L < -100, near-neutral unstable -500 < L < -200,
#: neutral |L| > 500, near-neutral stable 200 < L < 500, stable 50 < L < 200, very stable
#: 10 < L < 50.
STABILITY_CLASSES: dict[str, float] = {
    "very_unstable": -71.0, "unstable": -141.0, "near_neutral_unstable": -316.0, "neutral": math.inf,
    "near_neutral_stable": 316.0, "stable": 100.0, "very_stable": 22.0,
}
#: Platforms a plan may name.
PLATFORMS: tuple[str, ...] = ("sling_load", "rigid_mount", "quadrotor_fleet")
#: Quantities whose relative random uncertainty a plan may target.
QUANTITIES: tuple[str, ...] = ("sigma_u", "sigma_w", "u_star", "w_theta")
#: |L| above which the planner treats the surface layer as neutral [m] (the simulator needs a
#: finite L; 1e5 m gives z/L < 1e-3 at any hover height).
NEUTRAL_L_M = 1.0e5


@dataclass(frozen=True)
class Detect:
    """One instrument error the campaign should detect."""

    mechanism: str
    parameters: dict[str, float]

    @property
    def label(self) -> str:
        """``w_gain gain=1.1``."""
        return self.mechanism + " " + ", ".join(f"{k}={v:g}" for k, v in self.parameters.items())


@dataclass(frozen=True)
class PlanSpec:
    """A validated plan (every default filled in)."""

    name: str
    site: dict[str, Any]
    speed_range_ms: tuple[float, float]
    wind_from_deg: float
    obukhov_length_m: float
    roughness_length_m: float
    boundary_layer_height_m: float
    theta_mean_k: float
    platform: str
    max_hover_s: float
    mast_heights_m: tuple[float, ...]
    mast_latitude: float
    mast_longitude: float
    mast_azimuth_deg: float
    hover_height_m: float
    hover_distance_m: float
    targets: dict[str, float]
    detect: tuple[Detect, ...]
    power: float
    max_flights: int
    min_correlation: float
    draws: int
    curve_draws: int
    seed: int
    source: str = "plan"
    reference: str = "shared"
    raw: dict[str, Any] = field(default_factory=dict, compare=False)

    @property
    def reference_height_m(self) -> float:
        """Height of the mast sonic nearest the hover height [m]."""
        return min(self.mast_heights_m, key=lambda h: (abs(h - self.hover_height_m), h))


def plan_schema() -> dict[str, Any]:
    """The JSON schema of plan files (draft 2020-12)."""
    return json.loads(resources.files("dronewind").joinpath("schemas/plan.schema.json").read_text("utf-8"))


def _path(error: Any) -> str:
    out = ""
    for part in error.absolute_path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top level)"


def _fill(instance: dict[str, Any], schema: Mapping[str, Any]) -> None:
    for key, sub in (schema.get("properties") or {}).items():
        if "default" in sub and key not in instance:
            instance[key] = copy.deepcopy(sub["default"])
        if isinstance(instance.get(key), dict):
            _fill(instance[key], sub)


def parse_plan(data: Mapping[str, Any], source: str = "plan") -> PlanSpec:
    """Check a plan's content and fill in its defaults.

    Parameters
    ----------
    data : mapping
        The plan (YAML content).
    source : str
        Name used in the error messages (the file).

    Returns
    -------
    PlanSpec

    Raises
    ------
    InputError
        ``<source> [<key path>]: <what was expected>`` for the first problem found.
    """
    import jsonschema

    from dronewind.mechanisms import get_mechanism, validate_parameters

    if not isinstance(data, Mapping):
        raise InputError(source, f"expected a mapping (the plan), got {type(data).__name__}")
    raw = copy.deepcopy(dict(data))
    errors = sorted(jsonschema.Draft202012Validator(plan_schema()).iter_errors(raw),
                    key=lambda e: (len(list(e.absolute_path)), str(e.message)))
    if errors:
        e = errors[0]
        raise InputError(f"{source} [{_path(e)}]", e.message)
    _fill(raw, plan_schema())
    cond, mast, targets, platform = raw["conditions"], raw["mast"], raw["targets"], raw["platform"]
    speeds = cond["wind_speed_ms"]
    if isinstance(speeds, (int, float)):
        lo = hi = float(speeds)
    else:
        lo, hi = float(speeds[0]), float(speeds[1])
    if lo > hi:
        raise InputError(f"{source} [conditions.wind_speed_ms]", f"expected [lowest, highest], got [{lo}, {hi}]")
    if lo < 1.0:
        raise InputError(f"{source} [conditions.wind_speed_ms]",
                         f"{lo} m/s: below 1 m/s Taylor's hypothesis and the z/U time scale of Ghirardelli et al. "
                         "(2025, Eqs 10-13) do not hold; plan for at least 1 m/s")
    stab = cond["stability"]
    ell = STABILITY_CLASSES[stab["class"]] if "class" in stab else float(stab["obukhov_length_m"])
    if ell == 0:
        raise InputError(f"{source} [conditions.stability.obukhov_length_m]", "expected a non-zero length (m)")
    if not math.isfinite(ell) or abs(ell) > NEUTRAL_L_M:
        ell = NEUTRAL_L_M
    heights = tuple(float(h) for h in mast["heights_m"])
    hover = float(mast.get("hover_height_m", min(heights)))
    if abs(hover / ell) > 2.0:
        raise InputError(f"{source} [conditions.stability]",
                         f"z/L = {hover / ell:.2f} at the hover height {hover} m: outside |z/L| <= 2, where "
                         "surface-layer similarity (and the simulator) holds")
    site = dict(raw["site"])
    goal = {k: float(v) for k, v in (targets.get("relative_uncertainty") or {}).items()}
    kind = str(platform["kind"])
    if kind == "quadrotor_fleet":
        bad = sorted(set(goal) - {"sigma_u"})
        if bad:
            raise InputError(f"{source} [targets.relative_uncertainty.{bad[0]}]",
                             "a quadrotor fleet measures the horizontal wind from its tilt (Wetz et al. 2021): only "
                             "sigma_u can be targeted")
    detect = []
    for i, item in enumerate(targets.get("detect") or []):
        where = f"{source} [targets.detect[{i}]"
        mech = get_mechanism(item["mechanism"], f"{where}.mechanism]")
        if kind != "sling_load" or not ({"payload", "mast"} & set(mech.platforms)):
            raise InputError(f"{where}.mechanism]",
                             f"{mech.name}: detection power is simulated for the sling-load payload's mechanisms "
                             f"(the campaign diagnosis, dronewind.diagnose.campaign); platform is {kind}")
        params = validate_parameters(mech.name, item["parameters"], f"{where}.parameters]")
        detect.append(Detect(mech.name, {k: float(v) for k, v in params.items()}))
    return PlanSpec(
        name=str(raw["name"]), site=site, speed_range_ms=(lo, hi), wind_from_deg=float(cond["wind_from_deg"]) % 360.0,
        obukhov_length_m=float(ell), roughness_length_m=float(cond["roughness_length_m"]),
        boundary_layer_height_m=float(cond["boundary_layer_height_m"]), theta_mean_k=float(cond["theta_mean_k"]),
        platform=kind, max_hover_s=60.0 * float(platform["max_hover_min"]), mast_heights_m=heights,
        mast_latitude=float(mast.get("latitude", site["latitude"])),
        mast_longitude=float(mast.get("longitude", site["longitude"])),
        mast_azimuth_deg=float(mast["azimuth_deg"]), hover_height_m=hover,
        hover_distance_m=float(mast["hover_distance_m"]), targets=goal, detect=tuple(detect),
        power=float(targets["power"]), max_flights=int(targets["max_flights"]),
        min_correlation=float(targets["min_correlation"]), draws=int(raw["monte_carlo"]["draws"]),
        curve_draws=int(raw["monte_carlo"]["curve_draws"]), seed=int(raw["monte_carlo"]["seed"]), source=source,
        reference=str(raw["monte_carlo"]["reference"]), raw=raw)


def load_plan(path: str | Path) -> PlanSpec:
    """Read and check a plan file.

    Parameters
    ----------
    path : str or Path
        YAML plan file (format: this module's docstring and ``plan.schema.json``).

    Returns
    -------
    PlanSpec

    Raises
    ------
    InputError
        Missing or unreadable file, YAML syntax, or a value the schema or the physics rejects
        (named by file and key path).
    """
    from dronewind.core.yamltext import load_yaml

    p = Path(path)
    try:
        text = p.read_text("utf-8")
    except OSError as exc:
        raise InputError(p, f"cannot read the plan file: {exc.strerror or exc}") from None
    try:
        data = load_yaml(text)
    except Exception as exc:  # the YAML parser's own error types vary with the backend
        raise InputError(p, f"not valid YAML: {exc}") from None
    return parse_plan(data, str(p))
