"""Calibrated statistics of the campaign diagnosis (dronewind.diagnose.calibration).

Known answers on synthetic residuals: the discrepancy estimate and its interval's coverage,
the offset and trend statistics, the Westfall-Young family-wise p-values, and the bootstrap
reference, whose goodness-of-fit p-values must be uniform and whose candidate test must hold
its false-alarm rate and find a true effect, on campaigns drawn from a known Gaussian model.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.stats

from dronewind.diagnose.calibration import discrepancy, fit_dof, profiled_discrepancy, profiled_fit
from dronewind.diagnose.covariance import Whitener, flight_correlations
from dronewind.diagnose.fitting import ParameterResponse, ResponseModel
from dronewind.diagnose.reference import (
    check_attainable,
    empirical_p,
    familywise_p,
    flight_seed_scale,
    mc_standard_error,
    null_reference,
    offset_trend_z,
    seed_scale,
)


def test_discrepancy_recovers_a_known_scatter_and_its_interval_covers() -> None:
    """tau = 0.3 with sampling errors 0.2-0.5 on 400 flights: estimate within 0.05 (its standard
    error is about 0.02 there); the 95 % Q-profile interval covers the truth in 85-100 % of 120
    campaigns of 8 flights (binomial 95 % range of 120 draws at 0.95: 0.91-0.99, widened for
    the method's own approximation on few flights)."""
    rng = np.random.default_rng(1)
    n = 400
    sigma = rng.uniform(0.2, 0.5, (n, 1))
    r = 0.7 + rng.normal(0, 0.3, (n, 1)) + rng.normal(0, 1, (n, 1)) * sigma  # offset is not discrepancy
    d = discrepancy(r, sigma)
    assert d.tau[0] == pytest.approx(0.3, abs=0.05)
    covered = 0
    for _ in range(120):
        s = rng.uniform(0.2, 0.5, (8, 1))
        r = rng.normal(0, 0.3, (8, 1)) + rng.normal(0, 1, (8, 1)) * s
        d = discrepancy(r, s)
        covered += bool(d.low[0] <= 0.3 <= d.high[0])
    assert 0.85 <= covered / 120 <= 1.0


def _moments_of_one_feature(r, s, speed, lost):
    """DerSimonian-Laird moments of one feature written out (offset, and a trend with four or more
    flights of differing speed): Q, the degrees of freedom after ``lost`` and tau^2."""
    ok = np.isfinite(r) & np.isfinite(s) & (s > 0)
    r, w = r[ok], 1.0 / s[ok] ** 2
    x = np.ones((r.size, 1))
    if speed is not None and r.size >= 4 and np.ptp(speed[ok]) > 0:
        x = np.column_stack([x, speed[ok] - speed[ok].mean()])
    k = r.size - x.shape[1]
    if k < 1:
        return np.nan, 0.0, np.nan
    inv = np.linalg.inv(x.T @ (w[:, None] * x))
    e = r - x @ (inv @ (x.T @ (w * r)))
    q = float(np.sum(w * e * e))
    k_eff = k - min(max(lost, 0.0), 0.9 * k)
    denom = (np.sum(w) - np.trace(inv @ (x.T @ ((w * w)[:, None] * x)))) * k_eff / k
    return q, k_eff, max(0.0, (q - k_eff) / denom)


def test_batched_moments_are_the_written_out_ones() -> None:
    """The moments of features grouped by their usable flights equal the DerSimonian-Laird
    moments written out feature by feature, with missing flights, lost degrees of freedom and a
    trend (to rounding, 1e-10), with and without the Q-profile interval."""
    rng = np.random.default_rng(5)
    n, p = 9, 6
    sigma = rng.uniform(0.2, 0.6, (n, p))
    r = rng.normal(0, 0.4, (n, p)) + rng.normal(0, 1, (n, p)) * sigma
    r[0, 1] = r[4, 1] = r[2, 3] = np.nan
    r[:7, 5] = np.nan  # two flights left: no degree of freedom with the trend, one without
    speed = rng.uniform(3, 12, n)
    lost = rng.uniform(0, 2, p)
    for speeds in (speed, None):
        for interval in (False, True):
            d = discrepancy(r, sigma, speeds, interval=interval, lost_dof=lost)
            for f in range(p):
                q, k_eff, tau2 = _moments_of_one_feature(r[:, f], sigma[:, f], speeds, lost[f])
                np.testing.assert_allclose([d.q_statistic[f], d.dof[f], d.tau[f] ** 2], [q, k_eff, tau2],
                                           rtol=1e-10, atol=1e-12, equal_nan=True)


def test_profiled_moments_about_zero_are_the_written_out_ones() -> None:
    """The discrepancy after a fit, moments about zero (the likelihood ratio's), equals its
    docstring's formula written out with dense matrices: :math:`B_f = W^{1/2}(E_f - J_f K)`,
    :math:`E[Q_f]` from the sampling variances, the feature's own discrepancy and the others'
    leaking through the fit (to rounding, 1e-10), with a missing flight."""
    rng = np.random.default_rng(11)
    n, p, m = 7, 4, 2
    sigma = rng.uniform(0.2, 0.6, (n, p))
    fit_sigma = sigma * rng.uniform(1.0, 1.5, (n, p))
    r = rng.normal(0, 0.5, (n, p))
    r[2, 1] = np.nan
    jac = rng.normal(0, 1, (n, p, m))
    tau_start = rng.uniform(0.0, 0.3, p)
    d = profiled_discrepancy(r, sigma, None, jac, fit_sigma, tau_start, about_zero=True)
    used = np.isfinite(r)
    a = np.where(used[..., None], jac / fit_sigma[..., None], 0.0).reshape(n * p, m)
    k_map = np.where(used.reshape(1, -1), np.linalg.inv(a.T @ a) @ a.T / fit_sigma.reshape(1, -1), 0.0)
    var = np.where(used, sigma**2, 0.0).reshape(-1)
    tau2_of = np.where(used, tau_start[None, :] ** 2, 0.0).reshape(-1)
    feature_of = np.tile(np.arange(p), n)
    for f in range(p):
        rows = np.flatnonzero(used[:, f])
        select = np.zeros((rows.size, n * p))
        select[np.arange(rows.size), rows * p + f] = 1.0
        b = (select - jac[rows, f, :] @ k_map) / sigma[rows, f][:, None]
        col = np.sum(b**2, axis=0)
        own = feature_of == f
        expected0 = col @ var + np.sum(col[~own] * tau2_of[~own])
        q = np.sum(r[rows, f] ** 2 / sigma[rows, f] ** 2)
        tau2 = max(0.0, (q - expected0) / col[own].sum())
        np.testing.assert_allclose([d.q_statistic[f], d.dof[f], d.tau[f] ** 2], [q, col @ var, tau2],
                                   rtol=1e-10, atol=1e-12)


def test_discrepancy_is_zero_without_scatter_and_a_trend_is_not_scatter() -> None:
    """Pure sampling error: tau estimated 0 in most draws; a trend with wind speed on six flights
    is removed before the scatter is estimated (it would otherwise read as a discrepancy)."""
    rng = np.random.default_rng(2)
    zeros = sum(discrepancy(rng.normal(0, 1, (6, 1)) * 0.1, np.full((6, 1), 0.1)).tau[0] == 0 for _ in range(200))
    assert zeros > 80  # P(Q < dof) is about 0.58 for chi2 with 5 dof
    speed = np.linspace(3, 12, 6)
    r = (0.2 * (speed - speed.mean()))[:, None]
    assert discrepancy(r, np.full((6, 1), 0.05), speed).tau[0] == pytest.approx(0.0, abs=1e-9)
    assert discrepancy(r, np.full((6, 1), 0.05)).tau[0] > 0.3


def test_offset_trend_z_known_answers() -> None:
    """Equal errors: the offset z is mean/sigma*sqrt(n); the trend z is slope*sqrt(Sxx)/sigma."""
    speed = np.array([2.0, 4.0, 6.0, 8.0])
    r = np.column_stack([np.full(4, 0.2), 0.05 * (speed - 5.0)])
    s = np.full((4, 2), 0.1)
    mean_z, slope_z = offset_trend_z(r, s, speed)
    assert mean_z[0] == pytest.approx(0.2 / 0.1 * 2.0)
    assert slope_z[0] == pytest.approx(0.0, abs=1e-12)
    assert mean_z[1] == pytest.approx(0.0, abs=1e-12)
    assert slope_z[1] == pytest.approx(0.05 * np.sqrt(20.0) / 0.1)


def test_seed_scale_pools_within_flight_deviations() -> None:
    """Two flights of standard-normal seeds scaled by 2: k = 2 within its sampling error (240 dof)."""
    rng = np.random.default_rng(3)
    x = 2.0 * rng.normal(size=(2, 121, 3)) + np.array([[[5.0]], [[-5.0]]])
    assert seed_scale(x) == pytest.approx(np.full(3, 2.0), rel=0.15)


def test_flight_seed_scale_known_answers() -> None:
    """Each flight's own seed scatter: sd 1 and 3 of two flights with 40 seeds (ddof 1, exact
    for the +-sd pattern); a flight with fewer than 30 seeds has none (NaN: the bootstrap then
    draws it with the pooled scale)."""
    pattern = np.tile([-1.0, 1.0], 20) * np.sqrt(39.0 / 40.0)  # sample sd exactly 1
    x = np.stack([np.column_stack([pattern, 2 * pattern]), np.column_stack([3 * pattern + 7.0, 2 * pattern])])
    assert flight_seed_scale(x) == pytest.approx(np.array([[1.0, 2.0], [3.0, 2.0]]))
    assert seed_scale(x) == pytest.approx(np.array([np.sqrt(5.0), 2.0]))  # pooled variance (1 + 9) / 2
    few = x.copy()
    few[1, 25:, 0] = np.nan  # 25 seeds left on the second flight
    k_few = flight_seed_scale(few)
    assert k_few[0, 0] == pytest.approx(1.0)
    assert np.isnan(k_few[1, 0]) and k_few[1, 1] == pytest.approx(2.0)


def test_replicates_drawn_with_each_flights_scatter_calibrate_the_goodness_of_fit() -> None:
    """Flights whose seed scatter differs from the analytic errors by factors of 0.3 to 2.5 (as
    the speed, direction and tilt differences' do): the misfit against the pooled errors is then
    wider than pooled Gaussian replicates make it, and its bootstrap p-values pile up at both ends
    (Kolmogorov-Smirnov p < 0.001 over 300 campaigns); replicates drawn with each flight's own
    seed scatter (``flight_scale``) give uniform p-values (KS p > 0.01)."""
    rng = np.random.default_rng(11)
    n, n_seeds, p = 10, 41, 3
    true = np.exp(rng.uniform(np.log(0.3), np.log(2.5), size=(n, p)))  # seed scatter / analytic error
    analytic, zero, used = np.ones((n, p)), np.zeros((n, p)), np.ones((n, p), dtype=bool)
    speed = np.linspace(3.0, 11.0, n)
    seeds = true[:, None, :] * rng.normal(size=(n, n_seeds, p))
    refs = {name: null_reference(baseline=zero, analytic=analytic, scale=seed_scale(seeds), corr=None,
                                 tau=np.zeros(p), used=used, n_seeds=n_seeds, speed_ms=speed, models={},
                                 n_replicates=400, seed=1, flight_scale=fs)
            for name, fs in (("pooled", None), ("flight", flight_seed_scale(seeds)))}
    p_values: dict[str, list[float]] = {"pooled": [], "flight": []}
    for _ in range(300):
        own = true[:, None, :] * rng.normal(size=(n, n_seeds, p))
        resid = true * rng.normal(size=(n, p)) - own.mean(axis=1)
        sigma = np.sqrt(1.0 + 1.0 / n_seeds) * seed_scale(own)[None, :] * analytic
        gof = float(np.sum((resid / sigma) ** 2))
        for name, ref in refs.items():
            p_values[name].append(empirical_p(gof, ref.gof))
    assert scipy.stats.kstest(p_values["pooled"], "uniform").pvalue < 0.001
    assert scipy.stats.kstest(p_values["flight"], "uniform").pvalue > 0.01


def test_familywise_min_p_holds_its_rate_over_independent_tests() -> None:
    """Ten independent normal tests under the null: the min-p family-wise p is below 0.05 in
    about 5 % of 400 trials (binomial 99 % range 2-8.5 %); a single strong effect is found."""
    rng = np.random.default_rng(4)
    reps = {f"t{j}": np.abs(rng.normal(size=2000)) for j in range(10)}
    hits = 0
    for _ in range(400):
        obs = {t: abs(rng.normal()) for t in reps}
        hits += min(familywise_p(obs, reps).values()) < 0.05
    assert 0.02 <= hits / 400 <= 0.085
    obs = {t: abs(rng.normal()) for t in reps} | {"t3": 5.0}
    assert familywise_p(obs, reps)["t3"] < 0.01
    assert empirical_p(10.0, np.arange(9.0)) == pytest.approx(0.1)


def _campaign(rng: np.random.Generator, n_flights: int, n_seeds: int, corr: np.ndarray, effect: float,
              direction: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Seeds and a measurement from a known Gaussian model, plus ``effect`` along ``direction`` [feature units]."""
    p = corr.shape[0]
    chol = np.linalg.cholesky(corr)
    analytic = rng.uniform(0.5, 2.0, (n_flights, p))
    seeds = (rng.normal(size=(n_flights, n_seeds, p)) @ chol.T) * analytic[:, None, :]
    y = (rng.normal(size=(n_flights, p)) @ chol.T) * analytic + effect * direction[None, :]
    return y, seeds, analytic, seeds.mean(axis=1)


@pytest.mark.slow
def test_bootstrap_reference_is_calibrated_on_a_known_gaussian_model() -> None:
    """Campaigns drawn from the model the bootstrap assumes (5 correlated features, 6 flights, 30
    seeds, 100 replicates): over 50 null campaigns the goodness-of-fit p-values are uniform (KS
    p > 0.01) and a one-parameter candidate is significant at 0.05 in at most 7 (binomial 99 %
    bound of 50 at 0.05); an effect of 1.5 analytic errors per flight along the candidate's response (a
    non-centrality of about 20 over the six flights: power 0.95 at 0.01) is found in at least 8
    of 10 campaigns."""
    from dronewind.diagnose.covariance import shrunk_correlation
    from dronewind.diagnose.fitting import chi2

    rng = np.random.default_rng(5)
    p, n, n_seeds = 5, 6, 30
    corr = 0.5 * np.eye(p) + 0.5 * np.exp(-np.abs(np.subtract.outer(np.arange(p), np.arange(p))))
    direction = np.array([1.0, 0.5, 0.0, -0.5, 0.2])

    def run(effect: float) -> tuple[float, float]:
        y, seeds, analytic, base = _campaign(rng, n, n_seeds, corr, effect, direction)
        k = seed_scale(seeds / analytic[:, None, :])
        r_star = shrunk_correlation((seeds / analytic[:, None, :]).reshape(-1, p), np.repeat(np.arange(n), n_seeds))
        sigma = np.sqrt(1 + 1 / n_seeds) * k[None, :] * analytic
        resp = np.stack([base, base + 2.0 * direction[None, :]], axis=1)
        model = ResponseModel("m", base, [ParameterResponse("a", np.array([0.0, 2.0]), resp, 0.0, -5.0, 5.0)])
        speed = np.linspace(3, 10, n)
        tau = discrepancy(y - base, sigma, speed).tau_or_zero()
        total, fcorr = flight_correlations(r_star.matrix, sigma, tau)
        ref = null_reference(baseline=base, analytic=analytic, scale=k, corr=r_star.matrix, truth_corr=r_star.sample,
                             tau=tau,
                             used=np.ones((n, p), bool), n_seeds=n_seeds, speed_ms=speed,
                             models={"m": model}, n_replicates=100, seed=int(rng.integers(1 << 30)))
        gof = float(chi2(y, base, sigma, Whitener(r_star.matrix)).sum())
        lr = profiled_fit(model, y, sigma, r_star.matrix, speed, (total, Whitener(fcorr)),
                          plain=(sigma, Whitener(r_star.matrix))).lr_profile
        return empirical_p(gof, ref.gof), familywise_p({"m": lr}, ref.lr_profile)["m"]

    nulls = [run(0.0) for _ in range(50)]
    assert scipy.stats.kstest([g for g, _ in nulls], "uniform").pvalue > 0.01
    assert sum(lr_p < 0.05 for _, lr_p in nulls) <= 7
    assert sum(run(2.0)[1] < 0.01 for _ in range(10)) >= 8


def _linear_model(signature: np.ndarray) -> ResponseModel:
    """One parameter ``a`` whose effect on flight i is ``a * signature[i]`` (tabulated at -8..8)."""
    levels = np.array([-8.0, 0.0, 8.0])
    table = levels[None, :, None] * signature[:, None, :]
    return ResponseModel("m", np.zeros_like(signature), [ParameterResponse("a", levels, table, 0.0, -8.0, 8.0)])


def test_discrepancy_profiled_under_the_right_candidate_is_the_true_discrepancy() -> None:
    """A planted mechanism (a = 2 along a signature that differs from flight to flight, neither
    offset nor trend) on 30 flights with a known discrepancy tau = (0.6, 0, 1.0, 0.3) and sampling
    errors 0.5-1: estimated from the baseline's residuals the discrepancy holds the mechanism
    (tau^2 of the first feature several times the truth); profiled under the right candidate,
    its mean over 40 campaigns is the truth within 20 % of the largest tau^2 (the DerSimonian-Laird
    moment is unbiased before truncation at zero; the fit's projection accounted for), and the
    fitted parameter is 2 within 0.15 on average. A signature that is an offset and a trend with
    wind speed takes no degree of freedom from the moments (they are taken about both): the
    profiled discrepancy is then the baseline's."""
    rng = np.random.default_rng(11)
    n, p = 30, 4
    tau = np.array([0.6, 0.0, 1.0, 0.3])
    speed = np.linspace(3.0, 12.0, n)
    base_t2, prof_t2, est = [], [], []
    for _ in range(40):
        signature = rng.normal(size=(n, p)) * np.array([1.0, 0.6, 0.8, 0.0])
        model = _linear_model(signature)
        sigma = rng.uniform(0.5, 1.0, (n, p))
        y = 2.0 * signature + rng.normal(size=(n, p)) * tau[None, :] + rng.normal(size=(n, p)) * sigma
        tau0 = discrepancy(y, sigma, speed).tau_or_zero()
        total, fcorr = flight_correlations(None, sigma, tau0)
        prof = profiled_fit(model, y, sigma, None, speed, (total, Whitener(fcorr)))
        base_t2.append(tau0**2)
        prof_t2.append(prof.discrepancy.tau_or_zero() ** 2)
        est.append(prof.fit.theta[0])
    assert np.mean(base_t2, axis=0)[0] > 4.0 * tau[0] ** 2
    assert np.mean(prof_t2, axis=0) == pytest.approx(tau**2, abs=0.2)
    assert np.mean(est) == pytest.approx(2.0, abs=0.15)
    signature = np.zeros((n, p))
    signature[:, 0] = 0.1 * speed
    sigma = np.full((n, p), 0.5)
    y = 2.0 * signature + rng.normal(size=(n, p)) * tau[None, :] + rng.normal(size=(n, p)) * sigma
    tau0 = discrepancy(y, sigma, speed).tau_or_zero()
    total, fcorr = flight_correlations(None, sigma, tau0)
    prof = profiled_fit(_linear_model(signature), y, sigma, None, speed, (total, Whitener(fcorr)))
    assert prof.discrepancy.tau_or_zero() == pytest.approx(tau0, abs=1e-6)
    assert prof.lost_dof == pytest.approx(np.zeros(p), abs=1e-6)


def test_profile_likelihood_ratio_keeps_its_reference_under_a_large_discrepancy() -> None:
    """Four flights, a candidate whose signature changes sign from flight to flight (3, -2, 4, -3
    sampling errors per unit, on one of two features) planted at 2 units, no discrepancy, and a
    second candidate that moves the same feature by a common offset. Estimated about an offset
    and a trend, the discrepancy of that feature holds the planted signature (several sampling
    errors), so the bootstrap draws large discrepancies. The profile statistic (each hypothesis
    under its own discrepancy) keeps a reference close to chi-square with one degree of freedom
    (95th percentile below 7.7, twice chi2_1's 3.84) for both candidates in every campaign and
    finds the planted candidate at 0.01 in all six; the conditional statistic's reference has a
    95th percentile above 10 in every campaign (the fit absorbs part of the drawn discrepancy,
    whose offset it then counts as signal), and that tail sets the family-wise p-values."""
    n, p = 4, 2
    speed = np.array([3.5, 5.5, 7.5, 9.5])
    signature = np.zeros((n, p))
    signature[:, 0] = [3.0, -2.0, 4.0, -3.0]
    offset = np.zeros((n, p))
    offset[:, 0] = 1.0
    models = {"m": _linear_model(signature), "d": _linear_model(offset)}
    sigma = np.ones((n, p))
    tails = {c: (lambda x: scipy.stats.chi2.sf(x, 1)) for c in models}
    for trial in range(6):
        rng = np.random.default_rng(trial)
        y = 2.0 * signature + rng.normal(size=(n, p)) * sigma
        tau0 = discrepancy(y, sigma, speed).tau_or_zero()
        assert tau0[0] > 5.0
        total, fcorr = flight_correlations(None, sigma, tau0)
        fits = {c: profiled_fit(m, y, sigma, None, speed, (total, Whitener(fcorr)), plain=(sigma, Whitener(None)))
                for c, m in models.items()}
        ref = null_reference(baseline=np.zeros((n, p)), analytic=np.ones((n, p)), scale=np.ones(p), corr=None,
                             truth_corr=None, tau=tau0, used=np.ones((n, p), bool), n_seeds=30, speed_ms=speed,
                             models=models, n_replicates=200, seed=trial)
        assert all(np.quantile(ref.lr_profile[c], 0.95) < 7.7 for c in models)
        assert np.quantile(ref.lr["m"], 0.95) > 10.0
        p_fw = familywise_p({c: f.lr_profile for c, f in fits.items()}, ref.lr_profile, marginal=tails)
        assert p_fw["m"] < 0.01


def test_a_second_start_without_discrepancy_fits_a_signature_the_discrepancy_holds() -> None:
    """Four flights: a candidate moves the first feature along 3, -2, 4, -3 sampling errors per unit
    (a sign that changes from flight to flight) and the second by 0.5 on every flight; the data
    hold it at -2 in the first feature while the second is moved the other way (+1, what another
    world's physics may do). Estimated about an offset and a trend, the discrepancy of the first
    feature holds the planted signature, and a fit started under it follows the second feature
    (off by more than 0.9 in all six campaigns). Started also without discrepancy, the likelier
    step finds -2 within 0.4, with a larger profile likelihood ratio."""
    n, p = 4, 2
    speed = np.array([3.5, 5.5, 7.5, 9.5])
    signature = np.zeros((n, p))
    signature[:, 0] = [3.0, -2.0, 4.0, -3.0]
    signature[:, 1] = 0.5
    model = _linear_model(signature)
    sigma = np.ones((n, p))
    for trial in range(6):
        rng = np.random.default_rng(trial)
        y = -2.0 * signature + rng.normal(size=(n, p)) * sigma
        y[:, 1] = 1.0 + rng.normal(size=n)
        tau0 = discrepancy(y, sigma, speed).tau_or_zero()
        total, fcorr = flight_correlations(None, sigma, tau0)
        one = profiled_fit(model, y, sigma, None, speed, (total, Whitener(fcorr)))
        two = profiled_fit(model, y, sigma, None, speed, (total, Whitener(fcorr)), plain=(sigma, Whitener(None)))
        assert abs(one.fit.theta[0] + 2.0) > 0.9
        assert two.fit.theta[0] == pytest.approx(-2.0, abs=0.4)
        assert two.lr_profile > one.lr_profile


def test_fit_dof_is_the_leverage_of_the_free_parameters() -> None:
    """One parameter along a signature carried by one feature: it takes one degree of freedom, all of
    that feature's; at a bound it takes none."""
    n, p = 6, 3
    signature = np.zeros((n, p))
    signature[:, 1] = np.linspace(1.0, 2.0, n)
    model = _linear_model(signature)
    h = fit_dof(model, np.array([1.0]), np.ones((n, p)), np.arange(n))
    assert h == pytest.approx([0.0, 1.0, 0.0])
    assert fit_dof(model, np.array([8.0]), np.ones((n, p)), np.arange(n)) == pytest.approx(np.zeros(p))


def test_familywise_p_resolution_and_attainable_level() -> None:
    """13 tests, B = 600: an observed statistic beyond every replicate of its test gets the smallest
    p-value 1/601 with pivotal marginal tails; with rank marginals it gets about 13/601 (each other
    test's largest replicate ties it), which is why the diagnosis passes the tails. A level below
    1/(B+1) is refused; the Monte-Carlo standard error is sqrt(p(1-p)/(B+1))."""
    rng = np.random.default_rng(12)
    tests = [f"t{j}" for j in range(13)]
    reps = {t: rng.chisquare(1, 600) for t in tests}
    obs = {t: 0.5 for t in tests} | {"t0": 40.0}
    tails = {t: (lambda x: scipy.stats.chi2.sf(x, 1)) for t in tests}
    assert familywise_p(obs, reps, marginal=tails)["t0"] == pytest.approx(1 / 601)
    assert familywise_p(obs, reps)["t0"] >= 10 / 601
    with pytest.raises(ValueError):
        check_attainable(0.001, 600)
    check_attainable(0.01, 600)
    assert mc_standard_error(0.05, 600) == pytest.approx(np.sqrt(0.05 * 0.95 / 601))


def test_a_reference_drawn_in_parts_is_the_whole_reference_number_for_number() -> None:
    """The workflow draws the bootstrap in parts (diagnose_reference jobs): 3 parts of 11
    replicates of a 4-flight, 3-feature campaign with a shrunk correlation and a discrepancy,
    stored as arrays and read back, joined in order, equal every statistic and every replicate's
    features, errors and correlations of the reference drawn at once (the generator replays the
    earlier parts' random numbers). Parts of another seed do not join; a part outside the
    replicates is refused."""
    from dronewind.diagnose.covariance import shrunk_correlation
    from dronewind.diagnose.reference import (
        joined_reference,
        reference_arrays,
        reference_from_arrays,
        replicate_part,
    )

    n, p, n_seeds = 4, 3, 30
    rng = np.random.default_rng(5)
    speed = np.array([3.5, 5.5, 7.5, 9.5])
    signature = np.zeros((n, p))
    signature[:, 0] = [1.0, -1.0, 2.0, -2.0]
    models = {"m": _linear_model(signature)}
    seeds = rng.normal(size=(n, n_seeds, p))
    corr = shrunk_correlation(seeds.reshape(n * n_seeds, p), np.repeat(np.arange(n), n_seeds))
    args = dict(baseline=rng.normal(size=(n, p)), analytic=np.full((n, p), 0.5), scale=seed_scale(seeds),
                corr=corr.matrix, truth_corr=corr.sample, tau=np.array([0.3, 0.0, 0.1]), used=np.ones((n, p), bool),
                n_seeds=n_seeds, speed_ms=speed, models=models, n_replicates=11, seed=3)
    whole = null_reference(**args)
    parts = [reference_from_arrays(reference_arrays(null_reference(**args, replicates=replicate_part(11, k, 3))))
             for k in range(3)]
    assert [r.n_replicates for r in parts] == [3, 4, 4]
    joined = joined_reference(parts)
    a, b = reference_arrays(whole), reference_arrays(joined)
    assert a.keys() == b.keys() and "lr/m" in a
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    other = null_reference(**{**args, "seed": 4}, replicates=range(0, 2))
    with pytest.raises(ValueError, match="different bootstrap references"):
        joined_reference([parts[0], other])
    with pytest.raises(ValueError, match="contiguous range within range"):
        null_reference(**args, replicates=range(10, 12))
    with pytest.raises(ValueError, match="expected 0 <= part < 3"):
        replicate_part(11, 3, 3)
