r"""The planned campaign simulated, processed and forward-run in this process (the power's step 1).

:mod:`dronewind.plan.power` draws measured campaigns about the campaigns simulated here: the
planned one without an error and with each error to detect hidden in its simulation
(:func:`with_error`, at one campaign seed). Every flight goes through the steps of
:func:`dronewind.diagnose.in_process.campaign_evidence`: simulated and processed to L3
(:func:`processed_flight`), then forward-run conditioned on what its chain measured
(:func:`flight_forward_runs`). Flights of two campaigns whose forward inputs are the same
(:func:`forward_inputs_key`) share their runs (:func:`campaign_evidences`).
"""

from __future__ import annotations

import copy
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dronewind.core.progress import Progress
from dronewind.manifest import with_defaults
from dronewind.plan.spec import Detect

__all__ = ["with_error", "manifest_evidence", "flight_evidence", "processed_flight", "flight_forward_runs",
           "forward_inputs_key", "campaign_evidences", "hover_statistics", "process_pool"]


def with_error(data: Mapping[str, Any], error: Detect | None, seed: int | None = None) -> dict[str, Any]:
    """A virtual campaign manifest with ``error`` hidden in its simulation (and ``seed`` as its campaign seed).

    Parameters
    ----------
    data : mapping
        Virtual campaign manifest (:func:`dronewind.plan.manifest.plan_manifest`).
    error : Detect or None
        The error hidden in every flight (None: nothing hidden).
    seed : int, optional
        Campaign seed (``simulation.seed``); the manifest's own by default.

    Returns
    -------
    dict
        A copy of ``data`` with ``simulation.mechanisms`` (and ``simulation.seed``) replaced.
    """
    manifest = copy.deepcopy(dict(data))
    if seed is not None:
        manifest["simulation"]["seed"] = int(seed)
    manifest["simulation"]["mechanisms"] = ([{"mechanism": error.mechanism, "parameters": dict(error.parameters)}]
                                            if error else [])
    return manifest


def manifest_evidence(data: Mapping[str, Any], config: Mapping[str, Any], work_dir: str | Path,
                      progress: Progress | None = None) -> dict[str, Any]:
    """Simulate, process and forward-run every flight of a virtual campaign manifest, in this process.

    The steps of :func:`dronewind.diagnose.in_process.campaign_evidence` for any manifest
    (its reference sonic first; only that sonic is simulated).

    Parameters
    ----------
    data : mapping
        Virtual campaign manifest (:func:`dronewind.plan.manifest.plan_manifest`, an error
        possibly hidden by :func:`with_error`).
    config : mapping
        Workflow configuration (defaults where missing).
    work_dir : str or Path
        Folder for the raw files.
    progress : Progress, optional
        Counter of flights (one item per flight).

    Returns
    -------
    dict
        ``name``, ``measured`` and ``forward`` as :func:`~dronewind.diagnose.in_process.campaign_evidence`,
        and ``statistics``: flight -> :func:`hover_statistics`.
    """
    return campaign_evidences({"campaign": data}, config, work_dir, progress)["campaign"]


def _simulated_view(data: Mapping[str, Any]) -> dict[str, Any]:
    """The manifest as the power simulation runs it: only the reference sonic (the first) of the mast.

    :func:`~dronewind.diagnose.in_process.process_virtual_flight` reads every simulated mast
    file as the reference's record; the other heights do not enter the diagnosis.
    """
    view: dict[str, Any] = copy.deepcopy(dict(data))
    view["masts"] = [{**view["masts"][0], "sonics": view["masts"][0]["sonics"][:1]}]
    return view


def flight_evidence(view: Mapping[str, Any], flight_id: str, config: Mapping[str, Any], work_dir: str | Path
                    ) -> dict[str, Any]:
    """One flight of a virtual campaign simulated, processed and forward-run (its measured features and runs).

    Parameters
    ----------
    view : mapping
        Virtual campaign manifest with only the reference sonic (:func:`manifest_evidence`).
    flight_id : str
        Payload flight id.
    config : mapping
        Workflow configuration (defaults where missing).
    work_dir : str or Path
        Folder for the flight's raw files.

    Returns
    -------
    dict
        ``measured`` (features), ``forward`` (:func:`dronewind.diagnose.probe_runs.probe_runs`)
        and ``statistics`` (:func:`hover_statistics`) of the flight.
    """
    flight = processed_flight(view, flight_id, config, work_dir)
    runs = flight_forward_runs(view, flight_id, config, flight["conditions"], flight["record"])
    return {"measured": flight["measured"], "forward": runs, "statistics": flight["statistics"]}


def processed_flight(view: Mapping[str, Any], flight_id: str, config: Mapping[str, Any], work_dir: str | Path
                     ) -> dict[str, Any]:
    """One flight of a virtual campaign simulated and processed: what its forward runs are conditioned on.

    Parameters
    ----------
    view, flight_id, config, work_dir
        As :func:`flight_evidence`.

    Returns
    -------
    dict
        ``measured`` (features), ``statistics`` (:func:`hover_statistics`), ``conditions``
        (:func:`dronewind.diagnose.forward_conditions.forward_conditions`) and ``record`` (the
        measured atmosphere, :func:`dronewind.diagnose.forward_atmosphere.atmosphere_record`, or
        None for ``diagnosis.atmosphere: model``).
    """
    from dronewind.diagnose.in_process import forward_inputs, process_virtual_flight

    settings = with_defaults(dict(config))
    processing = settings["processing"]
    flight = next(f for f in view["payload_flights"] if f["id"] == flight_id)
    work = Path(work_dir)
    work.mkdir(parents=True, exist_ok=True)
    v = process_virtual_flight(view, flight, work, processing)
    measured, conditions, record = forward_inputs(view, flight_id, v, processing, settings["diagnosis"]["atmosphere"],
                                                  settings["diagnosis"]["forward_payload"])
    return {"measured": measured, "statistics": hover_statistics(v.l3), "conditions": conditions, "record": record}


def flight_forward_runs(view: Mapping[str, Any], flight_id: str, config: Mapping[str, Any],
                        conditions: Mapping[str, Any], record: Any) -> dict[str, Any]:
    """The forward runs of one processed flight (:func:`dronewind.diagnose.probe_runs.probe_runs`).

    Parameters
    ----------
    view, flight_id, config
        As :func:`flight_evidence`.
    conditions, record
        The flight's ``conditions`` and ``record`` (:func:`processed_flight`).

    Returns
    -------
    dict
        The baseline seeds' and the probes' runs.
    """
    from dronewind.diagnose import probe_runs
    from dronewind.diagnose.probes import resolved_seeds

    settings = with_defaults(dict(config))
    seeds = tuple(resolved_seeds(settings["diagnosis"]["seeds"], len(view["payload_flights"])))
    return probe_runs.probe_runs(view, flight_id, conditions, settings["processing"], seeds=seeds, atmosphere=record)


def forward_inputs_key(view: Mapping[str, Any], flight_id: str, conditions: Mapping[str, Any], record: Any) -> str:
    """A digest of everything a flight's forward runs depend on besides the configuration.

    The forward runs read the manifest without its ``simulation:`` section (the hidden error is
    not known to them, :func:`dronewind.diagnose.forward_conditions.forward_manifest`), the
    flight's conditions and the measured atmosphere record; two flights with the same digest
    have the same runs.

    Returns
    -------
    str
        SHA-256 hex digest.
    """
    from dronewind.core.cf import config_hash
    from dronewind.core.raw import content_digest

    # the record's attributes (its noise levels) enter the runs beside its values
    atmosphere = "" if record is None else content_digest(
        {str(name): record[name].values for name in record.variables}, prefix=config_hash(dict(record.attrs)))
    return config_hash({"manifest": {k: v for k, v in view.items() if k != "simulation"}, "flight": flight_id,
                        "conditions": dict(conditions), "atmosphere": atmosphere})


def _processed_task(task: tuple[str, dict[str, Any], str, dict[str, Any], str]
                    ) -> tuple[str, str, dict[str, Any], float, float]:
    """Worker of :func:`campaign_evidences`: one flight processed, its wall time and its CPU time [s]."""
    key, view, flight_id, config, work_dir = task
    t0, c0 = time.perf_counter(), time.process_time()
    out = processed_flight(view, flight_id, config, work_dir)
    return key, flight_id, out, time.perf_counter() - t0, time.process_time() - c0


def _forward_task(task: tuple[str, dict[str, Any], str, dict[str, Any], dict[str, Any], Any]
                  ) -> tuple[str, dict[str, Any], float, float]:
    """Worker of :func:`campaign_evidences`: one flight's forward runs, their wall time and CPU time [s]."""
    digest, view, flight_id, config, conditions, record = task
    t0, c0 = time.perf_counter(), time.process_time()
    out = flight_forward_runs(view, flight_id, config, conditions, record)
    return digest, out, time.perf_counter() - t0, time.process_time() - c0


def process_pool(workers: int, initializer: Any = None, initargs: tuple[Any, ...] = ()) -> Any:
    """A process pool of ``workers`` (forkserver where the platform has it: no state copied from this process)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
    return ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=initializer, initargs=initargs)


def campaign_evidences(manifests: Mapping[str, Mapping[str, Any]], config: Mapping[str, Any], work_dir: str | Path,
                       progress: Progress | None = None, workers: int = 1, cpu_seconds: list[float] | None = None,
                       flights: Sequence[str] | None = None) -> dict[str, dict[str, Any]]:
    """:func:`manifest_evidence` of several campaigns, their flights spread over ``workers`` processes.

    Every flight is simulated and processed on its own (seeded by the manifest); then the
    forward runs are made once for each distinct input (:func:`forward_inputs_key`): flights
    of two campaigns whose chain measured the same conditions over the same mast record (an
    error that moves neither, such as a w gain of the payload sonic on most flights) share
    their runs, which are the same runs either way. The result does not depend on ``workers``
    or on the order in which flights finish.

    Parameters
    ----------
    manifests : mapping
        Key -> virtual campaign manifest.
    config : mapping
        Workflow configuration (defaults where missing).
    work_dir : str or Path
        Folder for the raw files (one sub-folder per key and flight).
    progress : Progress, optional
        Counter of flights (one item per flight).
    workers : int
        Processes; 1 runs every flight in this process.
    cpu_seconds : list of float, optional
        The CPU time [s] of every task (a flight processed, a flight's forward runs) is
        appended to it (wherever it ran).
    flights : sequence of str, optional
        Only these payload flights of every campaign (all by default). A flight's evidence does
        not depend on which others are simulated with it: the campaign stays whole (its flight
        count sets the baseline seeds, :func:`flight_forward_runs`), so evidences of
        successive calls with the same ``work_dir`` add up to that of one call.

    Returns
    -------
    dict
        Key -> ``name``, ``measured``, ``forward`` and ``statistics`` (:func:`manifest_evidence`)
        of the flights simulated.
    """
    config = dict(config)
    views = {key: _simulated_view(data) for key, data in manifests.items()}
    wanted = None if flights is None else set(flights)
    tasks = [(key, view, f["id"], config, str(Path(work_dir) / str(i) / f["id"]))
             for i, (key, view) in enumerate(views.items()) for f in view["payload_flights"]
             if wanted is None or f["id"] in wanted]
    processed: dict[tuple[str, str], dict[str, Any]] = {}
    seconds: dict[tuple[str, str], float] = {}
    sharing: dict[str, list[tuple[str, str]]] = {}  # digest of the forward inputs -> the flights with it
    runs: dict[str, dict[str, Any]] = {}
    pool = process_pool(min(workers, len(tasks))) if workers > 1 and len(tasks) > 1 else None
    mapped = pool.map if pool is not None else map
    try:
        # first every flight simulated and processed; then the forward runs once per distinct input
        # (an error the chain's conditions and the mast record do not see leaves them as without it)
        for key, fid, out, wall, cpu in mapped(_processed_task, tasks):
            processed[(key, fid)], seconds[(key, fid)] = out, wall
            if cpu_seconds is not None:
                cpu_seconds.append(cpu)
        for key, view, fid, *_ in tasks:
            p = processed[(key, fid)]
            sharing.setdefault(forward_inputs_key(view, fid, p["conditions"], p["record"]), []).append((key, fid))
        forward_tasks = [(digest, views[key], fid, config, processed[(key, fid)]["conditions"],
                          processed[(key, fid)]["record"]) for digest, [(key, fid), *_] in sharing.items()]
        for digest, out, wall, cpu in mapped(_forward_task, forward_tasks):
            runs[digest] = out
            if cpu_seconds is not None:
                cpu_seconds.append(cpu)
            members = sharing[digest]
            for key, fid in members:
                if progress is not None:
                    progress.add(f"{key} flight {fid} simulated, processed and forward-run"
                                 + (f" (runs shared by {len(members)} campaigns)" if len(members) > 1 else ""),
                                 seconds[(key, fid)] + wall / len(members))
    finally:
        if pool is not None:
            pool.shutdown()
    done = {member: {"measured": processed[member]["measured"], "statistics": processed[member]["statistics"],
                     "forward": runs[digest]} for digest, members in sharing.items() for member in members}
    result = {}
    for key, view in views.items():
        fids = [f["id"] for f in view["payload_flights"] if wanted is None or f["id"] in wanted]
        result[key] = {"name": view["name"], "measured": {f: done[(key, f)]["measured"] for f in fids},
                       "forward": {f: done[(key, f)]["forward"] for f in fids},
                       "statistics": {f: done[(key, f)]["statistics"] for f in fids}}
    return result


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
