"""Hidden-effect experiments: hide a mechanism in a virtual campaign and ask the diagnosis to find it.

A *draw* picks a mechanism (or ``none``) and its size at random (seeded), writes a small
virtual campaign manifest with that mechanism in its ``simulation:`` section, and returns
the truth. The campaign is then simulated, processed and diagnosed — by the Snakemake
workflow in the tests, or in-process by :func:`run_in_process` for the rate benchmark —
and :func:`judge` says whether the named cause and its estimate match the truth.

Sizes are drawn from ranges in which the effect on a 4-flight campaign of 12-minute hovers
is several sampling errors; the ranges and tolerances are part of the test's statement.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dronewind.compare.chain import compute_l3
from dronewind.manifest import with_defaults
from dronewind.mast.chain import compute_mast_l1, compute_mast_l2
from dronewind.payload.chain import compute_payload_l1, compute_payload_l2

__all__ = ["HIDDEN_RANGES", "TOLERANCES", "Draw", "draw", "campaign_manifest", "judge", "run_in_process",
           "AMBIGUOUS_WITH"]

#: mechanism -> parameter -> (low, high) magnitude range; a sign is drawn where both signs make sense.
HIDDEN_RANGES: dict[str, dict[str, tuple[float, float, bool]]] = {
    "sonic_ins_lag": {"lag_s": (0.25, 0.6, True)},
    "heading_bias": {"deg": (6.0, 12.0, True)},
    "w_gain": {"gain": (1.12, 1.3, False)},
    "sonic_noise": {"sigma_ms": (0.2, 0.4, False)},
    "mast_w_attenuation": {"gain": (0.78, 0.88, False)},
    "attitude_lag": {"lag_s": (0.2, 0.4, False)},
    # height_offset is not hidden here: the simulated INS records the lowered payload, the
    # chain measures that height and the forward model runs at it, so the shear effect is
    # part of the baseline prediction and "none" is the right answer. (Its probes stay in
    # the forward model for a biased altitude.)
    "clock_drift": {"ppm": (250.0, 450.0, True)},
}

#: Allowed estimation error per parameter (absolute, or relative when the key ends in '%').
TOLERANCES: dict[str, dict[str, float]] = {
    "sonic_ins_lag": {"lag_s": 0.08},
    "heading_bias": {"deg": 2.0},
    "w_gain": {"gain": 0.05},
    "sonic_noise": {"sigma_ms%": 0.35},
    "mast_w_attenuation": {"gain": 0.05},
    "attitude_lag": {"lag_s%": 0.4},
    "height_offset": {"dz_m%": 0.5},
    "clock_drift": {"ppm%": 0.35},
}

#: Mechanisms that predict the same features (reported as an ambiguity set, not guessed).
AMBIGUOUS_WITH: dict[str, set[str]] = {
    "heading_bias": {"mount_misalignment"},
    "mount_misalignment": {"heading_bias"},
}


@dataclass(frozen=True)
class Draw:
    """One hidden effect."""

    mechanism: str
    parameters: dict[str, float]
    seed: int


def draw(rng: np.random.Generator, mechanisms: list[str] | None = None, p_none: float = 0.25) -> Draw:
    """Draw a mechanism (``none`` with probability ``p_none``) and its size.

    Parameters
    ----------
    rng : numpy.random.Generator
        Seeded generator.
    mechanisms : list of str, optional
        Mechanisms to draw from (default: every key of :data:`HIDDEN_RANGES`).
    p_none : float
        Probability of the null case.

    Returns
    -------
    Draw
        The truth, with the campaign seed to simulate it.
    """
    names = mechanisms or sorted(HIDDEN_RANGES)
    seed = int(rng.integers(1, 2**31 - 1))
    if rng.random() < p_none:
        return Draw("none", {}, seed)
    mech = str(rng.choice(names))
    params = {}
    for name, (lo, hi, signed) in HIDDEN_RANGES[mech].items():
        value = float(rng.uniform(lo, hi))
        if signed and rng.random() < 0.5:
            value = -value
        params[name] = round(value, 4)
    return Draw(mech, params, seed)


def campaign_manifest(truth: Draw, name: str = "hidden", n_flights: int = 4, hover_min: float = 12.0,
                      speeds_ms: tuple[float, ...] = (3.5, 5.5, 7.5, 9.5)) -> dict[str, Any]:
    """A small virtual campaign (one mast sonic, ``n_flights`` payload flights) hiding ``truth``."""
    flights, conditions = [], {}
    for i in range(n_flights):
        fid = f"h{i + 1:02d}"
        start = np.datetime64("2023-08-21T10:00:00") + np.timedelta64(int(i * 3600), "s")
        end = start + np.timedelta64(int(hover_min * 60), "s")
        flights.append({
            "id": fid, "reference": "mast30", "target_height_m": 30,
            "sonic": {"file": f"flights/{fid}/sonic.csv", "mount": "upside_down"},
            "ins": {"file": f"flights/{fid}/ins.csv"},
            "window": {"start": f"{start}Z", "end": f"{end}Z"},
        })
        conditions[fid] = {"mean_speed_ms": float(speeds_ms[i % len(speeds_ms)]),
                           "wind_from_deg": float(200 + 25 * i), "z_over_L": float(-0.2 + 0.1 * i),
                           "hover_height_m": 28.0}
    mechanisms = [] if truth.mechanism == "none" else [{"mechanism": truth.mechanism,
                                                        "parameters": dict(truth.parameters)}]
    return {
        "name": name,
        "site": {"name": "virtual", "latitude": 43.1247, "longitude": 0.3628, "altitude_m": 603},
        "masts": [{"id": "m", "latitude": 43.1247, "longitude": 0.3628,
                   "sonics": [{"id": "mast30", "height_m": 30, "model": "CSAT3", "azimuth_deg": 218.0,
                               "files": ["mast/mast30_*.dat"]}]}],
        "payload_flights": flights,
        "simulation": {"seed": truth.seed, "payload_flights": conditions, "mechanisms": mechanisms},
    }


def judge(truth: Draw, diagnosis: Mapping[str, Any]) -> dict[str, Any]:
    """Compare a ``diagnosis.json`` with the hidden truth.

    Returns
    -------
    dict
        ``detected`` (the hidden mechanism is named, or is in an ambiguity set with a named
        one), ``false_alarm`` (something named although nothing was hidden),
        ``estimate_ok`` (every parameter within :data:`TOLERANCES`), ``named`` and the
        estimate.
    """
    named = list(diagnosis.get("named_causes") or [])
    out: dict[str, Any] = {"mechanism": truth.mechanism, "truth": truth.parameters, "named": named}
    if truth.mechanism == "none":
        out.update(detected=not named, false_alarm=bool(named), estimate_ok=True)
        return out
    groups = [set(g) for g in diagnosis.get("ambiguity_sets") or []]
    equivalents = {truth.mechanism} | AMBIGUOUS_WITH.get(truth.mechanism, set())
    in_group = any(truth.mechanism in g and g & set(named) for g in groups)
    detected = truth.mechanism in named or in_group or bool(equivalents & set(named[:1]))
    out["detected"] = bool(detected)
    out["false_alarm"] = False
    est = (diagnosis.get("named_estimates") or {}).get(truth.mechanism, {}).get("estimate")
    if est is None:
        est = next((c["estimate"] for c in diagnosis.get("candidates", []) if c["mechanism"] == truth.mechanism), {})
    out["estimate"] = est
    ok = True
    for key, tol in TOLERANCES.get(truth.mechanism, {}).items():
        name = key.rstrip("%")
        if name not in est:
            ok = False
            continue
        err = abs(float(est[name]) - truth.parameters[name])
        limit = tol * abs(truth.parameters[name]) if key.endswith("%") else tol
        ok &= err <= limit
    out["estimate_ok"] = bool(ok) if truth.mechanism in named else bool(ok and detected)
    return out


def _process_flight(data: Mapping[str, Any], flight: Mapping[str, Any], work: Path,
                    processing: Mapping[str, Any], seeds: tuple[int, ...]) -> tuple[dict[str, Any], dict[str, Any]]:
    """Simulate one flight of a hidden-effect campaign, process it, run its forward probes.

    Returns
    -------
    measured : dict
        Residual features of the flight (:func:`~dronewind.diagnose.features.features_to_dict`).
    forward_runs : dict
        :func:`dronewind.diagnose.forward.probe_runs` of the flight.
    """
    from dronewind.diagnose import forward
    from dronewind.diagnose.features import features_to_dict
    from dronewind.simulate.payload import simulate_payload_flight

    fid = flight["id"]
    lag = {key: processing[key] for key in forward.LAG_SETTINGS}
    paths = simulate_payload_flight(copy.deepcopy(dict(data)), work, fid, work)
    s1, i1 = compute_payload_l1(work / flight["sonic"]["file"], work / flight["ins"]["file"], processing["despike"])
    l2 = compute_payload_l2(s1, i1, flight, float(data["site"]["altitude_m"]), **lag)
    m1 = compute_mast_l1([p for p in paths if p.suffix == ".dat"], data["masts"][0]["sonics"][0],
                         processing["despike"])
    m2 = compute_mast_l2(m1, l2, fid, processing["drone_mast"])
    l3 = compute_l3(l2, m2, flight, processing["drone_mast"], processing["rotation"])
    measured = features_to_dict(forward.measured_features(data, fid, s1, i1, l2, l3, **lag))
    conditions = forward.forward_conditions(data, fid, l3, l2)
    return measured, forward.probe_runs(data, fid, conditions, processing, seeds=seeds)


def run_in_process(truth: Draw, config: Mapping[str, Any], work_dir: str | Path, **manifest_kw: Any
                   ) -> dict[str, Any]:
    """Simulate, process and diagnose a hidden-effect campaign in this process (no Snakemake).

    Uses the same library functions as the workflow's rules, in the same order; meant for
    the rate benchmark, where hundreds of Snakemake jobs per draw would cost more than the
    science.

    Parameters
    ----------
    truth : Draw
        The hidden effect.
    config : mapping
        Workflow configuration, possibly partial: missing settings take their defaults
        (:func:`dronewind.manifest.with_defaults`).
    work_dir : str or Path
        Folder for the raw files.
    **manifest_kw
        Passed to :func:`campaign_manifest`.

    Returns
    -------
    dict
        The diagnosis, as ``diagnosis.json``.
    """
    from dronewind.diagnose import campaign as dc

    settings = with_defaults(config)
    processing, diagnosis = settings["processing"], settings["diagnosis"]
    data = campaign_manifest(truth, **manifest_kw)
    measured, fwd = {}, {}
    for flight in data["payload_flights"]:
        measured[flight["id"]], fwd[flight["id"]] = _process_flight(data, flight, Path(work_dir), processing,
                                                                    tuple(diagnosis["seeds"]))
    result = dc.diagnose(dc.assemble(measured, fwd), alpha=float(diagnosis["alpha"]),
                         max_causes=int(diagnosis["max_causes"]), min_gain=float(diagnosis["min_gain"]))
    return dc.to_json(result, data["name"])
