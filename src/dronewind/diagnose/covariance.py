r"""Correlated feature errors: a shrunk correlation matrix and whitening of residuals.

The residual features of one flight are not independent: :math:`\ln(\sigma_w)` ratio,
the drone's :math:`S_w/S_u`, the pendulum-band and the high-frequency w power all come
from one w series, so their sampling errors are correlated. A misfit that sums squared
z-scores as if they were independent counts one realisation's excursion several times.
This module estimates the feature correlation matrix from the forward model's baseline
seeds and whitens residuals with it.

Estimate
--------
The baseline seeds of a flight differ only by the turbulence realisation, so their
deviations from the flight's seed mean sample the realisation-to-realisation error. With
:math:`x_{gs,j}` the value of feature :math:`j` of seed :math:`s` of flight (group)
:math:`g`, divided by the feature's analytic error so that flights can be pooled, the
deviations :math:`d_{gs,j} = x_{gs,j} - \bar x_{g,j}` give, pooled over groups,

.. math::

    \hat s_j^2 = \frac{1}{\nu_{jj}} \sum_{g,s} d_{gs,j}^2, \qquad
    w_{gs,ij} = \frac{d_{gs,i}\, d_{gs,j}}{\hat s_i \hat s_j}, \qquad
    r_{ij} = \frac{1}{\nu_{ij}} \sum_{g,s} w_{gs,ij},

with :math:`\nu_{ij} = \sum_g (n_{g,ij} - 1)` the pooled degrees of freedom of the
:math:`n_{g,ij}` seeds of group :math:`g` where both features are finite. With few seeds
:math:`r_{ij}` is noisy (and for more features than degrees of freedom singular), so it is
shrunk toward the identity (the "target D" of Schäfer and Strimmer 2005, Table 1: zero
correlations, the variances being handled separately) with their analytic intensity

.. math::

    R^* = \lambda^* I + (1 - \lambda^*) R, \qquad
    \lambda^* = \min\!\left(1, \max\!\left(0,
    \frac{\sum_{i\ne j} \widehat{\mathrm{Var}}(r_{ij})}{\sum_{i\ne j} r_{ij}^2}\right)\right),
    \qquad
    \widehat{\mathrm{Var}}(r_{ij}) = \frac{n_{ij}}{\nu_{ij}^3}
    \sum_{g,s} (w_{gs,ij} - \bar w_{ij})^2

with :math:`n_{ij}` the number of rows where both are finite. For one group,
:math:`\nu = n - 1`, this is exactly Schäfer and Strimmer (2005), Eq. 14 with Appendix A
(:math:`\widehat{\mathrm{Var}}(r_{ij}) = n/(n-1)^3 \sum_k (w_{kij} - \bar w_{ij})^2`).
With groups the deviations of one group sum to zero, so the rows are not independent:
:math:`\sum_k d_{ki} d_{kj}` has the variance of a Wishart sum with :math:`\nu` (not
:math:`n`) terms, which the third power of :math:`\nu` accounts for. The intensity is the
Ledoit and Wolf (2003) optimum (minimum expected squared Frobenius loss) for the correlation
matrix, estimated without assuming normality. A pairwise estimate with missing values need not be
positive definite; the eigenvalues of :math:`R^*` are then raised to
:data:`MIN_EIGENVALUE` and the diagonal reset to 1.

Whitening
---------
With :math:`D_i = \mathrm{diag}(\sigma_{i,f})` the calibrated residual errors of flight
:math:`i`, the residual covariance is :math:`C_i = D_i R^* D_i`. Its Cholesky factor
is :math:`L_i = D_i L`, :math:`L L^\top = R^*`, so the whitened residual is
:math:`e_i = L^{-1} z_i` with :math:`z_i = (y_i - \hat y_i)/\sigma_i` and the misfit
:math:`\chi^2_i = e_i^\top e_i = z_i^\top R^{*-1} z_i`. Features missing for a flight
are dropped with their rows and columns of :math:`R^*` (the marginal distribution of the
rest is the sub-matrix). When the model is right :math:`\chi^2_i \sim \chi^2_{k_i}`,
:math:`k_i` the number of features used.

References
----------
Schäfer, J. and Strimmer, K. (2005): A shrinkage approach to large-scale covariance
matrix estimation and implications for functional genomics. Statistical Applications in
Genetics and Molecular Biology 4(1), Article 32, doi:10.2202/1544-6115.1175.

Ledoit, O. and Wolf, M. (2003): Improved estimation of the covariance matrix of stock
returns with an application to portfolio selection. Journal of Empirical Finance 10(5),
603-621, doi:10.1016/S0927-5398(03)00007-0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MIN_EIGENVALUE", "ShrunkCorrelation", "shrunk_correlation", "whiten", "Whitener", "flight_correlations",
           "log_determinant", "inverse_factors", "nearest_correlation", "row_patterns"]

#: Smallest eigenvalue of a shrunk correlation matrix: whitening divides by the square root
#: of the eigenvalues, so a near-singular pairwise estimate would amplify a residual
#: along its weakest direction by more than 30 (1/sqrt(1e-3)).
MIN_EIGENVALUE = 1e-3


@dataclass(frozen=True)
class ShrunkCorrelation:
    """Outcome of :func:`shrunk_correlation`.

    Attributes
    ----------
    matrix : numpy.ndarray
        Shrunk correlation matrix :math:`R^*`, (p, p), positive definite, unit diagonal.
    sample : numpy.ndarray
        Pooled sample correlation :math:`R` (0 off the diagonal where it is undefined).
    intensity : float
        Shrinkage intensity :math:`\\lambda^*` (1: identity, no correlation used).
    dof : int
        Pooled degrees of freedom of the deviations (the largest :math:`\\nu_{jj}`).
    n_rows : int
        Number of observations (seeds times groups).
    """

    matrix: np.ndarray
    sample: np.ndarray
    intensity: float
    dof: int
    n_rows: int


def _group_deviations(x: np.ndarray, groups: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Deviations of each row from its group's mean (per feature, over finite values) and the
    number of finite values of its group and feature."""
    dev = np.full_like(x, np.nan, dtype=float)
    count = np.zeros_like(x, dtype=float)
    for g in np.unique(groups):
        rows = groups == g
        block = x[rows]
        n = np.isfinite(block).sum(axis=0)
        with np.errstate(invalid="ignore"):
            mean = np.where(n > 0, np.nansum(block, axis=0) / np.maximum(n, 1), np.nan)
        dev[rows] = block - mean
        count[rows] = n
    return dev, count


def nearest_correlation(matrix: np.ndarray, floor: float = MIN_EIGENVALUE) -> np.ndarray:
    """``matrix`` with its eigenvalues raised to ``floor`` and its diagonal reset to 1."""
    vals, vecs = np.linalg.eigh(0.5 * (matrix + matrix.T))
    if vals.min() >= floor:
        return matrix
    fixed = (vecs * np.maximum(vals, floor)) @ vecs.T
    d = np.sqrt(np.diag(fixed))
    return fixed / np.outer(d, d)


def shrunk_correlation(x: np.ndarray, groups: np.ndarray | None = None) -> ShrunkCorrelation:
    """Pooled within-group correlation matrix, shrunk toward the identity (Schäfer-Strimmer).

    Parameters
    ----------
    x : numpy.ndarray
        Observations, (n, p); NaN marks a missing value (dropped pairwise).
    groups : numpy.ndarray, optional
        Group label of every row, (n,): deviations are taken from each group's mean and
        pooled (one group, the ordinary sample correlation, when omitted).

    Returns
    -------
    ShrunkCorrelation
        :math:`R^*`, the sample correlation, :math:`\\lambda^*` and the degrees of freedom
        (equations in the module docstring). A feature without scatter (fewer than two
        degrees of freedom, or zero variance) is uncorrelated with every other; with no
        off-diagonal information at all the intensity is 1.
    """
    x = np.asarray(x, dtype=float)
    n_rows, p = x.shape
    groups = np.zeros(n_rows, dtype=int) if groups is None else np.asarray(groups)
    dev, _ = _group_deviations(x, groups)
    finite = np.isfinite(dev)
    d0 = np.where(finite, dev, 0.0)
    # pooled degrees of freedom per pair: sum over groups of (rows with both finite - 1)+
    nu = np.zeros((p, p))
    for g in np.unique(groups):
        f = finite[groups == g].astype(float)
        both = f.T @ f
        nu += np.maximum(both - 1.0, 0.0)
    n_pair = finite.T.astype(float) @ finite.astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.sqrt(np.diag(d0.T @ d0) / np.diag(nu))
    usable = np.isfinite(s) & (s > 0) & (np.diag(nu) >= 2)
    z = np.where(finite & usable[None, :], d0 / np.where(usable, s, 1.0)[None, :], 0.0)
    w_sum = z.T @ z
    w_sq = (z * z).T @ (z * z)
    sample = np.eye(p)
    var = np.zeros((p, p))
    pair_ok = np.outer(usable, usable) & (nu >= 2) & (n_pair >= 3) & ~np.eye(p, dtype=bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = w_sum / nu
        w_bar = w_sum / n_pair
        ss = w_sq - n_pair * w_bar**2  # sum over rows of (w - w_bar)^2
        v = n_pair / nu**3 * ss
    sample[pair_ok] = r[pair_ok]
    var[pair_ok] = np.maximum(v[pair_ok], 0.0)
    denom = float(np.sum(sample[pair_ok] ** 2))
    intensity = 1.0 if denom <= 0 else float(np.clip(np.sum(var[pair_ok]) / denom, 0.0, 1.0))
    shrunk = intensity * np.eye(p) + (1.0 - intensity) * sample
    np.fill_diagonal(shrunk, 1.0)
    dof = int(np.max(np.diag(nu))) if p else 0
    return ShrunkCorrelation(nearest_correlation(shrunk), sample, intensity, dof, n_rows)


def row_patterns(mask: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The distinct rows of a boolean matrix and where each occurs.

    Parameters
    ----------
    mask : numpy.ndarray
        (n, p) bool.

    Returns
    -------
    list of (pattern, rows)
        Every distinct row (p,) with the indices of the rows equal to it, in order of first
        occurrence. The common case of one pattern is answered without sorting (``np.unique``
        over rows cost more than the batched work it groups).
    """
    mask = np.asarray(mask, dtype=bool)
    if mask.shape[0] == 0:
        return []
    if (mask == mask[0]).all():
        return [(mask[0], np.arange(mask.shape[0]))]
    groups: dict[bytes, list[int]] = {}
    for i, row in enumerate(mask):
        groups.setdefault(row.tobytes(), []).append(i)
    return [(mask[rows[0]], np.asarray(rows)) for rows in groups.values()]


def inverse_factors(corr: np.ndarray | None, use: np.ndarray, per_row: bool = False) -> np.ndarray:
    """Inverse Cholesky factors of every row's used sub-matrix, zero-padded (:meth:`Whitener.padded`).

    Parameters
    ----------
    corr : numpy.ndarray or None
        Correlation matrices: ``(..., p, p)`` shared by every row, or ``(..., n, p, p)`` one per
        row (``per_row``); leading axes are independent problems of the same shape (the
        replicates of a bootstrap, :mod:`dronewind.diagnose.replicates`). None: the identity.
    use : numpy.ndarray
        Features used in every row (n, p) (bool), the same for every leading index.
    per_row : bool
        Whether ``corr`` has a matrix per row.

    Returns
    -------
    numpy.ndarray
        ``(..., n, p, p)``: for row :math:`i` the inverse Cholesky factor of the sub-matrix of its
        used features in their rows and columns, zero elsewhere.

    Notes
    -----
    Rows with the same pattern of used features are factored in one batched call (the fits
    evaluate residuals thousands of times with a few fixed patterns; a Python loop of one
    LAPACK call per row was most of their time).
    """
    use = np.asarray(use, dtype=bool)
    n, p = use.shape
    if corr is None:
        out = np.zeros((n, p, p))
        out[:, np.arange(p), np.arange(p)] = use
        return out
    corr = np.asarray(corr, dtype=float)
    lead = corr.shape[:-3] if per_row else corr.shape[:-2]
    out = np.zeros((*lead, n, p, p))
    for pattern, rows in row_patterns(use):
        if not pattern.any():
            continue
        idx = np.flatnonzero(pattern)
        mats = corr[..., rows, :, :] if per_row else corr[..., None, :, :]
        sub = mats[..., idx[:, None], idx[None, :]]
        # (..., rows or 1, q, q): a matrix shared by the rows is factored once and broadcast
        out[..., rows[:, None, None], idx[None, :, None], idx[None, None, :]] = np.tril(
            np.linalg.inv(np.linalg.cholesky(sub)))
    return out


class Whitener:
    """Whitening of standardised residuals by a correlation matrix (sub-matrix per missing pattern).

    Parameters
    ----------
    corr : numpy.ndarray or None
        Correlation matrix :math:`R^*` (p, p) shared by every row, or one matrix per row
        (n, p, p: the residual correlation of each flight when a model discrepancy is added to
        the sampling covariance, :func:`flight_correlations`); None: independent errors (no
        change).

    Notes
    -----
    The inverse Cholesky factors of every row's sub-matrix of used features are computed once
    per pattern of used features over the rows and kept (:meth:`padded`).
    """

    def __init__(self, corr: np.ndarray | None) -> None:
        self.corr = None if corr is None else np.asarray(corr, dtype=float)
        self._padded: dict[tuple[tuple[int, ...], bytes], np.ndarray] = {}

    @property
    def per_row(self) -> bool:
        """Whether every row has a matrix of its own."""
        return self.corr is not None and self.corr.ndim == 3

    def padded(self, use: np.ndarray) -> np.ndarray:
        """Every row's :math:`L_i^{-1}` at once, zero-padded to the full feature set.

        Parameters
        ----------
        use : numpy.ndarray
            Features used in every row (n, p) (bool).

        Returns
        -------
        numpy.ndarray
            (n, p, p): for row :math:`i` the inverse Cholesky factor of the sub-matrix of its
            used features in their rows and columns, zero elsewhere, so that
            ``padded[i] @ nan_to_num(z[i])`` is :meth:`__call__`'s row on the used features.

        Notes
        -----
        Rows with the same pattern of used features are factored in one batched call (the
        fits evaluate residuals thousands of times with a few fixed patterns; a Python loop of
        one LAPACK call per row was most of their time).
        """
        use = np.asarray(use, dtype=bool)
        key = (use.shape, use.tobytes())
        if key not in self._padded:
            self._padded[key] = inverse_factors(self.corr, use, self.per_row)
        return self._padded[key]

    def subset(self, rows: np.ndarray) -> Whitener:
        """The whitener of the rows ``rows`` (itself when every row shares one matrix)."""
        if not self.per_row:
            return self
        assert self.corr is not None
        rows = np.asarray(rows, dtype=int)
        if rows.size == self.corr.shape[0] and np.array_equal(rows, np.arange(rows.size)):
            return self  # every row, in order: keep the factors already computed
        return Whitener(self.corr[rows])

    def __call__(self, z: np.ndarray) -> np.ndarray:
        """Whitened residuals of each row of ``z`` (n, p); NaN marks an unused feature.

        Returns
        -------
        numpy.ndarray
            Same shape: row :math:`i` holds :math:`L_i^{-1} z_i` over its used features, in the
            positions of those features (the components are not per-feature any more, but the
            sum of their squares is the misfit), NaN elsewhere.
        """
        z = np.asarray(z, dtype=float)
        if self.corr is None:
            return z
        use = np.isfinite(z)
        out = np.einsum("ipq,iq->ip", self.padded(use), np.where(use, z, 0.0))
        return np.where(use, out, np.nan)


def flight_correlations(corr: np.ndarray | None, sigma: np.ndarray, tau: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray]:
    r"""Total residual errors and per-flight correlations with a model discrepancy added.

    Parameters
    ----------
    corr : numpy.ndarray or None
        Sampling correlation :math:`R^*` (p, p); None: the identity.
    sigma : numpy.ndarray
        Sampling errors :math:`\sigma_{if}` of the residuals (n, p) [feature units].
    tau : numpy.ndarray
        Discrepancy standard deviation :math:`\tau_f` per feature (p,) [feature units].

    Every argument may carry the same leading axes (``(..., p, p)``, ``(..., n, p)``,
    ``(..., p)``): independent campaigns of one shape, as the replicates of a bootstrap
    (:mod:`dronewind.diagnose.replicates`); the outputs then carry them too.

    Returns
    -------
    total_sigma : numpy.ndarray
        :math:`\sqrt{\sigma_{if}^2 + \tau_f^2}` (n, p).
    correlations : numpy.ndarray
        (n, p, p): the correlation of :math:`C_i = D_i R^* D_i + \mathrm{diag}(\tau^2)`,
        :math:`D_i = \mathrm{diag}(\sigma_i)`; the discrepancy is independent between
        features and flights (Kennedy and O'Hagan 2001, with a diagonal discrepancy covariance).
    """
    sigma = np.asarray(sigma, dtype=float)
    tau2 = np.asarray(tau, dtype=float) ** 2
    p = sigma.shape[-1]
    r = np.eye(p) if corr is None else np.asarray(corr, dtype=float)
    total = np.sqrt(sigma**2 + tau2[..., None, :])
    s = np.where(np.isfinite(sigma), sigma, 0.0)
    t = np.where(np.isfinite(total) & (total > 0), total, 1.0)
    diag = tau2[..., :, None] * np.eye(p)  # diag(tau^2) of every leading index
    out = ((r[..., None, :, :] * s[..., :, None] * s[..., None, :] + diag[..., None, :, :])
           / (t[..., :, None] * t[..., None, :]))
    out[..., np.arange(p), np.arange(p)] = 1.0
    return total, out


def log_determinant(total_sigma: np.ndarray, whitener: Whitener, use: np.ndarray) -> float:
    r"""Log-determinant of the campaign's residual covariance over the used features.

    Parameters
    ----------
    total_sigma : numpy.ndarray
        Total errors :math:`t_{if}` (n, p) [feature units] (:func:`flight_correlations`).
    whitener : Whitener
        Whitening of the standardised residuals by their correlation :math:`R_i`.
    use : numpy.ndarray
        Features used in every row (n, p) (bool); the others are left out of every row's matrix.

    Returns
    -------
    float
        :math:`\sum_i \log|C_i|`, :math:`C_i = T_i R_i T_i` restricted to row :math:`i`'s used
        features, :math:`T_i = \mathrm{diag}(t_i)`; from the inverse Cholesky factors the whitener
        keeps, :math:`\log|R_i| = -2\sum_f \log (L_i^{-1})_{ff}`. With it,
        :math:`\chi^2 + \log|C|` is minus twice the Gaussian log-likelihood less a constant.
    """
    use = np.asarray(use, dtype=bool)
    t = np.where(use, np.asarray(total_sigma, dtype=float), 1.0)
    diag = np.diagonal(whitener.padded(use), axis1=1, axis2=2)
    return float(2.0 * np.sum(np.log(t[use])) - 2.0 * np.sum(np.log(diag[use])))


def whiten(z: np.ndarray, corr: np.ndarray | None) -> np.ndarray:
    """Whitened standardised residuals (see :class:`Whitener`); ``corr`` None leaves them unchanged."""
    return Whitener(corr)(z)
