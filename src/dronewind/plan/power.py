r"""Detection power of a planned campaign: the diagnosis' own response and error model, sampled.

Main path (:func:`campaign_power`), per plan:

1. The planned campaign without any error is simulated, processed and forward-run in this
   process (:func:`manifest_evidence`: the in-process path of
   :mod:`dronewind.diagnose.experiments`, :func:`~dronewind.diagnose.experiments.process_virtual_flight`
   and :func:`dronewind.diagnose.probe_runs.probe_runs`, for a given manifest). This gives, per
   flight, the forward model's baseline seeds and probes (the diagnosis' linearised
   response) and, through :func:`dronewind.diagnose.campaign.assemble`, its error model: the
   residual errors :math:`\sigma_{i,f}` and the shrunk feature correlation :math:`R^*`.
2. Each error to detect is run once more per flight through the forward model at its planned
   size (a probe at that level, common random numbers with the first baseline seed): its
   effect :math:`\Delta_{i,f}` on every feature.
3. Monte Carlo: a measured campaign is drawn as
   :math:`y_i = \bar b_i + \Delta_i + c\,D_i L \xi_i` (:math:`\xi` standard normal,
   :math:`L L^\top = R^*`, :math:`D_i = \mathrm{diag}(\sigma_{i,f})`) and diagnosed by
   :func:`dronewind.diagnose.campaign.diagnose` (the same tests, alpha, gain filter), and
   judged by :func:`dronewind.diagnose.experiments.judge`. The factor :math:`c` is the root
   mean square of the simulated null campaign's own standardised residuals
   :math:`(y - \bar b)/\sigma` over flights and features: the diagnosis' errors are wider
   than the realisation scatter by design (:mod:`dronewind.diagnose.campaign`, "the whitened
   baseline misfit per degree of freedom is 0.46"), and drawing with them would understate
   the power.
4. The power is the share of draws in which the error is named (or an ambiguity-equivalent
   cause is), with its 95 % Wilson interval (Wilson 1927) for the number of draws; the
   false-alarm rate from the same draws without the error.

Why not full simulations as the main path: one 6-flight campaign costs about 20 CPU-s to
simulate, process and forward-run, so 100 draws per error would take over half an hour; a
diagnosis of drawn features costs about 0.1 s. The full simulation is the check
(:func:`simulated_detection`, ``benchmarks/plan_validation.py``).
"""

from __future__ import annotations

import copy
import math
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dronewind.core.progress import Progress
from dronewind.manifest import with_defaults
from dronewind.plan.spec import Detect

__all__ = ["manifest_evidence", "PowerModel", "power_model", "draw_power", "PowerResult", "simulated_detection",
           "probe_for", "hover_statistics"]


def probe_for(error: Detect) -> Any:
    """The forward model's probe of ``error`` at its planned size (first parameter off its baseline level)."""
    from dronewind.diagnose.probes import Probe, baseline_level

    moved = [k for k, v in error.parameters.items() if not np.isclose(v, baseline_level(error.mechanism, k))]
    par = moved[0] if moved else next(iter(error.parameters))
    fixed = tuple((k, float(v)) for k, v in error.parameters.items() if k != par)
    return Probe(f"{error.mechanism}@plan", error.mechanism, par, (float(error.parameters[par]),), fixed)


def manifest_evidence(data: Mapping[str, Any], config: Mapping[str, Any], work_dir: str | Path,
                      errors: Sequence[Detect] = (), progress: Progress | None = None) -> dict[str, Any]:
    """Simulate, process and forward-run every flight of a virtual campaign manifest, in this process.

    The steps of :func:`dronewind.diagnose.experiments.campaign_evidence` for any manifest
    (its reference sonic first; only that sonic is simulated), plus one forward run per flight
    and error at the error's size.

    Parameters
    ----------
    data : mapping
        Virtual campaign manifest (:func:`dronewind.plan.manifest.plan_manifest`).
    config : mapping
        Workflow configuration (defaults where missing).
    work_dir : str or Path
        Folder for the raw files.
    errors : sequence of Detect
        Errors whose effect is run.
    progress : Progress, optional
        Counter of flights (one item per flight).

    Returns
    -------
    dict
        ``name``, ``measured`` and ``forward`` as :func:`~dronewind.diagnose.experiments.campaign_evidence`,
        and ``effects``: error label -> flight -> features (values) of the error's run.
    """
    from dronewind.diagnose import forward, forward_atmosphere, forward_conditions, probe_runs, probes
    from dronewind.diagnose.experiments import process_virtual_flight
    from dronewind.diagnose.features import features_to_dict
    from dronewind.diagnose.probes import resolved_seeds

    settings = with_defaults(config)
    processing, diagnosis = settings["processing"], settings["diagnosis"]
    # process_virtual_flight reads every simulated mast file as the reference's record: keep
    # only the reference sonic (the first) in the simulated view; the other heights do not
    # enter the diagnosis
    view: dict[str, Any] = copy.deepcopy(dict(data))
    view["masts"] = [{**view["masts"][0], "sonics": view["masts"][0]["sonics"][:1]}]
    seeds = tuple(resolved_seeds(diagnosis["seeds"], len(view["payload_flights"])))
    lag = {key: processing[key] for key in probes.LAG_SETTINGS}
    measured: dict[str, Any] = {}
    fwd: dict[str, Any] = {}
    effects: dict[str, dict[str, Any]] = {e.label: {} for e in errors}
    stats: dict[str, dict[str, float]] = {}
    for flight in view["payload_flights"]:
        fid = flight["id"]
        work = Path(work_dir) / fid
        work.mkdir(parents=True, exist_ok=True)
        ctx = progress.item(f"flight {fid} simulated, processed and forward-run") if progress else _null()
        with ctx:
            v = process_virtual_flight(view, flight, work, processing)
            stats[fid] = hover_statistics(v.l3)
            measured[fid] = features_to_dict(forward.measured_features(view, fid, v.sonic_l1, v.ins_l1, v.l2, v.l3,
                                                                       **lag))
            conditions = forward_conditions.forward_conditions(view, fid, v.l3, v.l2)
            from_mast = diagnosis["atmosphere"] == "measured"
            record = forward_atmosphere.atmosphere_record(v.mast_l1, conditions) if from_mast else None
            fwd[fid] = probe_runs.probe_runs(view, fid, conditions, processing, seeds=seeds, atmosphere=record)
            for e in errors:
                probe = probe_for(e)
                run = probe_runs.probe_runs(view, fid, conditions, processing, seeds=seeds, probes=(probe,),
                                         parts=[e.mechanism], atmosphere=record)
                effects[e.label][fid] = run["probes"][0]["features"]["values"] if run["probes"] else None
    return {"name": view["name"], "measured": measured, "forward": fwd, "effects": effects, "statistics": stats}


def hover_statistics(l3: Any) -> dict[str, float]:
    r"""The drone's hover statistics in an L3: sigma_u, sigma_w, u*, w'theta' and the duration.

    Parameters
    ----------
    l3 : xarray.Dataset
        L3 of a flight (streamline coordinates, :mod:`dronewind.compare.align`).

    Returns
    -------
    dict
        ``sigma_u`` [m s-1], ``sigma_w`` [m s-1], ``u_star`` [m s-1] (:math:`(\overline{u'w'}^2 +
        \overline{v'w'}^2)^{1/4}`), ``w_theta`` [K m s-1] (linear detrending, Ghirardelli et al.
        2025, Sect. 4.1) and ``duration_s`` [s].
    """
    from dronewind.core.uncertainty import product_series

    d = l3.sel(sensor="drone")
    u, v, w, t = (np.asarray(d[k].values, dtype=float) for k in ("u_ms", "v_ms", "w_ms", "theta_v_k"))
    ok = np.isfinite(u) & np.isfinite(v) & np.isfinite(w) & np.isfinite(t)
    u, v, w, t = u[ok], v[ok], w[ok], t[ok]
    uw, vw = float(np.mean(product_series(u, w))), float(np.mean(product_series(v, w)))
    times = l3["time"].values
    return {"sigma_u": float(np.sqrt(np.mean(product_series(u)))),
            "sigma_w": float(np.sqrt(np.mean(product_series(w)))),
            "u_star": float((uw**2 + vw**2) ** 0.25), "w_theta": float(np.mean(product_series(w, t))),
            "duration_s": float((times[-1] - times[0]) / np.timedelta64(1, "ns") * 1e-9)}


class _null:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> None:
        return None


@dataclass
class PowerModel:
    """The diagnosis' linearised response and error model of one simulated null campaign."""

    flights: list[str]
    measured: dict[str, Any]
    forward: dict[str, Any]
    baseline: np.ndarray
    sigma: np.ndarray
    chol: np.ndarray
    noise_factor: float
    effects: dict[str, np.ndarray] = field(default_factory=dict)
    errors: dict[str, Detect] = field(default_factory=dict)


def power_model(evidence: Mapping[str, Any], errors: Sequence[Detect] = ()) -> PowerModel:
    """Error model and effects from :func:`manifest_evidence`'s output (module docstring, steps 1-2).

    Parameters
    ----------
    evidence : mapping
        Output of :func:`manifest_evidence` for the campaign without errors.
    errors : sequence of Detect
        The errors whose ``effects`` the evidence holds.

    Returns
    -------
    PowerModel
    """
    from dronewind.diagnose import campaign as dc
    from dronewind.diagnose.features import FEATURES

    ev = dc.assemble(evidence["measured"], evidence["forward"])
    n_f = len(FEATURES)
    corr = ev.corr if ev.corr is not None else np.eye(n_f)
    corr = np.where(np.isfinite(corr), corr, 0.0)
    np.fill_diagonal(corr, 1.0)
    chol = np.linalg.cholesky(corr + 1e-9 * np.eye(n_f))
    resid = (ev.y - ev.baseline) / ev.sigma
    factor = float(np.sqrt(np.nanmean(resid**2))) if np.isfinite(resid).any() else 1.0
    model = PowerModel(ev.flights, dict(evidence["measured"]), dict(evidence["forward"]), ev.baseline, ev.sigma,
                       chol, factor)
    for e in errors:
        rows = []
        for i, fid in enumerate(ev.flights):
            values = (evidence.get("effects") or {}).get(e.label, {}).get(fid)
            run = np.array([np.nan if values is None or values.get(f) is None else float(values[f]) for f in FEATURES])
            rows.append(run - ev.baseline_seed0[i])
        model.effects[e.label] = np.where(np.isfinite(np.array(rows)), np.array(rows), 0.0)
        model.errors[e.label] = e
    return model


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


def _measured(model: PowerModel, y: np.ndarray, flights: Sequence[str]) -> dict[str, Any]:
    from dronewind.diagnose.features import FEATURES

    out = {}
    for i, fid in enumerate(flights):
        m = copy.copy(model.measured[fid])
        original = m["values"]
        m["values"] = {f: (None if original.get(f) is None or not math.isfinite(y[i, k]) else float(y[i, k]))
                       for k, f in enumerate(FEATURES)}
        out[fid] = m
    return out


def draw_power(model: PowerModel, label: str | None, n_flights: int, draws: int, seed: int,
               config: Mapping[str, Any] | None = None, progress: Progress | None = None) -> PowerResult:
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
        Workflow configuration (its ``diagnosis`` settings).
    progress : Progress, optional
        One item per draw.

    Returns
    -------
    PowerResult
        For ``label=None``, ``detected`` counts the draws naming nothing (1 - false-alarm rate).
    """
    from dronewind.diagnose import campaign as dc
    from dronewind.diagnose.experiments import Draw, judge

    diagnosis = with_defaults(config or {})["diagnosis"]
    flights = model.flights[:n_flights]
    idx = np.arange(len(flights))
    error = model.errors.get(label) if label else None
    truth = Draw(error.mechanism, dict(error.parameters), 0) if error else Draw("none", {}, 0)
    effect = model.effects[label][idx] if label else 0.0
    rng = np.random.default_rng([int(seed), n_flights, len(label or "")])
    forward = {f: model.forward[f] for f in flights}
    hits = 0
    reference = None  # the draws share the forward runs: one bootstrap reference serves them all
    for k in range(draws):
        ctx = progress.item(f"{label or 'no error'}, {n_flights} flights, draw {k + 1}") if progress else _null()
        with ctx:
            xi = rng.standard_normal((len(flights), model.chol.shape[0])) @ model.chol.T
            y = model.baseline[idx] + effect + model.noise_factor * model.sigma[idx] * xi
            ev = dc.assemble(_measured(model, y, flights), forward)
            result = dc.diagnose(ev, alpha=float(diagnosis["alpha"]), max_causes=int(diagnosis["max_causes"]),
                                 min_gain=float(diagnosis["min_gain"]), n_replicates=int(diagnosis["bootstrap"]),
                                 reference=reference)
            reference = result.reference
            out = dc.to_json(result, "plan")
            out["atmosphere"] = str(diagnosis["atmosphere"])
            hits += bool(judge(truth, out)["detected"])
    return PowerResult(label or "none", n_flights, hits, draws)


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
        :func:`hover_statistics`), ``evidence_seconds`` (CPU per campaign).
    """
    import time

    from dronewind.diagnose.experiments import Draw, diagnose_evidence, judge

    config = dict(config or {})
    truth = Draw(error.mechanism, dict(error.parameters), 0) if error else Draw("none", {}, 0)
    named, hits, cpu, stats = [], 0, [], []
    for s in seeds:
        manifest = copy.deepcopy(dict(data))
        manifest["simulation"]["seed"] = int(s)
        manifest["simulation"]["mechanisms"] = ([{"mechanism": error.mechanism, "parameters": dict(error.parameters)}]
                                                if error else [])
        t0 = time.process_time()
        with tempfile.TemporaryDirectory(dir=work_dir) as tmp:
            ctx = progress.item(f"seed {s} ({truth.label})") if progress else _null()
            with ctx:
                evidence = manifest_evidence(manifest, config, tmp)
                out = diagnose_evidence(evidence, config)
        cpu.append(time.process_time() - t0)
        stats.append(evidence["statistics"])
        verdict = judge(truth, out)
        hits += bool(verdict["detected"])
        named.append(list(verdict["named"]))
    return {"detected": hits, "n": len(seeds), "named": named, "statistics": stats, "evidence_seconds": cpu}
