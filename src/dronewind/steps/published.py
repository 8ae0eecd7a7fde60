"""The paper's published numbers as data, from files to files (see :mod:`dronewind.diagnose.published`).

1. :func:`published_forward` (per stationary sample): forward-model baseline and probe
   runs at the Table 4 conditions.
2. :func:`published_diagnosis`: fit every mechanism to Table 5 and the claims; JSON.
3. :func:`published_rerun` (per sample; :func:`published_reruns` runs every sample in one job):
   baseline and extended model rerun with fresh seeds; Table 5-like statistics.
4. :func:`published_report`: Markdown report and the before/after figure.

The per-sample steps take the one-flight view of the manifest (with the flight's
``simulation`` atmosphere settings, which :func:`dronewind.diagnose.published.table4_conditions`
uses) and the ``processing`` and ``diagnosis`` settings of their rule as arguments.
"""

from __future__ import annotations

import gc
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from dronewind.core.cf import atomic_write_text
from dronewind.steps.common import LOG
from dronewind.steps.diagnosis import write_json

__all__ = ["published_forward", "published_diagnosis", "published_rerun", "published_reruns", "published_report"]


def published_forward(published_file: str | Path, output: str | Path, *, campaign: Mapping[str, Any],
                      flight_id: str, processing: Mapping[str, Any], seeds: Sequence[int],
                      part: str | None = None) -> Path:
    """Forward-model runs (baseline seeds and every probe) of one sample at its Table 4 conditions.

    Parameters
    ----------
    published_file : str or Path
        Published-results file.
    output : str or Path
        JSON file to write.
    campaign : mapping
        One-flight view of the manifest that reconstructs the experiment.
    flight_id : str
        Sample (payload flight) id.
    processing : mapping
        ``processing`` settings of the chain (:data:`dronewind.diagnose.probes.CHAIN_SETTINGS`).
    seeds : sequence of int
        ``diagnosis.seeds``.
    part : str, optional
        Only this part (``"baseline"`` or a mechanism,
        :func:`dronewind.diagnose.probes.probe_parts`); all by default.

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.diagnose import probe_runs
    from dronewind.diagnose import published as dp

    pub = dp.load_published(published_file)
    conditions = dp.table4_conditions(pub, flight_id, campaign)
    LOG.info("sample %s: Table 4 conditions %s", flight_id, conditions)
    # the published numbers hold no lag (the lag drift of the hover's halves is not computed)
    # and only the features of dp.OBSERVED_FEATURES
    runs = probe_runs.probe_runs(campaign, flight_id, conditions, processing, seeds=tuple(seeds),
                              parts=None if part is None else [part], lag_drift=False,
                              features=dp.OBSERVED_FEATURES)
    return write_json(output, runs)


def published_diagnosis(published_file: str | Path, forward_files: Sequence[str | Path], output: str | Path, *,
                        alpha: float, max_causes: int) -> Path:
    """Fit and score every mechanism against the published numbers; write JSON.

    ``alpha`` and ``max_causes`` are the ``diagnosis`` settings; at most 2 causes are named
    from the published numbers.
    """
    from dronewind.diagnose import published as dp

    pub = dp.load_published(published_file)
    forward = {}
    for path in forward_files:
        run = json.loads(Path(path).read_text())
        forward[run["flight"]] = run
    result = dp.analyse(pub, forward, alpha=float(alpha), max_causes=int(min(max_causes, 2)))
    LOG.info("published numbers: named %s, baseline chi2 %.1f", result["named_causes"], result["baseline"]["chi2"])
    return write_json(output, result)


def published_rerun(published_file: str | Path, diagnosis_json: str | Path, output: str | Path, *,
                    campaign: Mapping[str, Any], flight_id: str, processing: Mapping[str, Any],
                    seeds: Sequence[int]) -> Path:
    """Baseline and extended model of one sample at Table 4 conditions (common random numbers per seed).

    ``campaign`` is the one-flight view of the manifest, ``processing`` the chain settings
    (as for :func:`published_forward`); ``seeds`` are fresh seeds, not ``diagnosis.seeds``
    (:func:`dronewind.diagnose.probes.fresh_seeds`, as the workflow passes them).
    """
    from dronewind.diagnose import forward, forward_conditions, probe_runs
    from dronewind.diagnose import published as dp

    pub = dp.load_published(published_file)
    diag = json.loads(Path(diagnosis_json).read_text())
    conditions = dp.table4_conditions(pub, flight_id, campaign)
    out: dict[str, Any] = {"flight": flight_id, "seeds": list(seeds), "mechanisms": diag["extended_mechanisms"],
                           "baseline": [], "extended": []}
    # the extended run of a seed takes the baseline run's true state and products where its
    # mechanisms act on the measurement only (probe_runs.shares_truth): the same numbers as its
    # own, without simulating the field and the motion again
    share = probe_runs.shares_truth(diag["extended_mechanisms"], measured=False)
    for seed in seeds:
        truth, cache = None, forward.ForwardCache()
        for model, mechanisms in (("baseline", []), ("extended", diag["extended_mechanisms"])):
            feats, products = forward.run_forward(
                forward_conditions.forward_manifest(campaign, flight_id, conditions, mechanisms, seed), flight_id,
                processing,
                truth=truth, cache=cache if share else None, lag_drift=False, features=dp.SUMMARY_FEATURES,
                errors=False)
            out[model].append(dp.flight_summary(products["l3"], feats.values))
            if share:
                truth = products["truth"]
                cache.freeze()
            del products  # not read again: freed before the next run (one run's datasets at a time)
        LOG.info("sample %s: seed %d rerun done", flight_id, seed)
    return write_json(output, out)


def published_reruns(published_file: str | Path, diagnosis_json: str | Path, outputs: Mapping[str, str | Path], *,
                     campaigns: Mapping[str, Mapping[str, Any]], processing: Mapping[str, Any],
                     seeds: Sequence[int]) -> list[Path]:
    """:func:`published_rerun` for several samples in one job (the workflow's ``published_diagnosis``, after the fit).

    A sample's rerun is a few forward runs (about 0.5 CPU-s) where a job starts in about 1 CPU-s,
    and every sample's rerun reads the one published-numbers diagnosis, so that a change of it
    reruns them all: the samples share one job.

    Parameters
    ----------
    published_file, diagnosis_json, processing, seeds
        As for :func:`published_rerun`.
    outputs : mapping
        Sample id -> the JSON file of its rerun, in the order they are run.
    campaigns : mapping
        Sample id -> its one-flight view of the manifest.

    Returns
    -------
    list of Path
        The written files, in the order of ``outputs``.
    """
    written = []
    for flight_id, output in outputs.items():
        written.append(published_rerun(published_file, diagnosis_json, output, campaign=campaigns[flight_id],
                                       flight_id=flight_id, processing=processing, seeds=seeds))
        gc.collect()  # the sample's datasets, held in reference cycles (extended_runs): one sample's peak
    return written


def published_report(published_file: str | Path, diagnosis_json: str | Path, rerun_files: Sequence[str | Path],
                     output_md: str | Path, output_json: str | Path, figure_png: str | Path,
                     figure_pdf: str | Path) -> list[Path]:
    """Markdown report, before/after numbers (JSON) and the figure of the published-numbers diagnosis."""
    from dronewind.diagnose import published as dp
    from dronewind.diagnose import published_markdown

    pub = dp.load_published(published_file)
    diag = json.loads(Path(diagnosis_json).read_text())
    reruns = {}
    for path in rerun_files:
        r = json.loads(Path(path).read_text())
        reruns[r["flight"]] = r
    summary = dp.rerun_summary(reruns, pub)
    write_json(output_json, summary)
    atomic_write_text(output_md, published_markdown.markdown(diag, summary, pub))
    _figure(summary, pub, Path(figure_png), Path(figure_pdf))
    return [Path(output_md), Path(output_json), Path(figure_png), Path(figure_pdf)]


def _figure(summary: Mapping[str, Any], pub: Mapping[str, Any], png: Path, pdf: Path) -> None:
    from dronewind.figures.published import published_before_after_figure

    published_before_after_figure(summary, pub, png, pdf)
