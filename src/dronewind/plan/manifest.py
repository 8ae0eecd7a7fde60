"""The planned campaign as a virtual-campaign manifest (``docs/manifest.md``, ``simulation:`` filled).

The skeleton has the plan's site, one mast with a CSAT3 sonic per planned height (the hover's
reference first), ``n`` sling-load payload flights one hour apart at the planned hover
height, distance and duration, and the ``simulation:`` conditions of each flight: the planned
wind speed at the hover height (``z_ref_m`` = hover height), the direction, the Obukhov
length, roughness length, boundary-layer depth and temperature. The workflow runs it as a
virtual campaign (``snakemake --config campaign=<file>``); replacing the file names and the
windows by the flown records and dropping ``simulation:`` makes it the measured campaign's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from dronewind.plan.spec import PlanSpec

__all__ = ["flight_speeds", "hover_offset_enu_m", "plan_manifest", "FIRST_START"]

#: Start of the first planned hover (a placeholder date: the plan has no calendar).
FIRST_START = np.datetime64("2024-06-01T09:00:00")


def flight_speeds(lowest_ms: float, highest_ms: float, n: int) -> list[float]:
    """``n`` wind speeds evenly spanning [lowest, highest], ordered so that every prefix spans the range.

    The first two are the ends, each next one the speed farthest from those before it, so the
    first ``k`` flights of a plan are the plan for ``k`` flights.

    Parameters
    ----------
    lowest_ms, highest_ms : float
        Range [m s-1].
    n : int
        Number of flights.

    Returns
    -------
    list of float
        Speeds [m s-1], rounded to 0.1 m/s.
    """
    if n <= 1 or highest_ms <= lowest_ms:
        return [round(0.5 * (lowest_ms + highest_ms), 1)] * max(n, 1)
    grid = list(np.linspace(lowest_ms, highest_ms, n))
    order = [0, n - 1]
    while len(order) < n:
        rest = [i for i in range(n) if i not in order]
        order.append(max(rest, key=lambda i: (min(abs(grid[i] - grid[j]) for j in order), -i)))
    return [round(float(grid[i]), 1) for i in order]


def hover_offset_enu_m(distance_m: float, wind_from_deg: float) -> list[float]:
    """Hover position relative to the mast: ``distance_m`` to the right of it, looking downwind [m east, m north]."""
    a = math.radians(wind_from_deg)
    e_u = (-math.sin(a), -math.cos(a))
    e_right = (e_u[1], -e_u[0])
    return [round(distance_m * e_right[0], 2), round(distance_m * e_right[1], 2)]


def plan_manifest(spec: PlanSpec, n_flights: int, duration_s: float, speeds_ms: Sequence[float],
                  distance_m: float, seed: int = 2024, mechanisms: Sequence[Mapping[str, Any]] = (),
                  name: str | None = None) -> dict[str, Any]:
    """The planned campaign as a virtual-campaign manifest.

    Parameters
    ----------
    spec : PlanSpec
        The plan.
    n_flights : int
        Number of payload flights.
    duration_s : float
        Hover duration of each [s].
    speeds_ms : sequence of float
        Mean wind speed of each flight at the hover height [m s-1] (cycled).
    distance_m : float
        Cross-wind drone-mast distance [m].
    seed : int
        ``simulation.seed``.
    mechanisms : sequence of mapping
        ``simulation.mechanisms`` entries (a hidden instrument error), none by default.
    name : str, optional
        Campaign name (default the plan's).

    Returns
    -------
    dict
        Manifest content (``docs/manifest.md``).
    """
    ref_h = spec.reference_height_m
    heights = [ref_h] + [h for h in spec.mast_heights_m if h != ref_h]
    sonics = [{"id": f"mast{h:g}", "height_m": h, "model": "CSAT3", "azimuth_deg": spec.mast_azimuth_deg,
               "files": [f"mast/mast{h:g}_*.dat"]} for h in heights]
    ref = sonics[0]["id"]
    flights, conditions = [], {}
    offset = hover_offset_enu_m(distance_m, spec.wind_from_deg)
    for i in range(n_flights):
        fid = f"p{i + 1:02d}"
        start = FIRST_START + np.timedelta64(3600 * i, "s")
        end = start + np.timedelta64(int(round(duration_s)), "s")
        flights.append({"id": fid, "reference": ref, "target_height_m": spec.hover_height_m,
                        "sonic": {"file": f"flights/{fid}/sonic.csv", "mount": "upside_down"},
                        "ins": {"file": f"flights/{fid}/ins.csv"},
                        "window": {"start": f"{start}Z", "end": f"{end}Z"}})
        conditions[fid] = {"mean_speed_ms": float(speeds_ms[i % len(speeds_ms)]),
                           "wind_from_deg": spec.wind_from_deg, "z_ref_m": spec.hover_height_m,
                           "obukhov_length_m": spec.obukhov_length_m, "hover_height_m": spec.hover_height_m,
                           "hover_offset_enu_m": offset}
    site = {"name": spec.site.get("name", spec.name), "latitude": spec.site["latitude"],
            "longitude": spec.site["longitude"], "altitude_m": spec.site["altitude_m"]}
    return {
        "name": name or spec.name,
        "site": site,
        "masts": [{"id": "mast", "latitude": spec.mast_latitude, "longitude": spec.mast_longitude,
                   "sonics": sonics}],
        "payload_flights": flights,
        "simulation": {
            "seed": int(seed),
            "atmosphere": {"roughness_length_m": spec.roughness_length_m,
                           "boundary_layer_height_m": spec.boundary_layer_height_m,
                           "theta_mean_k": spec.theta_mean_k},
            "payload": {}, "mast": {},
            "payload_flights": conditions,
            "mechanisms": [dict(m) for m in mechanisms],
        },
    }
