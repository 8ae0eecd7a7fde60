"""Hidden effects: the diagnosis must find a mechanism hidden in a virtual campaign, and nothing when none is.

Each draw picks a catalog mechanism and its size at random from the ranges of
dronewind.diagnose.experiments.HIDDEN_RANGES, on either side of its "off" value where both
make sense (or the null case), writes a 4-flight virtual campaign hiding it, runs the normal
Snakemake workflow up to diagnosis.json (with fewer baseline seeds and bootstrap replicates than
a campaign's defaults: :data:`DIAGNOSIS_SETTINGS`), and requires:

* null case: no named cause (a cause named where there is none is a failure);
* otherwise: no wrong cause; the hidden mechanism named (or reported in an ambiguity set with
  the named one) with its estimate within experiments.TOLERANCES (e.g. w_gain +/- 0.05, noise
  +/- 35 %), or else an expected failure reported with the verdict (the calibrated tests do
  not find every drawn size within tolerance on four flights: the rates over many draws are
  the benchmarks'); a hidden sonic-INS lag, which adds to every flight's processing lag (a measured
  condition of the forward model), with nothing named and the lags measured per flight
  equal to the processing lags plus the hidden one (+/- 0.1 s, experiments.judge).

The draws change with every commit: their seed is derived from ``git rev-parse HEAD``
(experiments.draw_seed; ``DRONEWIND_DRAW_SEED=<int>`` replays a failure), printed in the
pytest header and in the test ids. Four workflow runs: the null case, two distinct
mechanisms, and a model error (experiments.MODEL_ERRORS: physics the forward model does not
have, of a kind drawn at random), which must name no catalog cause, or only one the diagnosis
flags as sharing the model error's signature (experiments.CAVEATED_MODEL_ERRORS). The session
starts them in the background when it collects this module and runs its tests last
(tests/conftest.py). The rates over many draws, with intervals, are measured by
benchmarks/bench_diagnosis_rates.py (benchmarks/results/diagnosis_rates.json).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from dronewind.diagnose.experiments import campaign_manifest, draw, draw_seed, judge, model_error_draw
from tests.conftest import REPO, WorkflowRun, is_xdist_worker, shared_tmp

pytestmark = pytest.mark.slow

#: Seed of this run's draws and where it came from (printed by conftest's report header).
DRAW_SEED, DRAW_SEED_SOURCE = draw_seed(REPO)


def _draws(seed: int, n_mechanisms: int = 2) -> list:
    """The null case, ``n_mechanisms`` draws of distinct mechanisms, then a model error, from one seeded stream."""
    rng = np.random.default_rng(seed)
    out = [draw(rng, p_none=1.0)]
    while len(out) < n_mechanisms + 1:
        d = draw(rng, p_none=0.0)
        if d.mechanism not in {o.mechanism for o in out}:
            out.append(d)
    return [*out, model_error_draw(rng)]


#: Draws of this test: the null case first, then mechanisms drawn at random, then a model error
#: (physics the forward model does not have, of a kind drawn at random).
DRAWS = _draws(DRAW_SEED)


def test_draws_cover_the_null_case_distinct_mechanisms_and_a_model_error():
    assert DRAWS[0].mechanism == "none" and DRAWS[0].case == "null"
    mechanisms = [d.mechanism for d in DRAWS if d.case == "mechanism"]
    assert len(mechanisms) == 2 and len(set(mechanisms)) == 2
    assert DRAWS[-1].case == "model_error" and DRAWS[-1].model_error


#: Diagnosis settings of the runs, as the independent world's draws (tests/diagnose/test_independent_world.py):
#: 30 baseline seeds per flight (the least the error model takes; 120 pooled degrees of freedom on four
#: flights) and 300 bootstrap replicates, where a campaign's defaults (90 seeds on four flights for 400
#: pooled degrees of freedom, 600 replicates) cost three times the forward runs and twice the bootstrap.
#: The tests hold what they held: the bootstrap repeats the error model's estimate from as many seeds on
#: every replicate, so a false alarm or a wrong cause stays at the family-wise level alpha = 0.01
#: (p < alpha: the campaign beats all but 2 of 300 replicates, 3/301 = 1.00 % under the null, against
#: 6/601 = 1.00 % with 600); a miss is an expected failure either way, its rate the benchmarks'.
DIAGNOSIS_SETTINGS = {"seeds": [101 * (k + 1) for k in range(30)], "bootstrap": 300}


def hidden_runs(config: pytest.Config) -> dict[int, WorkflowRun]:
    """The workflow run of each draw (by its position in :data:`DRAWS`) up to diagnosis.json, made once per session.

    tests/conftest.py starts them one after another in the background when it has
    collected this module (whose tests then run last); a run nobody started runs when its
    test asks for it. On an xdist worker the runs are its controller's: the same folders of
    the shared temporary folder, waited for (``WorkflowRun(remote=True)``).
    """
    runs = config.stash.get(_RUNS, None)
    if runs is None:
        folder = shared_tmp(config) / "hidden"
        remote = is_xdist_worker(config)
        runs = {}
        for k, truth in enumerate(DRAWS):
            manifest = folder / f"draw{k}" / "hidden.yaml"
            settings = manifest.with_name("diagnosis.yaml")
            if not remote:
                manifest.parent.mkdir(parents=True)
                manifest.write_text(yaml.safe_dump(campaign_manifest(truth), sort_keys=False))
                settings.write_text(yaml.safe_dump({"diagnosis": DIAGNOSIS_SETTINGS}, default_flow_style=None))
            results = manifest.parent / "results"
            runs[k] = WorkflowRun(["--cores", "2", "--configfile", "config/config.yaml", str(settings),
                                   "--config", f"campaign={manifest}", f"results_dir={results}",
                                   "--", str(results / "hidden" / "diagnosis.json")],
                                  log=manifest.parent / "snakemake.log", remote=remote)
        config.stash[_RUNS] = runs
    return runs


_RUNS: pytest.StashKey[dict[int, WorkflowRun]] = pytest.StashKey()

#: The test ids of the draws (tests/conftest.py starts the runs of the selected ones by them).
DRAW_IDS = [f"{d.label}-seed{DRAW_SEED}" for d in DRAWS]


@pytest.mark.parametrize("truth", DRAWS, ids=DRAW_IDS)
def test_hidden_effect_is_found(truth, request):
    run = hidden_runs(request.config)[DRAWS.index(truth)]
    proc = run.wait()
    assert proc.returncode == 0, proc.stderr[-4000:]
    target = run.log.parent / "results" / "hidden" / "diagnosis.json"
    diagnosis = json.loads(target.read_text())
    verdict = judge(truth, diagnosis)
    summary = json.dumps({"verdict": verdict, "candidates": diagnosis["candidates"][:4]}, indent=1, default=str)
    if truth.case == "model_error":
        # no catalog cause for physics the forward model lacks; the goodness of fit and what the
        # model misses (features beyond their errors; none when the misfit is within them) are reported
        assert not verdict["false_alarm"] or verdict["caveated"], f"false attribution: {summary}"
        gof = diagnosis["goodness_of_fit"]
        assert gof["dof"] > 0 and gof["chi2"] >= 0 and 0.0 <= gof["p_value"] <= 1.0, gof
        assert isinstance(diagnosis["unexplained"], list) and all("feature" in u for u in diagnosis["unexplained"])
    elif truth.mechanism == "none":
        assert not verdict["false_alarm"], f"false alarm: {summary}"
    else:
        assert not verdict["wrong_cause"], f"a wrong cause named: {summary}"
        if not (verdict["detected"] and verdict["estimate_ok"]):
            # a miss, or an estimate outside its tolerance, is within the diagnosis' measured rates
            # on four 12-min flights (benchmarks/results/); it is reported with its verdict, while a
            # wrong cause or a false alarm fails
            pytest.xfail(f"hidden {truth} not named within tolerance on four flights: {summary}")
