"""The candidates' profiled fits on many bootstrap replicates at once (:mod:`dronewind.diagnose.replicates`)
give every replicate the statistics of the single-campaign functions.

Tolerance: the two do the same arithmetic in a different grouping of numpy calls, so they agree
to rounding; the statistics are differences of misfits of a few tens, whose rounding is about
1e-13, and 1e-9 x (1 + |value|) leaves four orders of magnitude while any wrong term (a missed
feature, a wrong cell, another start) moves them by far more.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from dronewind.diagnose import replicates
from dronewind.diagnose.calibration import (
    fit_jacobian,
    null_likelihood,
    profiled_discrepancy,
    profiled_fit,
)
from dronewind.diagnose.covariance import Whitener, flight_correlations, inverse_factors, shrunk_correlation
from dronewind.diagnose.fitting import ParameterResponse, ResponseModel, fit_parameters
from dronewind.diagnose.reference import (
    joined_reference,
    null_reference,
    reference_arrays,
    replicate_part,
    seed_scale,
)

TOL = 1e-9


def _close(a, b) -> None:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    assert np.all(np.abs(a - b) <= TOL * (1.0 + np.abs(a))), np.max(np.abs(a - b))


def _campaign(seed: int = 2, n: int = 6, p: int = 5):
    """A campaign of ``n`` flights and ``p`` features (one feature unused on one flight), with
    candidates of one parameter (3 and 5 levels), of two and of three parameters, and one whose
    table lacks a used feature (fitted one replicate at a time)."""
    rng = np.random.default_rng(seed)
    baseline = rng.normal(size=(n, p))
    used = np.ones((n, p), bool)
    used[2, 4] = False

    def par(name, levels, lower, upper, base=0.0):
        levels = np.asarray(levels, dtype=float)
        table = baseline[:, None, :] + rng.normal(0.0, 0.4, (n, levels.size, p)) * (levels - base)[None, :, None]
        return ParameterResponse(name, levels, table, base, lower, upper)

    models = {
        "one": ResponseModel("one", baseline, [par("a", [-1.0, 0.0, 1.0], -1.5, 1.5)]),
        "gain": ResponseModel("gain", baseline, [par("g", [0.8, 0.9, 1.0, 1.1, 1.2], 0.7, 1.3, base=1.0)]),
        "two": ResponseModel("two", baseline, [par("a", [-1.0, 0.0, 1.0], -1.5, 1.5),
                                               par("b", [-2.0, 0.0, 2.0], -2.0, 2.0)]),
        "three": ResponseModel("three", baseline, [par(k, [-1.0, 0.0, 1.0], -1.2, 1.2) for k in "xyz"]),
    }
    holed = par("h", [-1.0, 0.0, 1.0], -1.5, 1.5)
    holed.features[0, 2, 1] = np.nan
    models["holed"] = ResponseModel("holed", baseline, [holed])
    n_seeds = 12
    seeds = rng.normal(size=(n, n_seeds, p))
    corr = shrunk_correlation(seeds.reshape(n * n_seeds, p), np.repeat(np.arange(n), n_seeds))
    args = dict(baseline=baseline, analytic=rng.uniform(0.3, 0.6, (n, p)), scale=seed_scale(seeds),
                corr=corr.matrix, truth_corr=corr.sample, tau=np.array([0.2, 0.0, 0.1, 0.3, 0.0]), used=used,
                n_seeds=n_seeds, speed_ms=np.linspace(3.0, 10.0, n), models=models, n_replicates=24, seed=7)
    return args


def test_reference_statistics_are_those_of_the_single_campaign_fit() -> None:
    """Every candidate's likelihood-ratio statistics on every replicate of :func:`null_reference`
    (drawn in chunks, the candidates of one to three parameters fitted on all replicates at
    once) equal :func:`profiled_fit` on that replicate's features, errors and correlations; the
    candidate whose table lacks a used feature takes the single-campaign path."""
    args = _campaign()
    ref = null_reference(**args)
    used = replicates.used_features(np.stack(ref.y), np.stack(ref.sigma))
    assert [replicates.supported(m, used) for m in args["models"].values()] == [True, True, True, True, False]
    speed = args["speed_ms"]
    for b in range(ref.n_replicates):
        null = null_likelihood(ref.y[b], args["baseline"], ref.sigma[b], ref.corr[b], speed)
        for c, model in args["models"].items():
            prof = profiled_fit(model, ref.y[b], ref.sigma[b], ref.corr[b], speed,
                                (ref.total_sigma[b], Whitener(ref.flight_corr[b])), null=null,
                                plain=(ref.sigma[b], Whitener(ref.corr[b])))
            _close(ref.lr[c][b], prof.lr_statistic)
            _close(ref.lr_profile[c][b], prof.lr_profile)
    # the statistics are not all zero: the comparison above has something to compare
    assert min(float(np.max(v)) for v in ref.lr_profile.values()) > 0.1


def test_reference_parts_join_to_the_whole_with_batched_fits() -> None:
    """Parts of 7, 8 and 9 replicates (chunked otherwise than the whole) join to the whole
    reference number for number: a replicate's batched fits do not depend on the others in its chunk."""
    args = _campaign(seed=4)
    whole = reference_arrays(null_reference(**args))
    joined = reference_arrays(joined_reference([null_reference(**args, replicates=replicate_part(24, k, 3))
                                                for k in range(3)]))
    for key in whole:
        np.testing.assert_array_equal(whole[key], joined[key], err_msg=key)


def _replicate_inputs(args, n_rep: int = 5):
    ref = null_reference(**{**args, "n_replicates": n_rep})
    y, sigma, total = np.stack(ref.y), np.stack(ref.sigma), np.stack(ref.total_sigma)
    return ref, y, sigma, total


@pytest.mark.parametrize("name", ["one", "gain", "two", "three"])
def test_fit_is_fit_parameters_on_every_replicate(name: str) -> None:
    """Parameters and misfits of :func:`replicates.fit` are those of :func:`fit_parameters`, under
    a shared and under a per-flight correlation."""
    args = _campaign()
    model = args["models"][name]
    ref, y, sigma, total = _replicate_inputs(args)
    used = replicates.used_features(y, sigma)
    corr = np.stack(ref.corr)
    shared = replicates.fit(model, y, sigma, inverse_factors(corr, used))
    per_flight = replicates.fit(model, y, total, inverse_factors(np.stack(ref.flight_corr), used, per_row=True))
    idx = np.arange(y.shape[1])
    for b in range(y.shape[0]):
        for got, s, w in ((shared, sigma[b], Whitener(ref.corr[b])),
                          (per_flight, total[b], Whitener(ref.flight_corr[b]))):
            want = fit_parameters(model, y[b], s, idx, w)
            _close(got.theta[b], want.theta)
            _close(got.chi2[b], want.chi2)
            _close(got.chi2_baseline[b], want.chi2_baseline)


@pytest.mark.parametrize("about_zero", [False, True])
def test_profiled_discrepancy_is_the_single_campaign_one(about_zero: bool) -> None:
    """The discrepancy after a three-parameter fit (one parameter pushed to its bound on some
    replicates, whose column the single-campaign Jacobian leaves out) is
    :func:`profiled_discrepancy`'s, with the offset and trend removed and about zero."""
    args = _campaign()
    model = args["models"]["three"]
    ref, y, sigma, total = _replicate_inputs(args)
    theta = np.column_stack([np.linspace(-1.2, 0.5, y.shape[0]), np.full(y.shape[0], 0.3), np.full(y.shape[0], 1.2)])
    resid = y - model.predict_each(theta)
    tau_start = np.abs(np.random.default_rng(1).normal(0.2, 0.1, (y.shape[0], y.shape[2])))
    got = replicates.profiled_discrepancy(resid, sigma, args["speed_ms"], replicates.fit_jacobian(model, theta),
                                          total, tau_start, about_zero=about_zero)
    idx = np.arange(y.shape[1])
    # z at its upper bound on every replicate, x also at its lower one on the first
    assert [fit_jacobian(model, t, idx).shape[2] for t in theta] == [1, 2, 2, 2, 2]
    for b in range(y.shape[0]):
        jac = fit_jacobian(model, theta[b], idx)
        want = profiled_discrepancy(resid[b], sigma[b], args["speed_ms"], jac, total[b], tau_start[b],
                                    about_zero=about_zero).tau_or_zero()
        _close(got[b], want)
        np.testing.assert_array_equal(model.predict_each(theta[b:b + 1])[0], model.predict(theta[b], idx))


def test_leading_axes_of_the_covariance_helpers() -> None:
    """:func:`flight_correlations` and :func:`inverse_factors` with a leading axis are each item's own."""
    rng = np.random.default_rng(3)
    n, p = 4, 3
    a = rng.normal(size=(2, p, p))
    corr = np.stack([(m @ m.T + p * np.eye(p)) for m in a])
    corr = corr / np.sqrt(np.einsum("bii,bjj->bij", corr, corr))
    sigma = rng.uniform(0.5, 1.0, (2, n, p))
    tau = rng.uniform(0.0, 0.5, (2, p))
    use = np.ones((n, p), bool)
    use[1, 2] = False
    total, fcorr = flight_correlations(corr, sigma, tau)
    shared = inverse_factors(corr, use)
    per_row = inverse_factors(fcorr, use, per_row=True)
    for b in range(2):
        t, f = flight_correlations(corr[b], sigma[b], tau[b])
        np.testing.assert_array_equal(total[b], t)
        np.testing.assert_array_equal(fcorr[b], f)
        np.testing.assert_array_equal(shared[b], Whitener(corr[b]).padded(use))
        np.testing.assert_array_equal(per_row[b], Whitener(f).padded(use))


def test_replicates_of_different_used_features_are_refused() -> None:
    y = np.ones((2, 3, 2))
    y[1, 0, 0] = np.nan
    with pytest.raises(ValueError, match="one pattern of used features"):
        replicates.used_features(y, np.ones_like(y))


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
# a replicate whose first step ends at the plain start's own fit: the two statistics of the choice
# of step tie and differ by rounding only (calibration.more_likely)
@example(n=2, p=3, seed=22883, hole=False, tau=0.1326080660966763, levels=4)
@given(n=st.integers(2, 5), p=st.integers(2, 4), seed=st.integers(0, 2**16), hole=st.booleans(),
       tau=st.floats(0.0, 0.5), levels=st.sampled_from([3, 4]))
def test_random_campaigns_give_the_single_campaign_statistics(n, p, seed, hole, tau, levels) -> None:
    """Random small campaigns (two to five flights, so with and without the wind-speed trend in the
    moments; a feature unused on one flight or none; with and without a discrepancy; tables of three
    or four levels; candidates of one and of two parameters): every replicate's statistics are
    :func:`profiled_fit`'s."""
    rng = np.random.default_rng(seed)
    baseline = rng.normal(size=(n, p))
    used = np.ones((n, p), bool)
    if hole:
        used[rng.integers(n), rng.integers(p)] = False
    grid = np.linspace(-1.0, 1.0, levels) if levels == 3 else np.array([-1.0, 0.0, 0.5, 1.0])

    def par(name):
        table = baseline[:, None, :] + rng.normal(0.0, 0.5, (n, grid.size, p)) * grid[None, :, None]
        return ParameterResponse(name, grid, table, 0.0, -1.3, 1.3)

    models = {"one": ResponseModel("one", baseline, [par("a")]),
              "two": ResponseModel("two", baseline, [par("a"), par("b")])}
    n_seeds = 8
    seeds = rng.normal(size=(n, n_seeds, p))
    corr = shrunk_correlation(seeds.reshape(n * n_seeds, p), np.repeat(np.arange(n), n_seeds))
    speed = np.sort(rng.uniform(3.0, 10.0, n))
    ref = null_reference(baseline=baseline, analytic=rng.uniform(0.3, 0.6, (n, p)), scale=seed_scale(seeds),
                         corr=corr.matrix, truth_corr=corr.sample, tau=np.full(p, tau), used=used, n_seeds=n_seeds,
                         speed_ms=speed, models=models, n_replicates=6, seed=seed)
    for b in range(ref.n_replicates):
        null = null_likelihood(ref.y[b], baseline, ref.sigma[b], ref.corr[b], speed)
        for c, model in models.items():
            prof = profiled_fit(model, ref.y[b], ref.sigma[b], ref.corr[b], speed,
                                (ref.total_sigma[b], Whitener(ref.flight_corr[b])), null=null,
                                plain=(ref.sigma[b], Whitener(ref.corr[b])))
            _close(ref.lr[c][b], prof.lr_statistic)
            _close(ref.lr_profile[c][b], prof.lr_profile)


def test_a_tie_of_profile_statistics_is_not_more_likely() -> None:
    """Two statistics within rounding of each other tie (neither is the more likely), a margin above
    1e-9 relative is larger, elementwise on arrays."""
    from dronewind.diagnose.calibration import more_likely

    assert not more_likely(1.0802998943658384, 1.080299894365817)
    assert not more_likely(1.080299894365817, 1.0802998943658384)
    assert more_likely(1.0803, 1.0802)
    np.testing.assert_array_equal(more_likely(np.array([2.0, 1.0 + 1e-12, 0.5]), np.ones(3)), [True, False, False])
