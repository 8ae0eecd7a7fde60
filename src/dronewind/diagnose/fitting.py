r"""Fitting catalog mechanisms to per-flight residual features, and scoring them honestly.

The diagnosis compares, flight by flight, a vector of *features* measured on processed
data (ratios of drone to mast standard deviations, spectral ratios, direction and tilt
differences, lags, energy at the pendulum frequency, ...) with what the forward model
predicts for the same flight. The forward model is the simulator; its response to a
mechanism is tabulated by simulating every flight at a few parameter *levels* with common
random numbers (same seed as the baseline), so the table isolates the mechanism's effect
from sampling noise. This module is the statistics on top of those tables:

* :class:`ResponseModel` interpolates the tabulated responses: piecewise linear in each
  parameter, effects of the parameters of one mechanism added (first-order
  superposition about the baseline);
* :func:`fit_parameters` estimates a mechanism's parameters by bounded weighted least
  squares over a set of flights; the model is linear in the parameters between probe
  levels, so the misfit is a quadratic on each cell of the levels' grid and
  :func:`piecewise_linear_least_squares` takes the exact minimum of every cell (the global
  minimum, not a local one);
* :mod:`dronewind.diagnose.scoring` cross-validates the fits and groups candidates the data
  cannot tell apart.

Misfit: :math:`\chi^2 = \sum_i z_i^\top R^{-1} z_i` with
:math:`z_{if} = (y_{if} - \hat y_{if}) / s_{if}`, :math:`s_{if}` the residual standard
error of feature :math:`f` of flight :math:`i` (Ghirardelli et al. 2025, Eqs 10-13 for variance-type
features, calibrated by the baseline seeds; see :mod:`dronewind.diagnose.campaign`) and
:math:`R` the feature correlation matrix (:mod:`dronewind.diagnose.covariance`; the
identity when ``corr`` is None, which is the sum of squared z-scores). Every function that
takes ``corr`` whitens with it: the least squares fit (residuals :math:`L^{-1} z_i`, so the
parameter errors from the Jacobian account for the correlation), the likelihood-ratio
statistic, the held-out misfits and gain, and the distinguishability of candidates.
"""

from __future__ import annotations

import bisect
import functools
import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize
import scipy.stats

from dronewind.diagnose.covariance import Whitener

__all__ = [
    "ParameterResponse",
    "ResponseModel",
    "FitResult",
    "chi2",
    "standardised_residuals",
    "bounded_least_squares",
    "piecewise_linear_least_squares",
    "fit_parameters",
    "tabulated",
    "linear_cells",
    "unbounded_floor",
    "solve_cell",
]


@dataclass(frozen=True)
class ParameterResponse:
    """Simulated features of every flight at several levels of one parameter.

    Attributes
    ----------
    name : str
        Parameter name (e.g. ``lag_s``).
    levels : numpy.ndarray
        Parameter values, strictly increasing, including the baseline value (shape ``(k,)``).
    features : numpy.ndarray
        Feature values, shape ``(n_flights, k, n_features)``.
    baseline_level : float
        The level at which the mechanism is off (0 for most, 1 for gains).
    lower, upper : float
        Physical bounds of the parameter for fitting.
    """

    name: str
    levels: np.ndarray
    features: np.ndarray
    baseline_level: float
    lower: float
    upper: float

    def __post_init__(self) -> None:
        levels = np.asarray(self.levels, dtype=float)
        if levels.ndim != 1 or levels.size < 2 or np.any(np.diff(levels) <= 0):
            raise ValueError(f"{self.name}: levels must be strictly increasing with at least two values")
        if not np.any(np.isclose(levels, self.baseline_level)):
            raise ValueError(f"{self.name}: levels must include the baseline level {self.baseline_level}")
        if self.features.ndim != 3 or self.features.shape[1] != levels.size:
            raise ValueError(f"{self.name}: features must have shape (n_flights, {levels.size}, n_features)")

    # What effect() needs at every call, worked out once: the fits call it tens of thousands of times.

    @functools.cached_property
    def level_list(self) -> list[float]:
        """:attr:`levels` as floats [its unit]."""
        return [float(x) for x in np.asarray(self.levels, dtype=float)]

    @functools.cached_property
    def base_index(self) -> int:
        """Index of the baseline level in :attr:`levels`."""
        return int(np.argmin(np.abs(np.asarray(self.levels, dtype=float) - self.baseline_level)))

    def effect(self, value: float, flights: np.ndarray) -> np.ndarray:
        """Feature change against the baseline at ``value`` for the given flights.

        Piecewise-linear interpolation between levels, linear extrapolation beyond the
        outermost levels (the fit is bounded, so this stays within physical ranges).

        Parameters
        ----------
        value : float
            Parameter value [its unit].
        flights : numpy.ndarray
            Integer indices of the flights.

        Returns
        -------
        numpy.ndarray
            Shape ``(len(flights), n_features)``.
        """
        levels, base_index = self.level_list, self.base_index
        # the segment: numpy's searchsorted (left side) - 1, clipped to the segments; NaN sorts last
        k = bisect.bisect_left(levels, value) if value == value else len(levels)
        j = min(max(k - 1, 0), len(levels) - 2)
        w = (value - levels[j]) / (levels[j + 1] - levels[j])
        at_value = self.features[flights, j, :] * (1.0 - w) + self.features[flights, j + 1, :] * w
        return at_value - self.features[flights, base_index, :]

    def effects(self, values: np.ndarray) -> np.ndarray:
        """:meth:`effect` of every flight at each of several values (the replicates of a bootstrap).

        Parameters
        ----------
        values : numpy.ndarray
            (B,) [its unit].

        Returns
        -------
        numpy.ndarray
            (B, n_flights, n_features): row b is ``effect(values[b], all flights)``, number for number.
        """
        levels = np.asarray(self.level_list)
        # the segment of effect(): searchsorted (left side) - 1, clipped to the segments; NaN sorts last
        j = np.clip(np.searchsorted(levels, values, side="left") - 1, 0, levels.size - 2)
        w = ((values - levels[j]) / (levels[j + 1] - levels[j]))[:, None, None]
        f = self.features
        at_value = f[:, j, :].transpose(1, 0, 2) * (1.0 - w) + f[:, j + 1, :].transpose(1, 0, 2) * w
        return at_value - f[None, :, self.base_index, :]

    def linear_intervals(self) -> list[tuple[float, float]]:
        """The parameter intervals on which :meth:`effect` is linear, within the bounds [its unit].

        Segment ``j`` lies between levels ``j`` and ``j + 1``; the first and the last reach
        the bounds, as :meth:`effect` extrapolates their lines.
        """
        return [(lo, hi) for _, lo, hi in self.linear_segments()]

    def linear_segments(self) -> list[tuple[int, float, float]]:
        """:meth:`linear_intervals` with the index ``j`` of the segment each lies on."""
        levels = np.asarray(self.levels, dtype=float)
        edges = [-np.inf, *levels[1:-1], np.inf]
        out = []
        for j, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
            lo, hi = max(a, self.lower), min(b, self.upper)
            if lo <= hi:
                out.append((j, float(lo), float(hi)))
        return out

    def segment_line(self, j: int, flights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Intercept and slope of :meth:`effect` on segment ``j``: ``effect(v) = a + b v`` there.

        Returns
        -------
        a, b : numpy.ndarray
            (len(flights), n_features) [feature units, feature units per parameter unit]; NaN
            where :meth:`effect` is NaN on the segment.
        """
        levels = self.level_list
        f = self.features[flights]
        slope = (f[:, j + 1, :] - f[:, j, :]) / (levels[j + 1] - levels[j])
        return f[:, j, :] - levels[j] * slope - f[:, self.base_index, :], slope


@dataclass
class ResponseModel:
    """The forward model's features for one mechanism as a function of its parameters.

    Attributes
    ----------
    mechanism : str
        Catalog name.
    baseline : numpy.ndarray
        Baseline (no mechanism) features, shape ``(n_flights, n_features)``.
    parameters : list of ParameterResponse
        One table per parameter (empty for ``none``).
    """

    mechanism: str
    baseline: np.ndarray
    parameters: list[ParameterResponse] = field(default_factory=list)

    @property
    def n_parameters(self) -> int:
        """Number of fitted parameters."""
        return len(self.parameters)

    def predict(self, theta: Sequence[float] | np.ndarray, flights: np.ndarray) -> np.ndarray:
        """Predicted features of ``flights`` for parameter vector ``theta``.

        Parameters
        ----------
        theta : sequence of float or numpy.ndarray
            One value per parameter, in :attr:`parameters` order.
        flights : numpy.ndarray
            Integer flight indices.

        Returns
        -------
        numpy.ndarray
            Shape ``(len(flights), n_features)``.
        """
        out = np.array(self.baseline[flights], dtype=float, copy=True)
        for value, response in zip(theta, self.parameters, strict=True):
            out += response.effect(float(value), flights)
        return out

    def predict_each(self, theta: np.ndarray) -> np.ndarray:
        """:meth:`predict` of every flight for each of several parameter vectors (the replicates of a bootstrap).

        Parameters
        ----------
        theta : numpy.ndarray
            (B, m) [parameter units].

        Returns
        -------
        numpy.ndarray
            (B, n_flights, n_features): row b is ``predict(theta[b], all flights)``, number for number.
        """
        out = np.repeat(np.asarray(self.baseline, dtype=float)[None], theta.shape[0], axis=0)
        for k, response in enumerate(self.parameters):
            out += response.effects(theta[:, k])
        return out

    def baseline_theta(self) -> np.ndarray:
        """Parameter vector at which the mechanism is off."""
        return np.array([p.baseline_level for p in self.parameters], dtype=float)


def standardised_residuals(y: np.ndarray, prediction: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """:math:`z = (y - \\hat y)/s` over the measured features, NaN where a feature is not used.

    A feature is used where ``y`` and ``sigma`` are finite and ``sigma`` > 0; where the
    forward model cannot produce a used feature (NaN prediction) its residual is 0: no misfit.
    """
    use = np.isfinite(y) & np.isfinite(sigma) & (sigma > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        z = (y - prediction) / np.where(use, sigma, 1.0)
    return np.where(use, np.where(np.isfinite(z), z, 0.0), np.nan)


def chi2(y: np.ndarray, prediction: np.ndarray, sigma: np.ndarray,
         corr: np.ndarray | Whitener | None = None) -> np.ndarray:
    """Per-flight misfit :math:`z_i^\\top R^{-1} z_i`, ignoring missing features.

    Parameters
    ----------
    y, prediction, sigma : numpy.ndarray
        Shape ``(n_flights, n_features)``; NaN in ``y`` or ``sigma`` marks a feature
        that could not be measured for that flight.
    corr : numpy.ndarray or Whitener, optional
        Feature correlation matrix (or its :class:`~dronewind.diagnose.covariance.Whitener`);
        None: independent errors, :math:`\\sum_f z_f^2`.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_flights,)``.
    """
    e = _whitener(corr)(standardised_residuals(y, prediction, sigma))
    return np.nansum(e * e, axis=1)


def _whitener(corr: np.ndarray | Whitener | None) -> Whitener:
    return corr if isinstance(corr, Whitener) else Whitener(corr)


@dataclass(frozen=True)
class FitResult:
    """Outcome of :func:`fit_parameters`."""

    theta: np.ndarray
    theta_std: np.ndarray
    chi2: float
    chi2_baseline: float
    converged: bool
    message: str


def bounded_least_squares(
    residuals: Callable[[np.ndarray], np.ndarray], parameters: Sequence[ParameterResponse]
) -> tuple[np.ndarray, np.ndarray, float, bool, str]:
    """Multi-start bounded least squares over tabulated mechanism parameters.

    Starts at the baseline (mechanism off) and at every probe level of every parameter,
    because a tabulated response can be non-monotonic (e.g. a lag beyond the search
    window) and a single local start could stop at a poor optimum.

    Parameters
    ----------
    residuals : callable
        Parameter vector -> weighted residuals (finite).
    parameters : sequence of ParameterResponse
        Levels, baseline level and physical bounds per parameter.

    Returns
    -------
    theta, theta_std : numpy.ndarray
        Estimate and standard errors (Jacobian at the optimum, scaled by the reduced misfit
        when it exceeds 1).
    chi2 : float
        Misfit at the optimum.
    success : bool
    message : str
    """
    base = np.array([p.baseline_level for p in parameters], dtype=float)
    lower = np.array([p.lower for p in parameters])
    upper = np.array([p.upper for p in parameters])
    starts = [base]
    for k, p in enumerate(parameters):
        for level in p.levels:
            if not np.isclose(level, p.baseline_level):
                start = base.copy()
                start[k] = np.clip(level, p.lower, p.upper)
                starts.append(start)
    best = None
    for start in starts:
        res = scipy.optimize.least_squares(residuals, np.clip(start, lower, upper), bounds=(lower, upper),
                                           method="trf", x_scale="jac")
        if best is None or res.cost < best.cost:
            best = res
    assert best is not None
    value = float(2.0 * best.cost)
    dof = max(best.fun.size - len(parameters), 1)
    try:
        cov = np.linalg.pinv(best.jac.T @ best.jac)
        std = np.sqrt(np.clip(np.diag(cov), 0, None) * max(1.0, value / dof))
    except np.linalg.LinAlgError:
        std = np.full(len(parameters), np.nan)
    return best.x, std, value, bool(best.success), str(best.message)


def _probe_point(lo: float, hi: float, level_span: float) -> tuple[float, float]:
    """A point inside ``[lo, hi]`` and a step that stays inside, for a linear cell."""
    if np.isfinite(lo) and np.isfinite(hi):
        return (lo + hi) / 2.0, (hi - lo) / 4.0
    if np.isfinite(lo):
        return lo + level_span, level_span / 2.0
    if np.isfinite(hi):
        return hi - level_span, level_span / 2.0
    return 0.0, level_span / 2.0


def linear_cells(parameters: Sequence[ParameterResponse]
                 ) -> list[tuple[tuple[int, ...], np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """The cells of :func:`piecewise_linear_least_squares`: every combination of the parameters' linear segments.

    Returns
    -------
    list of (segments, lo, hi, centre, steps)
        The segment index of every parameter (:meth:`ParameterResponse.linear_segments`), the
        cell's bounds (m,), a point inside it and a step along each parameter that stays inside
        (m,), in the order of ``itertools.product`` over the parameters' segments.
    """
    spans = [float(np.ptp(np.asarray(p.levels, dtype=float))) or 1.0 for p in parameters]
    out = []
    for cell in itertools.product(*(p.linear_segments() for p in parameters)):
        points = [_probe_point(a, b, s) for (_, a, b), s in zip(cell, spans, strict=True)]
        out.append((tuple(c[0] for c in cell), np.array([c[1] for c in cell]), np.array([c[2] for c in cell]),
                    np.array([c for c, _ in points]), np.array([h for _, h in points])))
    return out


def _cell_floors(forms: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]
                 ) -> tuple[list[int], np.ndarray]:
    """Order in which to solve the cells, and a lower bound of each cell's bounded misfit.

    The bounded minimum of a cell's quadratic is at least its unbounded minimum
    :math:`|r_0|^2 - g^\top G^{+} g` (:math:`G = J^\top J`, :math:`g = J^\top r_0`). Solving the
    cells in increasing order of that bound, a cell whose bound exceeds the best bounded misfit
    found so far, and every later one, cannot hold the minimum (branch and bound): the
    bounded solver then runs on a few cells instead of all of them. With one parameter the
    bounded solve is a clipped division, and the cells keep their order (bounds of -inf).

    Returns
    -------
    order : list of int
        Cell indices in solving order.
    floor : numpy.ndarray
        Lower bound of every cell's misfit, lowered by a relative 1e-9 (and 1e-12 absolute)
        for rounding, so that no cell whose minimum ties the best is skipped wrongly.
    """
    n_par = forms[0][4].shape[1] if forms else 0
    if n_par < 2:
        return list(range(len(forms))), np.full(len(forms), -np.inf)
    floor = unbounded_floor(np.stack([f[3] for f in forms]), np.stack([f[4] for f in forms]))
    return [int(c) for c in np.argsort(floor, kind="stable")], floor


def unbounded_floor(r0: np.ndarray, jac: np.ndarray) -> np.ndarray:
    r"""Lower bound of a cell's bounded misfit: its unbounded minimum :math:`|r_0|^2 - g^\top G^{+} g`.

    Parameters
    ----------
    r0 : numpy.ndarray
        Residuals at the cell's centre (..., N).
    jac : numpy.ndarray
        Their Jacobian (..., N, m).

    Returns
    -------
    numpy.ndarray
        (...): the minimum lowered by a relative 1e-9 and 1e-12 absolute (rounding, :func:`_cell_floors`).
    """
    g = np.einsum("...ik,...i->...k", jac, r0)
    step = np.einsum("...kl,...l->...k", np.linalg.pinv(np.einsum("...ik,...il->...kl", jac, jac)), g)
    floor = np.einsum("...i,...i->...", r0, r0) - np.einsum("...k,...k->...", g, step)
    return floor - 1e-9 * np.abs(floor) - 1e-12


def solve_cell(lo: np.ndarray, hi: np.ndarray, centre: np.ndarray, r0: np.ndarray, jac: np.ndarray,
               base: np.ndarray) -> tuple[np.ndarray, float]:
    """Bounded linear least squares on one cell of :func:`piecewise_linear_least_squares`.

    Parameters
    ----------
    lo, hi : numpy.ndarray
        The cell's bounds of every parameter (m,).
    centre : numpy.ndarray
        The point the cell's linear form is taken at (m,).
    r0, jac : numpy.ndarray
        Residuals at ``centre`` (N,) and their Jacobian (N, m): ``r(theta) = r0 + J (theta - centre)``.
    base : numpy.ndarray
        Baseline level of every parameter (m,).

    Returns
    -------
    theta : numpy.ndarray
        The minimiser within the bounds (``scipy.optimize.lsq_linear``'s bounded-variable least
        squares, or the clipped normal equation for one moving parameter); a parameter that moves
        no residual stays at the point of its interval nearest the baseline level.
    value : float
        :math:`|r(\theta)|^2` from the linear form (the residuals are linear on the cell).
    """
    norms = np.sqrt(np.sum(jac * jac, axis=0))
    moving = norms > 1e-12 * max(float(norms.max(initial=0.0)), 1e-300)
    theta = np.clip(base, lo, hi)  # a parameter that moves nothing: nearest its baseline
    if moving.any():
        j, rhs = jac[:, moving], -(r0 + jac[:, ~moving] @ (theta[~moving] - centre[~moving]))
        d_lo, d_hi = lo[moving] - centre[moving], hi[moving] - centre[moving]
        if j.shape[1] == 1:
            d = np.clip(float(j[:, 0] @ rhs) / float(j[:, 0] @ j[:, 0]), d_lo, d_hi)
        else:
            d = scipy.optimize.lsq_linear(j, rhs, bounds=(d_lo, d_hi), method="bvls").x
        theta[moving] = np.clip(centre[moving] + d, lo[moving], hi[moving])
    r = r0 + jac @ (theta - centre)
    return theta, float(r @ r)


def piecewise_linear_least_squares(
    residuals: Callable[[np.ndarray], np.ndarray], parameters: Sequence[ParameterResponse],
    cell_form: Callable[[tuple[int, ...]], tuple[np.ndarray, np.ndarray]] | None = None,
) -> tuple[np.ndarray, np.ndarray, float, bool, str]:
    """Exact bounded least squares for residuals linear in each parameter between its levels.

    The tabulated model (:meth:`ResponseModel.predict`) is linear in every parameter on
    each segment between two probe levels (the outer segments extended to the bounds), and
    the parameters' effects add; residuals linear in the prediction (weighted, whitened)
    are therefore linear on every cell of the grid of segments, and the misfit is a
    quadratic there. Each cell is solved exactly (bounded linear least squares,
    ``scipy.optimize.lsq_linear`` with the cell's bounds, or the clipped normal equation
    for one parameter) and the least misfit over the cells is the global minimum. The
    residuals are evaluated at a point inside each cell and one step along each
    parameter, so the cell's linear form is read off the residual function itself.

    A general local optimiser from a few starts (:func:`bounded_least_squares`) finds the
    same minimum when it finds the right basin; this gives it with a fixed number of
    residual evaluations (cells x (parameters + 1)) and no start dependence.

    Parameters
    ----------
    residuals : callable
        Parameter vector -> weighted residuals (finite), linear on each cell.
    parameters : sequence of ParameterResponse
        Levels, baseline level and physical bounds per parameter.
    cell_form : callable, optional
        Segment index of every parameter (:meth:`ParameterResponse.linear_segments`) ->
        ``(r_0, J)``: the residuals at parameter vector 0 and their Jacobian on that cell
        (``residuals(theta) = r_0 + J theta`` there). Given, the cells' linear forms are taken
        from it instead of from residual evaluations (:func:`fit_parameters` builds it from
        the tables); the winner's misfit is still evaluated with ``residuals``.

    Returns
    -------
    theta, theta_std : numpy.ndarray
        Estimate and standard errors (the cell's Jacobian, scaled by the reduced misfit
        when it exceeds 1, as in :func:`bounded_least_squares`). A parameter that moves
        no residual in the winning cell stays at the point of its interval nearest the
        baseline level.
    chi2 : float
        Misfit at the optimum.
    success : bool
        Always true (the minimum is exact).
    message : str
    """
    base = np.array([p.baseline_level for p in parameters], dtype=float)
    forms = []
    grid = linear_cells(parameters)
    for segments, lo, hi, centre, steps in grid:
        if cell_form is not None:
            at_zero, jac = cell_form(segments)
            r0 = at_zero + jac @ centre
        else:
            r0 = np.asarray(residuals(centre), dtype=float)
            jac = np.empty((r0.size, len(parameters)))
            for k, h in enumerate(steps):
                step = centre.copy()
                step[k] += h
                jac[:, k] = (np.asarray(residuals(step), dtype=float) - r0) / h
        forms.append((lo, hi, centre, r0, jac))
    order, floor = _cell_floors(forms)
    best: tuple[float, np.ndarray, np.ndarray] | None = None
    for c in order:
        if best is not None and floor[c] > best[0]:
            break  # no later cell can do better than its unbounded minimum
        lo, hi, centre, r0, jac = forms[c]
        theta, value = solve_cell(lo, hi, centre, r0, jac, base)
        if best is None or value < best[0]:
            best = (value, theta, jac)
    assert best is not None
    _, theta, jac = best
    r = np.asarray(residuals(theta), dtype=float)  # the winner's misfit evaluated, not extrapolated
    value = float(r @ r)
    dof = max(r.size - len(parameters), 1)
    try:
        cov = np.linalg.pinv(jac.T @ jac)
        std = np.sqrt(np.clip(np.diag(cov), 0, None) * max(1.0, value / dof))
    except np.linalg.LinAlgError:
        std = np.full(len(parameters), np.nan)
    return theta, std, value, True, f"exact minimum over {len(grid)} linear cells"


def fit_parameters(model: ResponseModel, y: np.ndarray, sigma: np.ndarray, flights: np.ndarray,
                   corr: np.ndarray | Whitener | None = None) -> FitResult:
    """Bounded weighted least-squares estimate of a mechanism's parameters.

    Parameters
    ----------
    model : ResponseModel
        Tabulated responses.
    y : numpy.ndarray
        Measured features, shape ``(n_flights_total, n_features)``.
    sigma : numpy.ndarray
        Their standard errors, same shape.
    flights : numpy.ndarray
        Indices of the flights to fit.
    corr : numpy.ndarray or Whitener, optional
        Feature correlation matrix: the residuals are whitened with it (module docstring).

    Returns
    -------
    FitResult
        Parameters, their standard errors (from the Jacobian at the optimum, scaled by
        the reduced misfit when it exceeds 1), the misfit and the baseline misfit.
    """
    white = _whitener(corr)
    base_theta = model.baseline_theta()
    base_chi2 = float(chi2(y[flights], model.predict(base_theta, flights), sigma[flights], white.subset(flights)).sum())
    if model.n_parameters == 0:
        return FitResult(base_theta, base_theta, base_chi2, base_chi2, True, "no parameters")
    yf, sf = y[flights], sigma[flights]
    mask = np.isfinite(yf) & np.isfinite(sf) & (sf > 0)
    factors = white.subset(flights).padded(mask) if white.corr is not None else None

    def whiten_used(v: np.ndarray) -> np.ndarray:
        """Whitened standardised values (n, p) (zero where not used), as one vector of the used ones."""
        return (v if factors is None else np.einsum("ipq,iq->ip", factors, v))[mask]

    def residuals(theta: np.ndarray) -> np.ndarray:
        # a feature the forward model cannot produce at this flight counts as no misfit
        z = standardised_residuals(yf, model.predict(theta, flights), sf)
        return whiten_used(np.where(mask, z, 0.0))

    theta, theta_std, value, success, message = piecewise_linear_least_squares(
        residuals, model.parameters, _tabulated_cell_form(model, yf, sf, flights, mask, whiten_used))
    return FitResult(theta, theta_std, value, base_chi2, success, message)


def _tabulated_cell_form(model: ResponseModel, yf: np.ndarray, sf: np.ndarray, flights: np.ndarray,
                         mask: np.ndarray, whiten_used: Callable[[np.ndarray], np.ndarray]
                         ) -> Callable[[tuple[int, ...]], tuple[np.ndarray, np.ndarray]] | None:
    """The residuals' linear form on every cell, read from the response tables (``cell_form`` of
    :func:`piecewise_linear_least_squares`).

    On a cell every parameter's effect is the line :meth:`ParameterResponse.segment_line`, so the
    whitened residuals are ``W((y - baseline - sum a_k) / s) - sum_k theta_k W(b_k / s)``. The
    lines of every segment are whitened once per fit; a cell then costs a few additions where
    the probing of the residual function cost ``m + 1`` evaluations. None (probe instead) where
    a used feature's baseline or table value is missing (:func:`tabulated`).

    ``yf`` and ``sf`` may carry leading axes of independent campaigns that share ``mask`` (the
    replicates of a bootstrap, :func:`dronewind.diagnose.replicates.fit`), with ``whiten_used``
    keeping them: the form's residuals (..., N) and Jacobian (..., N, m) then have them too.
    """
    if not tabulated(model, flights, mask):
        return None
    scale = np.where(mask, sf, 1.0)

    def whitened(v: np.ndarray) -> np.ndarray:
        return whiten_used(np.where(mask, v / scale, 0.0))

    start = whitened(yf - model.baseline[flights])
    lines = []
    for par in model.parameters:
        per_segment = {}
        for j, _, _ in par.linear_segments():
            a, b = par.segment_line(j, flights)
            per_segment[j] = (whitened(a), -whitened(b))
        lines.append(per_segment)

    def form(segments: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
        at_zero = start.copy()
        jac = np.empty((*start.shape, len(segments)))
        for k, j in enumerate(segments):
            a_w, b_w = lines[k][j]
            at_zero -= a_w
            jac[..., k] = b_w
        return at_zero, jac

    return form


def tabulated(model: ResponseModel, flights: np.ndarray, mask: np.ndarray) -> bool:
    """Whether a candidate's fit reads its cells off the tables (:func:`_tabulated_cell_form`): it has
    a parameter, and its baseline and every table are finite on the used features ``mask``
    (len(flights), p); a missing prediction counts as no misfit, which is not linear across the cells."""
    if model.n_parameters == 0:
        return False
    return bool(np.isfinite(model.baseline[flights][mask]).all()) and not any(
        (~np.isfinite(par.features[flights]) & mask[:, None, :]).any() for par in model.parameters)
