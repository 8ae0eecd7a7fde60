"""Plan a drone-mast validation campaign: hover duration, separation, flights and wind range.

:func:`plan_campaign` answers, for a :class:`~dronewind.plan.spec.PlanSpec`:

* **hover duration**: the shortest hover whose predicted relative random uncertainties
  (:mod:`dronewind.plan.uncertainty`, Ghirardelli et al. 2025, Eqs 10-13) meet every target
  at the lowest planned wind speed (the uncertainties grow as the wind drops), at least the
  chain's usable hover (``processing.hover.min_duration_s``) plus a margin; when the
  platform's longest hover is too short at the lowest speed, the lowest speed is raised until
  it is not (the wind range the flights should span);
* **separation**: the largest drone-mast distance (:mod:`dronewind.plan.separation`);
* **flights**: the smallest number by which the detection power (:mod:`dronewind.plan.power`)
  of every error has reached the target, their speeds spanning the wind range: each error's
  power is simulated at one flight, two, ... up to the first count at which it reaches the
  target (the power against flight count; the power grows with the flights, so an error is not
  drawn again at the counts between that one and the plan's), and the plan's count is the
  largest of these; there every error's power is drawn with all its draws. The campaign's
  flights are simulated in stages (:func:`power_stages`: the first two, then two more at a
  time), each before the counts it adds, and the counts of a stage are drawn about the flights
  simulated up to it; a plan that reaches its target at a count does not simulate the flights
  beyond that count's stage;
* the manifest skeleton of the planned campaign (:mod:`dronewind.plan.manifest`).
"""

from __future__ import annotations

import logging
import math
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dronewind.core.progress import Progress
from dronewind.manifest import with_defaults
from dronewind.plan.manifest import flight_speeds, plan_manifest
from dronewind.plan.power import NO_ERROR, PowerResult, campaign_power_model, draw_powers, power_pool
from dronewind.plan.separation import along_wind_limit_m, separation_limit_m
from dronewind.plan.simulation import campaign_evidences, with_error
from dronewind.plan.spec import PlanSpec
from dronewind.plan.uncertainty import DURATION_STEP_S, PointUncertainty, point_uncertainty

__all__ = ["CampaignPlan", "plan_campaign", "power_campaigns", "power_stages", "search_counts", "plan_uncertainty",
           "HOVER_MARGIN_S", "STAGE_FLIGHTS"]

#: Flights added to the power simulation at each stage after the first (:func:`power_stages`).
STAGE_FLIGHTS = 2

#: Margin added to the chain's shortest usable hover [s]: the hover window found in the INS
#: track is a few seconds shorter than the planned one (a planned 600 s gave 596 s).
HOVER_MARGIN_S = 30.0

log = logging.getLogger("dronewind")


@dataclass
class CampaignPlan:
    """The plan's answer (:func:`plan_campaign`)."""

    spec: PlanSpec
    duration_s: float
    speed_range_ms: tuple[float, float]
    speeds_ms: list[float]
    n_flights: int
    separation_limit_m: float
    along_wind_limit_m: float
    distance_m: float
    uncertainty: dict[str, dict[str, float]]
    targets_met: dict[str, bool]
    power: dict[str, PowerResult] = field(default_factory=dict)
    false_alarm: PowerResult | None = None
    power_curve: dict[str, list[PowerResult]] = field(default_factory=dict)
    power_note: str = ""
    notes: list[str] = field(default_factory=list)
    manifest: dict[str, Any] = field(default_factory=dict)
    points: dict[float, PointUncertainty] = field(default_factory=dict, repr=False)
    seconds: dict[str, float] = field(default_factory=dict)
    #: flights of the campaign simulated for the power (:func:`power_stages`; 0 without the power)
    simulated_flights: int = 0

    def to_json(self) -> dict[str, Any]:
        """The plan as JSON-serialisable data."""
        def pr(r: PowerResult) -> dict[str, Any]:
            lo, hi = r.interval
            return {"n_flights": r.n_flights, "detected": r.detected, "draws": r.draws, "power": r.power,
                    "ci95": [lo, hi]}

        return {
            "name": self.spec.name, "platform": self.spec.platform,
            "hover_duration_s": self.duration_s, "wind_range_ms": list(self.speed_range_ms),
            "flight_speeds_ms": self.speeds_ms, "n_flights": self.n_flights,
            "hover_height_m": self.spec.hover_height_m, "reference_height_m": self.spec.reference_height_m,
            "separation_limit_cross_wind_m": self.separation_limit_m,
            "separation_limit_along_wind_m": self.along_wind_limit_m, "planned_distance_m": self.distance_m,
            "targets": self.spec.targets, "predicted_uncertainty": self.uncertainty, "targets_met": self.targets_met,
            "power_target": self.spec.power,
            "power": {k: pr(v) for k, v in self.power.items()},
            "no_false_alarm": None if self.false_alarm is None else pr(self.false_alarm),
            "power_curve": {k: [pr(r) for r in v] for k, v in self.power_curve.items()},
            "power_method": self.power_note, "simulated_flights": self.simulated_flights, "notes": self.notes,
            "seconds": self.seconds,
        }

    def table(self) -> str:
        """The plan as a plain-text table."""
        lines = [f"plan {self.spec.name} ({self.spec.platform})",
                 f"  hover duration          {self.duration_s / 60:.1f} min ({self.duration_s:.0f} s)",
                 f"  hover height            {self.spec.hover_height_m:g} m (mast sonic at "
                 f"{self.spec.reference_height_m:g} m)",
                 f"  largest separation      {self.separation_limit_m:.0f} m across the wind, "
                 f"{self.along_wind_limit_m:.0f} m along it (planned {self.distance_m:.0f} m across)",
                 f"  flights                 {self.n_flights} at "
                 + ", ".join(f"{u:g}" for u in self.speeds_ms) + " m/s",
                 f"  wind range              {self.speed_range_ms[0]:g}-{self.speed_range_ms[1]:g} m/s",
                 "", f"  {'quantity':<10}{'target':>8}{'lowest U':>10}{'highest U':>11}  met"]
        lo, hi = (f"{u:g}" for u in self.speed_range_ms)
        for q in self.uncertainty[lo]:
            target = self.spec.targets.get(q)
            t = f"{target:.3f}" if target is not None else "-"
            met = "" if target is None else ("yes" if self.targets_met[q] else "NO")
            lines.append(f"  {q:<10}{t:>8}{self.uncertainty[lo][q]:>10.3f}{self.uncertainty[hi][q]:>11.3f}  {met}")
        if self.power:
            lines += ["", f"  {'error to detect':<26}{'power':>7}  {'95 % interval':<13}  target {self.spec.power:g}"]
            for label, r in self.power.items():
                lo_ci, hi_ci = r.interval
                ok = "yes" if r.power >= self.spec.power else "NO"
                lines.append(f"  {label:<26}{r.power:>7.2f}  {lo_ci:.2f}-{hi_ci:.2f}      {ok}  "
                             f"({r.detected}/{r.draws} draws)")
            if self.false_alarm is not None:
                fa = 1.0 - self.false_alarm.power
                lo_ci, hi_ci = self.false_alarm.interval
                lines.append(f"  {'false alarm (no error)':<26}{fa:>7.2f}  {1 - hi_ci:.2f}-{1 - lo_ci:.2f}")
        if self.power_note:
            lines += ["", "  " + self.power_note]
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)


def plan_uncertainty(spec: PlanSpec, speed_ms: float) -> PointUncertainty:
    """The predicted uncertainty model at the plan's hover point and ``speed_ms``."""
    return point_uncertainty(spec.hover_height_m, speed_ms, spec.wind_from_deg, spec.obukhov_length_m,
                             spec.roughness_length_m, spec.boundary_layer_height_m, spec.theta_mean_k, seed=spec.seed)


def _hover(spec: PlanSpec, min_hover_s: float) -> tuple[float, float, list[str]]:
    """Hover duration [s] and lowest usable speed [m s-1] (module docstring) and notes."""
    notes: list[str] = []
    lo, hi = spec.speed_range_ms
    floor = DURATION_STEP_S * math.ceil((min_hover_s + HOVER_MARGIN_S) / DURATION_STEP_S)
    need_lo = plan_uncertainty(spec, lo).duration_for(spec.targets)
    if need_lo <= spec.max_hover_s:
        return max(need_lo, floor), lo, notes
    if plan_uncertainty(spec, hi).duration_for(spec.targets) > spec.max_hover_s:
        notes.append(f"the targets need more than the longest hover ({spec.max_hover_s / 60:g} min) even at "
                     f"{hi:g} m/s: the plan flies the longest hover and the targets are not met")
        return spec.max_hover_s, lo, notes
    a, b = lo, hi  # bisection on the speed at which the longest hover just suffices
    for _ in range(14):
        mid = 0.5 * (a + b)
        if plan_uncertainty(spec, mid).duration_for(spec.targets) > spec.max_hover_s:
            a = mid
        else:
            b = mid
    new_lo = math.ceil(b * 10) / 10
    notes.append(f"below {new_lo:g} m/s the longest hover ({spec.max_hover_s / 60:g} min) does not meet the "
                 f"targets: the flights should span {new_lo:g}-{hi:g} m/s")
    return max(plan_uncertainty(spec, new_lo).duration_for(spec.targets), floor), new_lo, notes


def plan_campaign(spec: PlanSpec, config: Mapping[str, Any] | None = None, work_dir: str | Path | None = None,
                  simulate_power: bool = True, workers: int = 1) -> CampaignPlan:
    """Plan the campaign (module docstring).

    Parameters
    ----------
    spec : PlanSpec
        The plan (:func:`dronewind.plan.spec.load_plan`).
    config : mapping, optional
        Workflow configuration (processing and diagnosis settings; defaults where missing).
    work_dir : str or Path, optional
        Folder for the simulated records (a temporary folder by default).
    simulate_power : bool
        Compute the detection power (the simulated null campaign and the Monte Carlo); when
        false only the uncertainties, the separation and the skeleton.
    workers : int
        Processes for the power's simulated flights and Monte-Carlo calls (one flight, or one
        error and flight count, per task); the plan does not depend on it.

    Returns
    -------
    CampaignPlan
    """
    t_start = time.perf_counter()
    cpu_start = time.process_time()
    settings = with_defaults(dict(config or {}))
    processing = settings["processing"]
    duration, lowest, notes = _hover(spec, float(processing["hover"]["min_duration_s"]))
    hi = spec.speed_range_ms[1]
    points = {u: plan_uncertainty(spec, u) for u in sorted({lowest, hi})}
    unc = {f"{u:g}": points[u].relative(duration) for u in points}
    worst = {q: max(v[q] for v in unc.values()) for q in unc[f"{lowest:g}"]}
    met = {q: worst[q] <= t * (1 + 1e-9) for q, t in spec.targets.items()}
    dz = spec.hover_height_m - spec.reference_height_m
    limit = separation_limit_m(spec.hover_height_m, lowest, spec.obukhov_length_m, spec.roughness_length_m,
                               spec.min_correlation, spec.boundary_layer_height_m, dz)
    along = along_wind_limit_m(limit, lowest, float(processing["drone_mast"]["max_lag_s"]))
    distance = min(spec.hover_distance_m, limit)
    if spec.hover_distance_m > limit:
        notes.append(f"the planned distance {spec.hover_distance_m:g} m exceeds the separation limit "
                     f"{limit:.0f} m: the skeleton hovers at the limit")
    seconds = {"uncertainty_and_separation": time.perf_counter() - t_start}
    plan = CampaignPlan(spec, duration, (lowest, hi), [], spec.max_flights, limit, along, distance, unc, met,
                        notes=notes, points=points, seconds=seconds)
    if spec.platform != "sling_load":
        plan.power_note = (f"detection power not simulated: the campaign diagnosis (dronewind.diagnose.campaign) "
                           f"models the sling-load payload; platform {spec.platform}")
    if not (simulate_power and spec.detect and spec.platform == "sling_load"):
        plan.n_flights = spec.max_flights
        plan.speeds_ms = flight_speeds(lowest, hi, plan.n_flights)
        plan.manifest = plan_manifest(spec, plan.n_flights, duration, plan.speeds_ms, distance)
        return plan
    worker_cpu = _power(plan, settings, work_dir, max(1, int(workers)))
    plan.seconds["total"] = time.perf_counter() - t_start
    # this process's CPU and that of the power's tasks that ran in worker processes
    plan.seconds["total_cpu"] = time.process_time() - cpu_start + worker_cpu
    return plan


def power_campaigns(plan: CampaignPlan) -> dict[str, dict[str, Any]]:
    """The campaigns the detection power is simulated from: the plan's ``max_flights`` without and with each error.

    Parameters
    ----------
    plan : CampaignPlan
        A plan's hover duration, wind range and distance (:func:`plan_campaign`, the power not
        needed).

    Returns
    -------
    dict
        :data:`~dronewind.plan.power.NO_ERROR` -> the virtual campaign of ``max_flights`` flights
        spanning the wind range at the plan's seed; each error's label -> the same campaign
        with that error hidden (common random numbers, :mod:`dronewind.plan.power`).
    """
    spec = plan.spec
    speeds = flight_speeds(plan.speed_range_ms[0], plan.speed_range_ms[1], spec.max_flights)
    full = plan_manifest(spec, spec.max_flights, plan.duration_s, speeds, plan.distance_m, seed=spec.seed)
    return {NO_ERROR: with_error(full, None)} | {e.label: with_error(full, e) for e in spec.detect}


def power_stages(max_flights: int, step: int = STAGE_FLIGHTS) -> list[int]:
    """Flight counts simulated for the power before each search step (module docstring).

    Parameters
    ----------
    max_flights : int
        The plan's most flights.
    step : int
        Flights added at each stage after the first, which holds
        :data:`~dronewind.diagnose.probes.MIN_FLIGHTS` (the fewest a campaign diagnosis takes).

    Returns
    -------
    list of int
        Increasing flight counts ending at ``max_flights``.

    Examples
    --------
    >>> power_stages(6), power_stages(2), power_stages(7), power_stages(1)
    ([2, 4, 6], [2], [2, 4, 6, 7], [1])
    """
    from dronewind.diagnose.probes import MIN_FLIGHTS

    most = max(1, int(max_flights))
    stages = [min(most, max(MIN_FLIGHTS, int(step)))]
    while stages[-1] < most:
        stages.append(min(most, stages[-1] + max(1, int(step))))
    return stages


def search_counts(labels: Sequence[str], counts: Sequence[int], reach: dict[str, int | None],
                  curve: dict[str, list[PowerResult]], target: float, workers: int,
                  draw: Callable[[list[tuple[str, int]]], list[PowerResult]]) -> None:
    """Each error's power at ``counts`` in turn, until the first count at which it reaches ``target``.

    The power grows with the flights: an error that reached the target is not drawn at later
    counts. The counts are drawn in batches of as many as fill ``workers`` evenly with the errors
    still drawn (three errors on two workers: two counts, six calls; two errors: one count; one
    error: two counts); a count below :data:`~dronewind.diagnose.probes.MIN_FLIGHTS` (its draws
    are not diagnosed, it costs nothing) alone. A result beyond an error's first count that
    reaches the target is left out, so that ``reach`` and ``curve`` do not depend on ``workers``.

    Parameters
    ----------
    labels : sequence of str
        The errors.
    counts : sequence of int
        Increasing flight counts to draw.
    reach : dict
        Error -> the first count at which it reached the target, or None; updated.
    curve : dict
        Error -> its power at each count drawn, in order; extended.
    target : float
        Power target [1].
    workers : int
        Processes ``draw`` spreads its calls over.
    draw : callable
        ``[(error, count), ...]`` -> their :class:`~dronewind.plan.power.PowerResult`, in order.
    """
    from dronewind.diagnose.probes import MIN_FLIGHTS

    todo = list(counts)
    while todo and any(reach[label] is None for label in labels):
        pending = [label for label in labels if reach[label] is None]
        ks = todo[:1] if todo[0] < MIN_FLIGHTS else todo[:max(1, workers // math.gcd(len(pending), max(1, workers)))]
        todo = todo[len(ks):]
        results = draw([(label, k) for k in ks for label in pending])
        for j, k in enumerate(ks):
            for label, result in zip(pending, results[j * len(pending):(j + 1) * len(pending)], strict=True):
                if reach[label] is None:
                    curve[label].append(result)
                    if result.power >= target:
                        reach[label] = k


def _merge_evidence(into: dict[str, dict[str, Any]], new: Mapping[str, Mapping[str, Any]]) -> None:
    """Add the flights of ``new`` (:func:`~dronewind.plan.simulation.campaign_evidences`) to ``into``."""
    for key, ev in new.items():
        have = into.setdefault(key, {"name": ev["name"], "measured": {}, "forward": {}, "statistics": {}})
        for part in ("measured", "forward", "statistics"):
            have[part].update(ev[part])


def _power(plan: CampaignPlan, settings: Mapping[str, Any], work_dir: str | Path | None, workers: int) -> float:
    """Simulate the campaign without and with each error in stages of flights, each stage followed by
    the power at its flight counts, until every error reaches the target; then the power at that count.

    Returns the CPU time of the tasks that ran in worker processes [s] (0 with one worker).
    """
    spec = plan.spec
    cpu: list[float] = []  # CPU time of every task [s]
    manifests = power_campaigns(plan)
    flight_ids = [f["id"] for f in manifests[NO_ERROR]["payload_flights"]]
    labels = [e.label for e in spec.detect]
    draws_curve = min(spec.curve_draws, spec.draws)
    more_draws = spec.draws - draws_curve
    plan.power_curve = {label: [] for label in labels}
    plan.seconds["simulation"] = plan.seconds["power_draws"] = 0.0
    evidence: dict[str, dict[str, Any]] = {}
    #: error -> the first flight count at which its power reached the target
    reach: dict[str, int | None] = dict.fromkeys(labels)
    final: dict[str | None, PowerResult] = {}
    n = spec.max_flights
    simulated = 0
    # Counts in turn, each error until the first count at which its power reaches the target
    # (search_counts); the plan's count is the largest of these first counts, and the flights and
    # counts above it are not needed to find it. The flights are simulated in stages (power_stages);
    # the counts of a stage are drawn about the flights simulated so far.
    with tempfile.TemporaryDirectory(dir=work_dir) as tmp:
        for stage in power_stages(spec.max_flights):
            t0 = time.perf_counter()
            progress = Progress("plan flight", (stage - simulated) * (1 + len(labels)), "done")
            _merge_evidence(evidence, campaign_evidences(manifests, settings, tmp, progress, workers, cpu,
                                                         flights=flight_ids[simulated:stage]))
            progress.finished()
            model = campaign_power_model(manifests, evidence, spec.detect)
            plan.seconds["simulation"] += time.perf_counter() - t0
            t1 = time.perf_counter()
            counts = list(range(simulated + 1, stage + 1))
            simulated = stage
            pool = power_pool(model, workers) if workers > 1 else None
            progress_power = Progress("power", 0, "diagnosed")  # this stage's draws

            def draw_curve(calls: list[tuple[str, int]], model: Any = model, pool: Any = pool,
                           progress_power: Progress = progress_power) -> list[PowerResult]:
                progress_power.total += len(calls)
                return draw_powers(model, [(label, k, draws_curve, spec.seed) for label, k in calls], settings,
                                   progress_power, spec.reference, workers, cpu, pool)

            try:
                search_counts(labels, counts, reach, plan.power_curve, spec.power, workers, draw_curve)
                done = all(reach[label] is not None for label in labels)
                if done or stage == spec.max_flights:
                    # the plan's count; every error's power there from all its draws, and the false alarms
                    n = max(r for r in reach.values() if r is not None) if done else spec.max_flights
                    calls: list[tuple[str | None, int, int, int]] = [(None, n, spec.draws, spec.seed + 2)]
                    for label in labels:
                        if reach[label] in (None, n):  # drawn at n already: the more draws
                            calls += [(label, n, more_draws, spec.seed + 1)] if more_draws > 0 else []
                        else:  # reached at fewer flights: all its draws at n
                            calls.append((label, n, spec.draws, spec.seed))
                    progress_power.total += len(calls)
                    final = dict(zip([c[0] for c in calls],
                                     draw_powers(model, calls, settings, progress_power, spec.reference, workers,
                                                 cpu, pool), strict=True))
            finally:
                if pool is not None:
                    pool.shutdown()
            progress_power.finished()
            plan.seconds["power_draws"] += time.perf_counter() - t1
            if final:
                break
    plan.simulated_flights = simulated
    if not all(reach[label] is not None for label in labels):
        plan.notes.append(f"no number of flights up to {spec.max_flights} reaches power {spec.power:g} for "
                          "every error: the plan flies the most and the power target is not met")
    elif n < spec.max_flights:
        plan.notes.append(f"power against flight count drawn for each error up to the first count that reaches power "
                          f"{spec.power:g} ("
                          + ", ".join(f"{label}: {reach[label]}" for label in labels)
                          + f"), then at the plan's {n} flight{'s' if n > 1 else ''}, the largest of these "
                          f"({simulated} of {spec.max_flights} flights simulated)")
    for label in labels:
        at_n = [r for r in plan.power_curve[label] if r.n_flights == n]
        more = final.get(label, PowerResult(label, n, 0, 0))
        first = at_n[0] if at_n and reach[label] in (None, n) else PowerResult(label, n, 0, 0)
        plan.power[label] = PowerResult(label, n, first.detected + more.detected, first.draws + more.draws)
    plan.false_alarm = final[None]
    plan.n_flights = n
    plan.speeds_ms = flight_speeds(plan.speed_range_ms[0], plan.speed_range_ms[1], spec.max_flights)[:n]
    plan.speed_range_ms = (min(plan.speeds_ms), max(plan.speeds_ms)) if n > 1 else plan.speed_range_ms
    plan.manifest = plan_manifest(spec, n, plan.duration_s, plan.speeds_ms, plan.distance_m)
    plan.power_note = (f"power: {spec.draws} Monte-Carlo campaigns per error drawn about the {simulated}-flight "
                       f"campaign simulated with the error (its effect: the residuals' difference from the same "
                       f"campaign without it; noise factor {model.noise_factor:.2f}), each diagnosed and judged as a "
                       f"measured campaign"
                       + (" against one bootstrap reference per error and flight count" if spec.reference == "shared"
                          else " with a bootstrap reference of its own") + "; 95 % Wilson intervals")
    return float(sum(cpu)) if workers > 1 else 0.0
