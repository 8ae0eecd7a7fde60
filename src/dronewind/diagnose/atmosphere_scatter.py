"""Seed scatter of the measured-atmosphere forward model against the scatter of independent realisations.

The diagnosis takes the error of a residual feature (measured minus the mean of the forward
baseline seeds) from the seeds' scatter (:mod:`dronewind.diagnose.campaign`:
:math:`(1 + 1/K)` times the seed variance). That is right only if, across independent true
atmospheres of the same conditions, the residuals scatter as the seeds do. With
``diagnosis.atmosphere: measured`` the forward runs are built from the reference mast's
record (:func:`dronewind.simulate.payload_wind.measured_constraint`), so the seeds must also
resample what that record got wrong by chance, its spectral sampling error
(:func:`dronewind.simulate.constraint.spectral_sampling_factors`).

:func:`realisation_scatter` measures it with the project's own simulator: N virtual flights
of one campaign's conditions with different campaign seeds (the "true" atmospheres), each
processed as measured (:func:`dronewind.diagnose.in_process.process_virtual_flight`) and
forward-run with K baseline seeds of its own (:func:`dronewind.diagnose.probe_runs.probe_runs`,
on the conditions and record of :func:`dronewind.diagnose.in_process.forward_inputs`); per
feature, the ratio

.. math:: R = \\frac{(1 + 1/K)\\,\\overline{s^2_{seeds}}}{\\mathrm{var}_i(y_i - \\bar b_i)}

is 1 when the seed scatter is the residual's. For Gaussian features its sampling
distribution is Fisher's F with N(K - 1) and N - 1 degrees of freedom
(:func:`ratio_interval`).
"""

from __future__ import annotations

import copy
import tempfile
from collections.abc import Sequence
from contextlib import nullcontext
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["realisation_scatter", "ratio_interval", "scatter_ratios"]


def ratio_interval(n_realisations: int, n_seeds: int, level: float = 0.95) -> tuple[float, float]:
    """Central interval of the variance ratio R when the seed scatter is the realisation scatter.

    Parameters
    ----------
    n_realisations, n_seeds : int
        N and K of :func:`realisation_scatter`.
    level : float
        Probability inside the interval.

    Returns
    -------
    tuple of float
        Quantiles of Fisher's F with N(K - 1) and N - 1 degrees of freedom (the pooled seed
        variance over the variance of N residuals, Gaussian features).
    """
    from scipy import stats

    tail = 0.5 * (1.0 - level)
    lo, hi = stats.f.ppf([tail, 1.0 - tail], n_realisations * (n_seeds - 1), n_realisations - 1)
    return float(lo), float(hi)


def scatter_ratios(measured: np.ndarray, baseline: np.ndarray) -> dict[str, np.ndarray]:
    """Realisation and seed variances of residual features and their ratio R.

    Parameters
    ----------
    measured : numpy.ndarray
        (N, F) features of the N true realisations.
    baseline : numpy.ndarray
        (N, K, F) features of their K forward baseline seeds.

    Returns
    -------
    dict
        ``realisation_variance`` (F,) variance over realisations of measured minus the mean
        of its seeds; ``seed_variance`` (F,) mean over realisations of the seeds' variance;
        ``ratio`` (F,) R of the module docstring. NaN features are left out per realisation.
    """
    n_seeds = baseline.shape[1]
    resid = measured - np.nanmean(baseline, axis=1)
    a = np.nanvar(resid, axis=0, ddof=1)
    b = np.nanmean(np.nanvar(baseline, axis=1, ddof=1), axis=0)
    return {"realisation_variance": a, "seed_variance": b, "ratio": (1.0 + 1.0 / n_seeds) * b / a}


def realisation_scatter(n_realisations: int, n_seeds: int, features: Sequence[str], hover_min: float = 12.0,
                        speed_ms: float = 5.5, first_seed: int = 1000,
                        work_dir: str | Path | None = None) -> dict[str, Any]:
    """Features of independent true realisations of one flight and of their forward baseline seeds.

    Parameters
    ----------
    n_realisations : int
        N: campaign seeds ``first_seed`` .. ``first_seed + N - 1`` of a one-flight virtual
        campaign (:func:`dronewind.diagnose.experiments.campaign_manifest`, nothing hidden;
        the drone 35 m across the wind from the mast sonic, 10 m upwind).
    n_seeds : int
        K baseline seeds per realisation, its own for each (a seed's latent draws are the
        same for every flight of one id, so seeds shared by the realisations would make the
        seed variance of N realisations an estimate with K - 1 degrees of freedom).
    features : sequence of str
        Feature names (:data:`dronewind.diagnose.features.FEATURES`).
    hover_min : float
        Hover length [min].
    speed_ms : float
        Mean wind speed of the campaign [m s-1].
    first_seed : int
        Campaign seed of the first realisation.
    work_dir : str or Path, optional
        Folder for the virtual flights' raw files (a temporary one by default).

    Returns
    -------
    dict
        ``measured`` (N, F) and ``baseline`` (N, K, F) arrays, ``features``, ``seeds``
        (per realisation) and :func:`scatter_ratios`.
    """
    from dronewind.diagnose import experiments as ex
    from dronewind.diagnose import in_process, probe_runs, probes
    from dronewind.manifest import with_defaults

    processing = with_defaults({})["processing"]
    names = list(features)
    measured, baseline, seeds_used = [], [], []

    with (tempfile.TemporaryDirectory() if work_dir is None else nullcontext(str(work_dir))) as folder:
        for i in range(n_realisations):
            data = ex.campaign_manifest(ex.Draw("none", {}, first_seed + i), n_flights=1, hover_min=hover_min,
                                        speeds_ms=(speed_ms,))
            flight = data["payload_flights"][0]
            fid = flight["id"]
            v = in_process.process_virtual_flight(copy.deepcopy(data), flight, Path(folder) / f"r{i}", processing)
            found, conditions, record = in_process.forward_inputs(data, fid, v, processing)
            seeds = tuple(int(5000 + 37 * (first_seed + i) + k) for k in range(n_seeds))
            runs = probe_runs.probe_runs(data, fid, conditions, processing, seeds=seeds, parts=[probes.BASELINE_PART],
                                      atmosphere=record, lag_drift="lag_drift_s" in names, features=names)
            measured.append([_value(found["values"].get(f)) for f in names])
            baseline.append([[_value(run["values"].get(f)) for f in names] for run in runs["baseline"]])
            seeds_used.append(list(seeds))
    m, b = np.array(measured, float), np.array(baseline, float)
    return {"features": names, "measured": m, "baseline": b, "seeds": seeds_used, **scatter_ratios(m, b)}


def _value(x: object) -> float:
    return float("nan") if x is None else float(x)  # type: ignore[arg-type]
