"""Correlated feature errors: shrinkage intensity, whitened misfits, evidence of duplicated features.

Known answers:

* one group: the intensity equals a plain transcription of Schäfer and Strimmer (2005),
  Eq. 14 with Appendix A (to rounding);
* equicorrelated Gaussian data: the expected intensity to first order is
  :math:`\\lambda \\approx [(1+\\rho^2)/n] / [\\rho^2 + (1-\\rho^2)^2/(n-1)]`
  (the variance of a mean of standardised products over the expected squared correlation);
* pooled group deviations with :math:`\\nu` degrees of freedom behave like one group of
  :math:`\\nu + 1` rows, whatever the group means;
* a whitened misfit of correlated Gaussian residuals is :math:`\\chi^2_k`;
* a feature duplicated with correlation :math:`\\rho` multiplies the evidence by
  :math:`2/(1+\\rho)` (not 2).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.stats

from dronewind.diagnose.covariance import MIN_EIGENVALUE, Whitener, flight_correlations, shrunk_correlation, whiten
from dronewind.diagnose.fitting import ParameterResponse, ResponseModel, chi2
from dronewind.diagnose.scoring import score_candidate


def _equicorrelated(p: int, rho: float) -> np.ndarray:
    r = np.full((p, p), rho)
    np.fill_diagonal(r, 1.0)
    return r


def _plain_schaefer_strimmer(x: np.ndarray) -> float:
    """Eq. 14 and Appendix A of Schäfer and Strimmer (2005), written out with loops."""
    n, p = x.shape
    xs = (x - x.mean(axis=0)) / x.std(axis=0, ddof=1)
    num = den = 0.0
    for i in range(p):
        for j in range(p):
            if i == j:
                continue
            w = xs[:, i] * xs[:, j]
            r = n / (n - 1) * w.mean()
            var = n / (n - 1) ** 3 * np.sum((w - w.mean()) ** 2)
            num += var
            den += r * r
    return min(1.0, max(0.0, num / den))


def test_intensity_of_one_group_is_the_published_formula():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(12, 5)) @ np.linalg.cholesky(_equicorrelated(5, 0.4)).T
    assert shrunk_correlation(x).intensity == pytest.approx(_plain_schaefer_strimmer(x), rel=1e-10)


def test_intensity_of_equicorrelated_gaussian_data():
    """Mean over 300 data sets of n = 40, p = 6, rho = 0.5: first-order expectation 0.118,
    measured 0.125. Monte Carlo error of the mean 0.002; the tolerance 0.02 covers the
    second-order terms (O(1/n) of the ratio of expectations). Independent data: the optimum is
    the identity (1); the estimate averages 0.9 (clipped at 1 from noisy estimates)."""
    rng = np.random.default_rng(11)
    p, rho, n = 6, 0.5, 40
    chol = np.linalg.cholesky(_equicorrelated(p, rho))
    lam = [shrunk_correlation(rng.normal(size=(n, p)) @ chol.T).intensity for _ in range(300)]
    expected = (1 + rho**2) / n / (rho**2 + (1 - rho**2) ** 2 / (n - 1))
    assert np.mean(lam) == pytest.approx(expected, abs=0.02)
    lam_indep = [shrunk_correlation(rng.normal(size=(n, p))).intensity for _ in range(100)]
    assert np.mean(lam_indep) > 0.8


def test_pooled_groups_behave_like_one_group_with_the_same_degrees_of_freedom():
    """8 groups of 5 rows (nu = 32) with large group means common to all features (which would
    correlate the features if they were not removed) against one group of 33 rows: mean
    intensity 0.150 both (measured); 400 data sets each, Monte Carlo error of the difference
    0.003, tolerance 0.012 (4 errors). The pooled correlation recovers rho."""
    rng = np.random.default_rng(5)
    p, rho = 6, 0.5
    chol = np.linalg.cholesky(_equicorrelated(p, rho))
    groups = np.repeat(np.arange(8), 5)
    pooled, single, r01 = [], [], []
    for _ in range(400):
        offsets = 5.0 * rng.normal(size=(8, 1)) * np.ones((1, p))
        est = shrunk_correlation(rng.normal(size=(40, p)) @ chol.T + offsets[groups], groups)
        pooled.append(est.intensity)
        r01.append(est.sample[0, 1])
        single.append(shrunk_correlation(rng.normal(size=(33, p)) @ chol.T).intensity)
        assert est.dof == 32
    assert np.mean(pooled) == pytest.approx(np.mean(single), abs=0.012)
    assert np.mean(r01) == pytest.approx(rho, abs=0.03)  # sd of r over nu = 32 is 0.13; mean of 400: 0.007


def test_constant_and_missing_features_are_uncorrelated_and_the_matrix_positive_definite():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(20, 5))
    x[:, 1] = x[:, 0] + 0.01 * rng.normal(size=20)  # nearly collinear with feature 0
    x[:, 3] = 2.0  # no scatter
    x[::3, 4] = np.nan  # missing values, dropped pairwise
    est = shrunk_correlation(x)
    assert est.matrix[3, [0, 1, 2, 4]] == pytest.approx(0.0)
    assert np.diag(est.matrix) == pytest.approx(1.0)
    assert np.linalg.eigvalsh(est.matrix).min() >= MIN_EIGENVALUE * 0.999
    assert est.sample[0, 1] > 0.99


def test_whitened_misfit_of_correlated_residuals_is_chi_square():
    """4000 draws of 8 correlated Gaussian features (random correlation, unequal errors),
    three features missing in every other draw: the whitened misfit has mean k (8 or 5)
    within 4 Monte Carlo errors sqrt(2k/N), and passes a KS test against chi2_k (p > 1e-3).
    The unwhitened sum of z^2 has the same mean but the variance 2 tr(R^2) > 2k."""
    rng = np.random.default_rng(7)
    p, n = 8, 4000
    a = rng.normal(size=(p, p))
    cov = a @ a.T + 0.5 * np.eye(p)
    d = np.sqrt(np.diag(cov))
    corr = cov / np.outer(d, d)
    sigma = np.tile(rng.uniform(0.5, 2.0, p), (n, 1))
    y = (rng.normal(size=(n, p)) @ np.linalg.cholesky(corr).T) * sigma
    y[1::2, [1, 4, 6]] = np.nan
    pred = np.zeros_like(y)
    full, part = chi2(y[::2], pred[::2], sigma[::2], corr), chi2(y[1::2], pred[1::2], sigma[1::2], corr)
    for value, k in ((full, p), (part, p - 3)):
        assert value.mean() == pytest.approx(k, abs=4 * np.sqrt(2 * k / value.size))
        assert scipy.stats.kstest(value, scipy.stats.chi2(k).cdf).pvalue > 1e-3
    # the diagonal misfit sum z^2 has variance 2 tr(R^2), not 2k: overdispersed by correlation
    naive = chi2(y[::2], pred[::2], sigma[::2])
    assert 2 * np.sum(corr**2) > 1.3 * 2 * p
    assert naive.var() == pytest.approx(2 * np.sum(corr**2), rel=0.15)  # sampling error of a variance, N = 2000


def test_whiten_leaves_independent_errors_unchanged():
    z = np.array([[1.0, np.nan, -2.0]])
    assert whiten(z, None) is z or np.array_equal(whiten(z, None), z, equal_nan=True)
    assert np.array_equal(whiten(z, np.eye(3)), z, equal_nan=True)


def test_batched_whitening_is_the_per_row_cholesky_solve():
    """Every row of the batched whitening (:meth:`Whitener.padded`) is :math:`L_i^{-1} z_i` over its used
    features, with the factor of that row's own sub-matrix: checked against a direct triangular
    solve for per-row correlations and four patterns of missing features, to rounding (1e-12)."""
    rng = np.random.default_rng(4)
    n, p = 7, 5
    a = rng.standard_normal((p, p))
    cov = a @ a.T + p * np.eye(p)
    corr = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    sigma = rng.uniform(0.5, 2.0, (n, p))
    _, per_row = flight_correlations(corr, sigma, rng.uniform(0.0, 1.0, p))
    z = rng.standard_normal((n, p))
    z[1, 2] = z[3, 0] = z[3, 4] = z[5, :4] = z[6, :] = np.nan
    for matrix in (corr, per_row):
        got = Whitener(matrix)(z)
        for i in range(n):
            use = np.isfinite(z[i])
            assert np.array_equal(np.isfinite(got[i]), use)
            if use.any():
                m = matrix[i] if matrix.ndim == 3 else matrix
                expected = np.linalg.solve(np.linalg.cholesky(m[np.ix_(use, use)]), z[i, use])
                np.testing.assert_allclose(got[i, use], expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("rho", [0.5, 0.9, 0.999])
def test_a_correlated_duplicate_feature_no_longer_doubles_the_evidence(rho):
    """One mechanism seen in one feature, then in that feature and its duplicate (identical
    values, errors correlated rho). Diagonal errors: the LR statistic doubles. Whitened: it is
    2/(1 + rho) times the single-feature one (exact for a linear response: both misfits are
    quadratic forms in the same residual), i.e. about the same evidence when rho -> 1."""
    rng = np.random.default_rng(1)
    n = 6
    levels = np.array([-1.0, 0.0, 1.0])
    base = np.zeros((n, 1))
    sig = np.linspace(0.5, 1.5, n)[:, None]
    table = base[:, None, :] + levels[None, :, None] * sig[:, None, :]
    y1 = 0.4 * sig + 0.3 * rng.normal(size=(n, 1))
    s1 = np.full((n, 1), 0.3)
    single = ResponseModel("m", base, [ParameterResponse("p", levels, table, 0.0, -3.0, 3.0)])
    dup = ResponseModel("m", np.hstack([base, base]),
                        [ParameterResponse("p", levels, np.concatenate([table, table], axis=2), 0.0, -3.0, 3.0)])
    y2, s2 = np.hstack([y1, y1]), np.hstack([s1, s1])
    corr = np.array([[1.0, rho], [rho, 1.0]])
    lr1 = score_candidate(single, y1, s1).lr_statistic
    lr_diag = score_candidate(dup, y2, s2).lr_statistic
    lr_white = score_candidate(dup, y2, s2, corr=corr).lr_statistic
    assert lr1 > 1.0
    assert lr_diag == pytest.approx(2.0 * lr1, rel=1e-5)
    assert lr_white == pytest.approx(2.0 / (1.0 + rho) * lr1, rel=1e-5)


def test_campaign_correlation_and_error_model_from_baseline_seeds():
    """Baseline runs whose features 0 and 1 share one series (correlation 0.8) and are
    otherwise independent: the pooled, shrunk correlation finds it; diagnosis.json states it."""
    from dronewind.diagnose.campaign import CampaignEvidence, error_model, feature_correlation
    from dronewind.diagnose.features import FEATURES

    rng = np.random.default_rng(4)
    n_flights, n_seeds, p = 4, 5, len(FEATURES)
    common = rng.normal(size=(n_flights, n_seeds))
    runs = rng.normal(size=(n_flights, n_seeds, p))
    runs[:, :, 1] = 0.8 * common + 0.6 * runs[:, :, 1]
    runs[:, :, 0] = common
    runs += 10.0 * rng.normal(size=(n_flights, 1, p))  # flight means: removed before pooling
    analytic = np.ones((n_flights, p))
    corr = feature_correlation(runs, analytic)
    assert corr is not None and corr.dof == n_flights * (n_seeds - 1)
    assert corr.sample[0, 1] == pytest.approx(0.8, abs=0.25)  # sd of r at nu = 16 and rho 0.8: 0.09
    assert corr.matrix[0, 1] == pytest.approx((1 - corr.intensity) * corr.sample[0, 1])
    zero = np.zeros((n_flights, p))
    ev = CampaignEvidence([f"f{i}" for i in range(n_flights)], zero, analytic, analytic, np.ones(p), zero, zero,
                          [{} for _ in range(n_flights)], correlation=corr, n_seeds=n_seeds)
    em = error_model(ev)
    assert em["n_seeds"] == 5 and em["dof"] == 16 and 0 <= em["shrinkage_intensity"] <= 1
    assert em["largest_correlations"][0]["features"] == [FEATURES[0], FEATURES[1]]
    assert feature_correlation(runs[:, :1], analytic) is None
