"""The exact piecewise-linear least squares of the diagnosis' fits, on problems with known answers.

The tabulated response of a mechanism is linear in each parameter between probe levels, so
the weighted misfit is a quadratic on each cell of the levels' grid:
:func:`dronewind.diagnose.fitting.piecewise_linear_least_squares` must return its global
minimum (checked against a dense grid and against closed forms), keep a parameter that
moves nothing at its baseline, and never do worse than the multi-start local optimiser it
replaces (:func:`dronewind.diagnose.fitting.bounded_least_squares`).
"""

from __future__ import annotations

import numpy as np
import pytest

from dronewind.diagnose.fitting import (
    ParameterResponse,
    ResponseModel,
    bounded_least_squares,
    fit_parameters,
    piecewise_linear_least_squares,
)


def _model(tables, levels, bounds, baseline):
    params = [ParameterResponse(f"p{k}", np.asarray(lv, float), t, 0.0, lo, hi)
              for k, (t, lv, (lo, hi)) in enumerate(zip(tables, levels, bounds, strict=True))]
    return ResponseModel("m", baseline, params)


def _residuals(model, y, sigma):
    flights = np.arange(y.shape[0])
    return lambda theta: ((y - model.predict(theta, flights)) / sigma).ravel()


def test_one_parameter_global_minimum_beyond_a_local_one():
    """A V-shaped response (|theta| in one feature, theta in another) whose misfit has a local
    minimum near the baseline and the global one in the extrapolated segment: the exact
    solver finds the global one, at the closed-form value."""
    levels = np.array([-1.0, 0.0, 1.0])
    base = np.zeros((1, 2))
    # feature 0 = |theta| * 1, feature 1 = theta * 0.2: tabulated at the levels
    table = np.array([[[1.0, -0.2], [0.0, 0.0], [1.0, 0.2]]])
    model = _model([table], [levels], [(-5.0, 5.0)], base)
    y = np.array([[3.0, -0.6]])  # exactly theta = -3 (extrapolated), misfit 0
    sigma = np.ones_like(y)
    theta, std, value, ok, _ = piecewise_linear_least_squares(_residuals(model, y, sigma), model.parameters)
    assert ok
    assert theta[0] == pytest.approx(-3.0, abs=1e-12)
    assert value == pytest.approx(0.0, abs=1e-20)
    # standard error from the cell's Jacobian: 1 / sqrt(1 + 0.2^2)
    assert std[0] == pytest.approx(1 / np.sqrt(1.04), rel=1e-9)


def test_two_parameters_match_the_dense_grid_and_the_bounds():
    """Two parameters with kinks at the levels: the exact minimum is at most the best point of
    a dense grid (to rounding), inside the bounds, and a bound binds where it must."""
    rng = np.random.default_rng(3)
    n_flights, n_feat = 4, 5
    levels = [np.array([-2.0, 0.0, 1.0, 3.0]), np.array([0.5, 1.0, 1.4])]
    bounds = [(-4.0, 4.0), (0.3, 1.6)]
    base = rng.normal(0, 1, (n_flights, n_feat))
    tables = []
    for lv, b0 in zip(levels, (0.0, 1.0), strict=True):
        t = base[:, None, :] + rng.normal(0, 1, (n_flights, lv.size, n_feat))
        t[:, np.argmin(np.abs(lv - b0)), :] = base
        tables.append(t)
    params = [ParameterResponse("a", levels[0], tables[0], 0.0, *bounds[0]),
              ParameterResponse("g", levels[1], tables[1], 1.0, *bounds[1])]
    model = ResponseModel("m", base, params)
    y = base + rng.normal(0, 1, base.shape)
    sigma = np.full_like(y, 0.7)
    res = _residuals(model, y, sigma)
    theta, _, value, _, _ = piecewise_linear_least_squares(res, params)
    assert bounds[0][0] <= theta[0] <= bounds[0][1] and bounds[1][0] <= theta[1] <= bounds[1][1]
    assert value == pytest.approx(float(res(theta) @ res(theta)), rel=1e-12)
    grid = [(a, g) for a in np.linspace(*bounds[0], 97) for g in np.linspace(*bounds[1], 40)]
    assert value <= min(float(res(np.array(p)) @ res(np.array(p))) for p in grid) + 1e-9
    # the local optimiser from its starts does no better
    assert value <= bounded_least_squares(res, params)[2] + 1e-9


def test_a_parameter_that_moves_nothing_stays_at_its_baseline():
    """The second parameter's table equals the baseline at every level: it is not moved (a
    local optimiser may leave it anywhere), and the first is fitted as alone."""
    levels = np.array([-1.0, 0.0, 1.0])
    base = np.zeros((2, 1))
    moving = np.array([[[-1.0], [0.0], [1.0]], [[-2.0], [0.0], [2.0]]])
    still = np.zeros((2, 3, 1))
    model = _model([moving, still], [levels, levels], [(-3, 3), (-3, 3)], base)
    y = np.array([[0.5], [1.0]])
    theta, _, value, _, _ = piecewise_linear_least_squares(_residuals(model, y, np.ones_like(y)), model.parameters)
    assert theta == pytest.approx([0.5, 0.0], abs=1e-12)
    assert value == pytest.approx(0.0, abs=1e-20)


@pytest.mark.parametrize("seed", range(6))
def test_never_worse_than_the_multistart_local_fit(seed):
    """Random three-parameter tables (mount-like: levels on both sides, wide bounds) with NaN
    where a probe level is missing: fit_parameters' exact minimum is at most the local
    optimiser's from every start."""
    rng = np.random.default_rng(100 + seed)
    n_flights, n_feat = 6, 8
    base = rng.normal(0, 1, (n_flights, n_feat))
    params = []
    for k, half in enumerate((4.0, 4.0, 6.0)):
        lv = np.array([-half, 0.0, half])
        t = base[:, None, :] + rng.normal(0, 0.5, (n_flights, 3, n_feat)) * np.array([1, 0, 1])[None, :, None]
        if k == 2:
            t[0, 2, 3] = np.nan  # a level this flight could not take
        params.append(ParameterResponse(f"p{k}", lv, t, 0.0, -3 * half, 3 * half))
    model = ResponseModel("m", base, params)
    y = model.predict(rng.uniform(-6, 6, 3), np.arange(n_flights)) + rng.normal(0, 0.3, base.shape)
    sigma = np.full_like(y, 0.3)
    fit = fit_parameters(model, y, sigma, np.arange(n_flights))
    flights = np.arange(n_flights)
    mask = np.isfinite(y)

    def res(theta):
        z = (y - model.predict(theta, flights)) / sigma
        return np.where(np.isfinite(z), z, 0.0)[mask]

    local = bounded_least_squares(res, params)
    assert fit.chi2 <= local[2] + 1e-9
    assert fit.chi2 == pytest.approx(float(res(fit.theta) @ res(fit.theta)), rel=1e-10)


@pytest.mark.parametrize("missing", [False, True])
def test_fits_from_the_tables_equal_fits_from_probed_residuals(missing):
    """:func:`fit_parameters` reads each cell's linear form from the response tables; probing
    the residual function (the generic path) gives the same fit to rounding (1e-9), with
    correlated errors and missing measurements, and with a missing table value at a used
    feature (where the tables cannot be used and the fit probes)."""
    from dronewind.diagnose.covariance import Whitener

    rng = np.random.default_rng(9)
    n, p = 6, 4
    levels = [[-2.0, 0.0, 1.0, 3.0], [0.5, 1.0, 1.5]]
    baseline = rng.normal(0, 1, (n, p))
    tables = []
    for lv in levels:
        t = baseline[:, None, :] + rng.normal(0, 0.6, (n, len(lv), p))
        t[:, int(np.argmin(np.abs(np.asarray(lv) - (1.0 if lv[0] > 0 else 0.0)))), :] = baseline
        tables.append(t)
    params = [ParameterResponse("a", np.asarray(levels[0]), tables[0], 0.0, -3.0, 4.0),
              ParameterResponse("b", np.asarray(levels[1]), tables[1], 1.0, 0.2, 2.0)]
    model = ResponseModel("m", baseline, params)
    if missing:
        tables[1][2, 2, 1] = np.nan  # on the segment above the truth: y stays measured there
    y = model.predict([1.7, 0.8], np.arange(n)) + rng.normal(0, 0.3, (n, p))
    y[4, 3] = np.nan
    sigma = rng.uniform(0.2, 0.5, (n, p))
    a = rng.normal(0, 1, (p, p))
    cov = a @ a.T + p * np.eye(p)
    white = Whitener(cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov))))
    flights = np.arange(n)
    fit = fit_parameters(model, y, sigma, flights, white)
    mask = np.isfinite(y) & (sigma > 0)
    factors = white.padded(mask)

    def probed(theta):
        from dronewind.diagnose.fitting import standardised_residuals

        z = standardised_residuals(y, model.predict(theta, flights), sigma)
        return np.einsum("ipq,iq->ip", factors, np.where(mask, z, 0.0))[mask]

    theta, _, value, _, _ = piecewise_linear_least_squares(probed, model.parameters)
    np.testing.assert_allclose(fit.theta, theta, rtol=1e-9, atol=1e-9)
    assert fit.chi2 == pytest.approx(value, rel=1e-9)
