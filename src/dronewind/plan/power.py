r"""Detection power of a planned campaign: the event the campaign diagnosis decides, sampled.

Main path (:func:`dronewind.plan.planner.plan_campaign`), per plan:

1. The planned campaign is simulated, processed and forward-run in this process twice at one
   campaign seed (common random numbers): without any error, and with each error to detect
   hidden in the simulation at its planned size (:func:`~dronewind.plan.simulation.manifest_evidence`: the in-process
   path of :mod:`dronewind.diagnose.experiments`,
   :func:`~dronewind.diagnose.in_process.process_virtual_flight` and
   :func:`dronewind.diagnose.probe_runs.probe_runs`). The forward runs of each are conditioned
   on what the chain measured of that campaign (wind, stability, sonic-INS lag), so an error
   that also moves a measured condition (a heading bias moves the wind direction, a lag the
   lag the chain finds) has the effect on the residual features that the diagnosis sees.
   A flight whose chain measured exactly the conditions of the campaign without the error,
   over the same mast record, has the same forward runs; they are made once
   (:func:`~dronewind.plan.simulation.campaign_evidences`). The flights are simulated in
   stages (:func:`dronewind.plan.planner.power_stages`), and the model of a stage's flight
   counts is assembled from the flights simulated up to it (:func:`campaign_power_model`).
   Through :func:`dronewind.diagnose.campaign.assemble` each campaign gives its forward
   baseline :math:`\bar b_{i,f}`, residual errors :math:`\sigma_{i,f}`, shrunk feature
   correlation :math:`R^*` and candidates' responses (the diagnosis' probes).
2. The error's effect on the residuals is the difference of the two campaigns' residuals,
   :math:`\Delta_{i,f} = (y^E - \bar b^E)_{i,f} - (y^0 - \bar b^0)_{i,f}`: the realisation
   the two share cancels.
3. Monte Carlo: a measured campaign is drawn as
   :math:`y_i = \bar b^E_i + \Delta_i + c\,D^E_i L^E \xi_i` (:math:`\xi` standard normal,
   :math:`L L^\top = R^*`, :math:`D_i = \mathrm{diag}(\sigma_{i,f})`) against the forward runs
   of the campaign with the error, and decided exactly as a measured campaign is: by
   :func:`dronewind.diagnose.in_process.decide_evidence`'s call of
   :func:`dronewind.diagnose.campaign.diagnose` (the configured alpha, ``max_causes``,
   ``min_gain`` and bootstrap replicates; the record of the decision without the goodness of
   fit, which does not change what is named), judged by
   :func:`dronewind.diagnose.experiments.judge` against the planned manifest (the flights'
   own processing lags). The factor :math:`c` is the root mean square of the simulated null
   campaign's own standardised residuals :math:`(y - \bar b)/\sigma` over flights and
   features: the realised misfit, discrepancy included. The draws share the forward runs, so
   the bootstrap reference of their diagnoses is drawn once per error and flight count
   (:func:`shared_reference`: with the root mean square of the discrepancies the draws
   profile, in place of each draw's own);
   ``monte_carlo.reference: per_draw`` gives every draw its own, as a measured campaign's
   diagnosis has. The two decide paired draws alike but where a p-value sits near alpha
   (``benchmarks/results/plan_reference_agreement.json``, ``benchmarks/plan_reference_agreement.py``).
4. The power is the share of draws in which the judge finds the error detected (named, or an
   ambiguity-equivalent cause named; a hidden sonic-INS lag, which the chain measures and the
   forward runs are conditioned on, is detected when no cause is named), with its 95 % Wilson
   interval (Wilson 1927) for the number of draws; the false-alarm rate from draws of the
   campaign without the error (:math:`\Delta = 0`).

Cost: a 2-flight campaign costs about 16 CPU-s to simulate, process and forward-run; a shared
bootstrap reference about 2.7 CPU-s on two flights and 3.3 on three (600 replicates of the
example plan's campaigns; throughput in ``benchmarks/test_bench_statistics.py``) and each drawn
campaign's decision against it about 0.16 CPU-s on three flights (0.48 with the goodness of fit,
which is not computed: it refits the named causes on every replicate; 20 draws of a 3 degree
heading bias); a draw with a reference of its own as much as a shared one. Full simulations of every draw
would add the simulation's cost to each; they are the check (:func:`simulated_detection`,
``benchmarks/plan_validation.py``).
"""

from __future__ import annotations

import copy
import math
import tempfile
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dronewind.core.progress import Progress
from dronewind.manifest import with_defaults
from dronewind.plan.simulation import manifest_evidence, process_pool, with_error
from dronewind.plan.spec import Detect

__all__ = ["NO_ERROR", "campaign_power_model", "draw_powers", "power_pool", "PowerModel", "power_model", "draw_power",
           "shared_reference", "drawn_campaigns", "DrawnCampaign", "PowerResult", "simulated_detection"]


class _null:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> None:
        return None


@dataclass
class CaseModel:
    """One simulated campaign (without or with an error) as the diagnosis assembles it.

    Attributes
    ----------
    flights : list of str
        Flight ids, in the diagnosis' order.
    measured, forward : dict
        Flight -> measured features and forward runs (:func:`~dronewind.plan.simulation.manifest_evidence`).
    baseline, sigma : numpy.ndarray
        Mean forward baseline and residual errors (n_flights, n_features) [feature units].
    residual : numpy.ndarray
        Measured minus baseline (n_flights, n_features) [feature units].
    chol : numpy.ndarray
        Cholesky factor of the shrunk feature correlation (n_features, n_features).
    manifest : dict
        The simulated manifest (the judge reads the flights' processing lags from it).
    """

    flights: list[str]
    measured: dict[str, Any]
    forward: dict[str, Any]
    baseline: np.ndarray
    sigma: np.ndarray
    residual: np.ndarray
    chol: np.ndarray
    manifest: dict[str, Any]


@dataclass
class PowerModel:
    """The null campaign, the campaigns with each error, the errors' effects and the noise factor."""

    null: CaseModel
    noise_factor: float
    cases: dict[str, CaseModel] = field(default_factory=dict)
    effects: dict[str, np.ndarray] = field(default_factory=dict)
    errors: dict[str, Detect] = field(default_factory=dict)
    #: (label, flights) -> the shared bootstrap reference of its draws (:func:`shared_reference`)
    references: dict[tuple[str | None, int], Any] = field(default_factory=dict, repr=False)

    @property
    def flights(self) -> list[str]:
        """Flight ids of the campaign."""
        return self.null.flights


def _case(evidence: Mapping[str, Any], manifest: Mapping[str, Any]) -> CaseModel:
    from dronewind.diagnose import campaign as dc
    from dronewind.diagnose.features import FEATURES

    ev = dc.assemble(evidence["measured"], evidence["forward"])
    n_f = len(FEATURES)
    corr = ev.corr if ev.corr is not None else np.eye(n_f)
    corr = np.where(np.isfinite(corr), corr, 0.0)
    np.fill_diagonal(corr, 1.0)
    chol = np.linalg.cholesky(corr + 1e-9 * np.eye(n_f))
    return CaseModel(list(ev.flights), dict(evidence["measured"]), dict(evidence["forward"]), ev.baseline, ev.sigma,
                     ev.y - ev.baseline, chol, copy.deepcopy(dict(manifest)))


def power_model(null_evidence: Mapping[str, Any], null_manifest: Mapping[str, Any],
                error_evidence: Mapping[str, tuple[Detect, Mapping[str, Any], Mapping[str, Any]]] | None = None
                ) -> PowerModel:
    """Response and error models of the campaigns and the errors' effects (module docstring, steps 1-2).

    Parameters
    ----------
    null_evidence : mapping
        :func:`~dronewind.plan.simulation.manifest_evidence` of the campaign without errors.
    null_manifest : mapping
        Its manifest.
    error_evidence : mapping, optional
        Error label -> (error, :func:`~dronewind.plan.simulation.manifest_evidence` of the
        campaign with the error hidden, at the null campaign's seed, and its manifest).

    Returns
    -------
    PowerModel
    """
    null = _case(null_evidence, null_manifest)
    z = null.residual / null.sigma
    factor = float(np.sqrt(np.nanmean(z**2))) if np.isfinite(z).any() else 1.0
    model = PowerModel(null, factor)
    for label, (error, evidence, manifest) in (error_evidence or {}).items():
        case = _case(evidence, manifest)
        if case.flights != null.flights:
            raise ValueError(f"{label}: the campaign with the error has flights {case.flights}, not {null.flights}")
        delta = case.residual - null.residual
        model.cases[label] = case
        model.effects[label] = np.where(np.isfinite(delta), delta, 0.0)
        model.errors[label] = error
    return model


#: Key of the campaign without an error in :func:`campaign_power_model`'s manifests.
NO_ERROR = "no error"


def campaign_power_model(manifests: Mapping[str, Mapping[str, Any]], evidences: Mapping[str, Mapping[str, Any]],
                         errors: Sequence[Detect]) -> PowerModel:
    """:func:`power_model` of the campaigns :func:`dronewind.plan.planner.power_campaigns` gives.

    Parameters
    ----------
    manifests : mapping
        :data:`NO_ERROR` -> the campaign without an error; error label -> the same campaign with
        that error hidden (same seed).
    evidences : mapping
        The same keys -> their :func:`~dronewind.plan.simulation.campaign_evidences`: the same
        flights of each (all, or the first ones, simulated so far); the models are assembled from
        those flights.
    errors : sequence of Detect
        The errors (their labels are keys of ``manifests``).

    Returns
    -------
    PowerModel
    """
    return power_model(evidences[NO_ERROR], manifests[NO_ERROR],
                       {e.label: (e, evidences[e.label], manifests[e.label]) for e in errors})


@dataclass(frozen=True)
class PowerResult:
    """Detection rate of drawn campaigns with its 95 % Wilson interval."""

    label: str
    n_flights: int
    detected: int
    draws: int

    @property
    def power(self) -> float:
        """Detected share."""
        return self.detected / self.draws if self.draws else float("nan")

    @property
    def interval(self) -> tuple[float, float]:
        """95 % Wilson interval."""
        from dronewind.diagnose.experiments import wilson_interval

        return wilson_interval(self.detected, self.draws)


def _measured(case: CaseModel, y: np.ndarray, flights: Sequence[str]) -> dict[str, Any]:
    from dronewind.diagnose.features import FEATURES

    out = {}
    for i, fid in enumerate(flights):
        m = copy.copy(case.measured[fid])
        original = m["values"]
        m["values"] = {f: (None if original.get(f) is None or not math.isfinite(y[i, k]) else float(y[i, k]))
                       for k, f in enumerate(FEATURES)}
        out[fid] = m
    return out


def _first_flights(manifest: Mapping[str, Any], flights: Sequence[str]) -> dict[str, Any]:
    """``manifest`` with only ``flights`` among its payload flights (and their simulated conditions)."""
    out = copy.deepcopy(dict(manifest))
    keep = set(flights)
    out["payload_flights"] = [f for f in out["payload_flights"] if f["id"] in keep]
    sim = out.get("simulation")
    if isinstance(sim, dict) and isinstance(sim.get("payload_flights"), dict):
        sim["payload_flights"] = {k: v for k, v in sim["payload_flights"].items() if k in keep}
    return out


def shared_reference(draws: Sequence[DrawnCampaign], config: Mapping[str, Any] | None = None) -> Any:
    r"""One bootstrap reference for drawn campaigns that share their forward runs.

    Parameters
    ----------
    draws : sequence of DrawnCampaign
        Campaigns drawn about one simulated case (:func:`drawn_campaigns`: same flights, same
        forward runs).
    config : mapping, optional
        Workflow configuration (its ``diagnosis.bootstrap`` replicates).

    Returns
    -------
    dronewind.diagnose.reference.NullReference or None
        None where there are no draws, fewer than two seeds or no candidates (the diagnosis then
        uses its chi-square tails, as for a measured campaign), or fewer flights than the
        campaign diagnosis needs (:data:`dronewind.diagnose.probes.MIN_FLIGHTS`: the draws are
        then not diagnosed, and a reference would be drawn for nothing).

    Notes
    -----
    Every input of a draw's own reference (:func:`dronewind.diagnose.naming.diagnose`) is the
    same for all draws but the model discrepancy :math:`\hat\tau_f` the draw profiles from its
    residuals about the baseline. The shared reference takes its root mean square over the
    draws, :math:`\tau_f = (\overline{\hat\tau_f^2})^{1/2}`: the replicates' discrepancy
    variance is then the draws' mean one. A hidden error moves the residuals, so its draws
    profile a larger discrepancy than the null's and their reference is wider, as each draw's
    own is. Checked on paired draws against a reference of each draw's own
    (``benchmarks/plan_reference_agreement.py``).
    """
    from dronewind.diagnose import campaign as dc
    from dronewind.diagnose.calibration import discrepancy
    from dronewind.diagnose.naming import campaign_reference
    from dronewind.diagnose.probes import MIN_FLIGHTS

    if not draws:
        return None
    n_replicates = int(with_defaults(dict(config or {}))["diagnosis"]["bootstrap"])
    # the draws share everything but their features: one assembly, each draw's features in its
    # measured entries (a feature the campaign does not use stays out, as assemble leaves it)
    ev = dc.assemble(draws[0].evidence["measured"], draws[0].evidence["forward"])
    if ev.n_seeds < 2 or n_replicates <= 0 or not ev.models or len(ev.flights) < MIN_FLIGHTS:
        return None
    used = np.isfinite(ev.y)
    tau2 = [discrepancy(np.where(used, d.y, np.nan) - ev.baseline, ev.sigma, ev.speed_ms,
                        interval=False).tau_or_zero() ** 2 for d in draws]
    return campaign_reference(ev, np.sqrt(np.mean(tau2, axis=0)), n_replicates)


def draw_power(model: PowerModel, label: str | None, n_flights: int, draws: int, seed: int,
               config: Mapping[str, Any] | None = None, progress: Progress | None = None,
               reference: str = "shared") -> PowerResult:
    """Detection rate of ``label`` (``None``: no error; then the rate of naming nothing) over drawn campaigns.

    Parameters
    ----------
    model : PowerModel
        From :func:`power_model`.
    label : str or None
        Error label (:attr:`Detect.label`) or None for the null case.
    n_flights : int
        Use the first ``n_flights`` flights.
    draws : int
        Monte-Carlo draws.
    seed : int
        Seed of the draws.
    config : mapping, optional
        Workflow configuration (its ``diagnosis`` settings, as
        :func:`dronewind.diagnose.in_process.decide_evidence` reads them).
    progress : Progress, optional
        One item per draw.
    reference : {"shared", "per_draw"}
        ``shared``: one bootstrap reference for all draws of this case and flight count
        (:func:`shared_reference`, kept in ``model.references``); ``per_draw``: each draw's
        diagnosis draws its own, exactly as a measured campaign's does (about 3 CPU-s per draw on two or
        three flights against 0.1-0.4, ``benchmarks/results/plan_reference_agreement.json``).

    Returns
    -------
    PowerResult
        For ``label=None``, ``detected`` counts the draws naming nothing (1 - false-alarm rate).
    """
    from dronewind.diagnose.experiments import judge
    from dronewind.diagnose.in_process import decide_evidence

    if reference not in ("shared", "per_draw"):
        raise ValueError(f"reference {reference!r}: expected 'shared' or 'per_draw'")
    drawn = list(drawn_campaigns(model, label, n_flights, draws, seed))
    ref = None
    if reference == "shared":
        key = _reference_key(model, label, n_flights)
        if key not in model.references:
            model.references[key] = shared_reference(drawn, config)
        ref = model.references[key]
    hits = 0
    for k, draw in enumerate(drawn):
        ctx = progress.item(f"{label or 'no error'}, {n_flights} flights, draw {k + 1}") if progress else _null()
        with ctx:
            out = decide_evidence(draw.evidence, dict(config or {}), reference=ref)
            hits += bool(judge(draw.truth, out, draw.campaign)["detected"])
    return PowerResult(label or "none", n_flights, hits, draws)


#: The power model of a worker process of :func:`draw_powers` (set once per process by its initializer).
_WORKER_MODEL: PowerModel | None = None


def _set_worker_model(model: PowerModel) -> None:
    global _WORKER_MODEL
    _WORKER_MODEL = model


def _reference_key(model: PowerModel, label: str | None, n_flights: int) -> tuple[str | None, int]:
    """Key of ``model.references`` for a case and flight count (more flights than the case has: all of them)."""
    case = model.cases[label] if label else model.null
    return label, min(n_flights, len(case.flights))


def _timed_draw(model: PowerModel, task: tuple[str | None, int, int, int, dict[str, Any], str, Any]
                ) -> tuple[PowerResult, Any, float, float]:
    """One :func:`draw_power` call of :func:`draw_powers` (its reference set first when given): the result,
    the shared reference of its case and flight count, and its wall and CPU time [s]."""
    label, n_flights, draws, seed, config, reference, ref = task
    key = _reference_key(model, label, n_flights)
    if ref is not None:
        model.references[key] = ref
    t0, c0 = time.perf_counter(), time.process_time()
    result = draw_power(model, label, n_flights, draws, seed, config, None, reference)
    return result, model.references.get(key), time.perf_counter() - t0, time.process_time() - c0


def _draw_task(task: tuple[str | None, int, int, int, dict[str, Any], str, Any]
               ) -> tuple[PowerResult, Any, float, float]:
    """Worker of :func:`draw_powers`: :func:`_timed_draw` on the worker process's model."""
    assert _WORKER_MODEL is not None, "draw_powers' worker started without its model"
    return _timed_draw(_WORKER_MODEL, task)


def power_pool(model: PowerModel, workers: int) -> Any:
    """A pool of ``workers`` processes holding ``model``, for several :func:`draw_powers` calls.

    Each process receives the model once, when it starts (:func:`~dronewind.plan.simulation.process_pool`);
    shut it down after use (``with power_pool(model, 2) as pool: ...``). The shared references
    made in it come back with the results and are passed to later calls by the caller's model.
    """
    return process_pool(workers, _set_worker_model, (model,))


def draw_powers(model: PowerModel, calls: Sequence[tuple[str | None, int, int, int]],
                config: Mapping[str, Any] | None = None, progress: Progress | None = None,
                reference: str = "shared", workers: int = 1, cpu_seconds: list[float] | None = None,
                pool: Any = None) -> list[PowerResult]:
    """Several :func:`draw_power` calls, spread over ``workers`` processes.

    Parameters
    ----------
    model : PowerModel
        From :func:`power_model`; the shared references the calls make are kept in
        ``model.references`` (a call whose reference is there already uses it).
    calls : sequence of (label, n_flights, draws, seed)
        The arguments of each call.
    config : mapping, optional
        Workflow configuration.
    progress : Progress, optional
        One item per call (``draws`` campaigns diagnosed).
    reference : {"shared", "per_draw"}
        As :func:`draw_power`.
    workers : int
        Processes; 1 runs every call in this process. The draws are seeded by their arguments
        and the references by their draws, so the results do not depend on ``workers``.
    cpu_seconds : list of float, optional
        Each call's CPU time [s] is appended to it (wherever it ran).
    pool : executor, optional
        A :func:`power_pool` of this model to run the calls on (left open); by default a pool of
        ``workers`` processes is started for these calls alone.

    Returns
    -------
    list of PowerResult
        In the order of ``calls``.
    """
    config = dict(config or {})
    tasks = [(label, int(n), int(draws), int(seed), config, reference,
              model.references.get(_reference_key(model, label, int(n)))) for label, n, draws, seed in calls]

    def record(label: str | None, n: int, result: PowerResult, ref: Any, seconds: float, cpu: float) -> PowerResult:
        if cpu_seconds is not None:
            cpu_seconds.append(cpu)
        if reference == "shared":  # kept also where there is none (too few flights or seeds), as draw_power keeps it
            model.references.setdefault(_reference_key(model, label, n), ref)
        if progress is not None:
            progress.add(f"{label or 'no error'}, {n} flights, {result.draws} draws", seconds)
        return result

    if pool is None and (workers <= 1 or len(tasks) <= 1):
        return [record(task[0], task[1], *_timed_draw(model, task)) for task in tasks]
    # the largest calls first (a reference costs about its flight count, the draws their number):
    # the last calls to finish are then short ones, and no worker idles while one runs alone
    order = sorted(range(len(tasks)), key=lambda i: (-tasks[i][1], -tasks[i][2], i))
    results: dict[int, PowerResult] = {}
    own = pool is None
    executor = power_pool(model, min(workers, len(tasks))) if own else pool
    try:
        for i, done in zip(order, executor.map(_draw_task, [tasks[i] for i in order]), strict=True):
            results[i] = record(tasks[i][0], tasks[i][1], *done)
    finally:
        if own:
            executor.shutdown()
    return [results[i] for i in range(len(tasks))]  # in the order of the calls


@dataclass
class DrawnCampaign:
    """One Monte-Carlo campaign of :func:`drawn_campaigns`.

    Attributes
    ----------
    evidence : dict
        ``name``, ``measured`` (the drawn features) and ``forward`` (the case's forward runs),
        as :func:`dronewind.diagnose.in_process.decide_evidence` reads it.
    y : numpy.ndarray
        The drawn features (n_flights, p) [feature units], flights in the diagnosis' order.
    truth : dronewind.diagnose.experiments.Draw
        The hidden error (``none`` for the null case), for the judge.
    campaign : dict
        The manifest of the drawn flights (the judge reads their processing lags).
    """

    evidence: dict[str, Any]
    truth: Any
    campaign: dict[str, Any]
    y: np.ndarray


def drawn_campaigns(model: PowerModel, label: str | None, n_flights: int, draws: int, seed: int
                    ) -> Iterator[DrawnCampaign]:
    """The measured campaigns drawn about a simulated case (module docstring, step 3).

    Parameters
    ----------
    model : PowerModel
        From :func:`power_model`.
    label : str or None
        Error label or None for the campaign without an error.
    n_flights : int
        Use the first ``n_flights`` flights.
    draws : int
        Number of campaigns.
    seed : int
        Seed of the draws (with ``n_flights`` and the label's length: the same arguments give
        the same campaigns).

    Yields
    ------
    DrawnCampaign
    """
    from dronewind.diagnose.experiments import Draw

    case = model.cases[label] if label else model.null
    flights = case.flights[:n_flights]
    idx = np.arange(len(flights))
    error = model.errors.get(label) if label else None
    truth = Draw(error.mechanism, dict(error.parameters), 0) if error else Draw("none", {}, 0)
    effect = model.effects[label][idx] if label else 0.0
    campaign = _first_flights(case.manifest, flights)
    rng = np.random.default_rng([int(seed), n_flights, len(label or "")])
    forward = {f: case.forward[f] for f in flights}
    for _ in range(draws):
        xi = rng.standard_normal((len(flights), case.chol.shape[0])) @ case.chol.T
        y = case.baseline[idx] + effect + model.noise_factor * case.sigma[idx] * xi
        yield DrawnCampaign({"name": "plan", "measured": _measured(case, y, flights), "forward": forward}, truth,
                            campaign, y)


def simulated_detection(data: Mapping[str, Any], error: Detect | None, seeds: Sequence[int],
                        config: Mapping[str, Any] | None = None, work_dir: str | Path | None = None,
                        progress: Progress | None = None) -> dict[str, Any]:
    """Full-simulation check: the planned campaign with ``error`` hidden, simulated and diagnosed per seed.

    Parameters
    ----------
    data : mapping
        Planned manifest (its ``simulation.seed`` and ``mechanisms`` are replaced).
    error : Detect or None
        The hidden error (None: nothing hidden).
    seeds : sequence of int
        Campaign seeds.
    config : mapping, optional
        Workflow configuration.
    work_dir : str or Path, optional
        Folder for the raw files (a temporary folder by default).
    progress : Progress, optional
        One item per campaign.

    Returns
    -------
    dict
        ``detected`` (count), ``n``, ``named`` (per seed), ``statistics`` (per seed, flight ->
        :func:`~dronewind.plan.simulation.hover_statistics`), ``evidence_seconds`` (CPU per campaign).
    """
    from dronewind.diagnose.experiments import Draw, judge
    from dronewind.diagnose.in_process import decide_evidence

    config = dict(config or {})
    truth = Draw(error.mechanism, dict(error.parameters), 0) if error else Draw("none", {}, 0)
    named, hits, cpu, stats = [], 0, [], []
    for s in seeds:
        manifest = with_error(data, error, s)
        t0 = time.process_time()
        with tempfile.TemporaryDirectory(dir=work_dir) as tmp:
            ctx = progress.item(f"seed {s} ({truth.label})") if progress else _null()
            with ctx:
                evidence = manifest_evidence(manifest, config, tmp)
                out = decide_evidence(evidence, config)
        cpu.append(time.process_time() - t0)
        stats.append(evidence["statistics"])
        verdict = judge(truth, out, manifest)
        hits += bool(verdict["detected"])
        named.append(list(verdict["named"]))
    return {"detected": hits, "n": len(seeds), "named": named, "statistics": stats, "evidence_seconds": cpu}
