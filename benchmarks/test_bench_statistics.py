"""The campaign diagnosis' statistics: the parametric bootstrap over seeds (the cost of a diagnosis)."""

from __future__ import annotations

import numpy as np

from conftest import cpu_round

#: The default campaign's shape: ten flights, the diagnosis' features, 41 baseline seeds per flight
#: and twelve candidates (nine of one parameter, three of three), with four or five probe levels each.
N_FLIGHTS, N_SEEDS, REPLICATES = 10, 41, 100


def _models(rng, baseline):
    from dronewind.diagnose.fitting import ParameterResponse, ResponseModel

    n, p = baseline.shape
    models = {}
    for c in range(12):
        n_par = 3 if c < 3 else 1
        params = []
        for k in range(n_par):
            levels = np.array([-2.0, -1.0, 0.0, 1.0, 2.0] if c % 2 else [-1.0, 0.0, 1.0, 3.0])
            table = baseline[:, None, :] + rng.normal(0, 0.5, (n, levels.size, p)) * levels[None, :, None]
            params.append(ParameterResponse(f"p{k}", levels, table, 0.0, float(levels[0]) * 1.5,
                                            float(levels[-1]) * 1.5))
        models[f"c{c}"] = ResponseModel(f"c{c}", baseline, params)
    return models


def test_bootstrap_reference(benchmark):
    """:func:`~dronewind.diagnose.reference.null_reference` with 100 replicates on the default
    campaign's shape: every replicate redraws seeds and measurement, re-estimates the seed scale,
    the shrunk correlation and the discrepancy, and profiles every candidate's fit."""
    from dronewind.diagnose.features import FEATURES
    from dronewind.diagnose.reference import null_reference

    rng = np.random.default_rng(0)
    p = len(FEATURES)
    baseline = rng.normal(0, 1, (N_FLIGHTS, p))
    a = rng.normal(0, 1, (p, p))
    cov = a @ a.T + p * np.eye(p)
    corr = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    kwargs = dict(baseline=baseline, analytic=rng.uniform(0.05, 0.2, (N_FLIGHTS, p)), scale=np.ones(p), corr=corr,
                  tau=np.zeros(p), used=np.ones((N_FLIGHTS, p), bool), n_seeds=N_SEEDS,
                  speed_ms=np.linspace(3.0, 11.0, N_FLIGHTS), models=_models(rng, baseline), n_replicates=REPLICATES)
    _, cpu = cpu_round(benchmark, null_reference, rounds=3, **kwargs)
    benchmark.extra_info.update(replicates=REPLICATES, candidates=12, flights=N_FLIGHTS,
                                replicates_per_cpu_s=round(REPLICATES / cpu, 1))
