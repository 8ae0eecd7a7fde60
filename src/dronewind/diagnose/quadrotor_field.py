"""Field candidates of the quadrotor diagnosis: the single-law model on field windows and its held-out scores.

The field windows (:func:`field_data`) pair each UAV's attitude with the reference wind; the
baseline is one drag law for every UAV (Wetz et al. 2021, Eqs. 12-18) and the extensions
``pitch_offset`` (Wetz et al. 2021, Sect. 5.2), ``yaw_offset`` (Sect. 5.4) and ``drag_regime``
(power laws per speed range, Kistner et al. 2024, Eq. 1 and Table 2; :func:`regime_speed`)
are fitted by least squares (:func:`fit_field`). :func:`score_field_candidates` scores each
extension on windows of flights left out (k-fold over flights) with a one-sided paired
Wilcoxon signed-rank test per unit (see :mod:`dronewind.diagnose.quadrotor`).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
import pandas as pd
import scipy.optimize
import scipy.sparse
import scipy.stats

from dronewind.core.constants import AIR_DENSITY_KGM3, GRAVITY_MS2
from dronewind.errors import InputError
from dronewind.quadrotor.calibration import BOUNDS
from dronewind.quadrotor.drag import attitude_trig, lean_from_trig, speed_from_tilt, tilt_from_attitude

__all__ = [
    "FieldData",
    "field_data",
    "fit_field",
    "predict_field",
    "score_field_candidates",
    "regime_speed",
]


#: Candidates of the field naming rounds. ``flight_pitch_offset`` (one pitch offset per flight
#: and UAV: an IMU re-levelled between days) replaces the per-UAV ``pitch_offset``;
#: ``air_density`` (the logged density in the drag balance) is scored when the records log it.
FIELD_CANDIDATES = ("pitch_offset", "yaw_offset", "drag_regime", "flight_pitch_offset", "air_density")

#: Candidate -> the simpler candidate it extends (its parameters a special case of the other's):
#: when the data cannot tell the two apart, the simpler one is named.
NESTED = {"flight_pitch_offset": "pitch_offset"}


#: Windows below this reference speed carry little direction information: the weather vane turns
#: the nose only while the roll exceeds 1 degree (Wetz et al. 2021 Sect. 5.4), i.e. heading errors of tens of
#: degrees persist at 2-3 m/s.
MIN_DIRECTION_SPEED_MS = 3.5


@dataclass
class FieldData:
    """Averaging windows of the fleet as arrays (blocks re-averaged to ``block_s``)."""

    win: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    yaw: np.ndarray
    vn: np.ndarray
    ve: np.ndarray
    ref_speed: np.ndarray
    ref_from: np.ndarray
    flight: np.ndarray
    uav: np.ndarray
    uavs: list[str]
    rho: np.ndarray | None = None  # air density of each block [kg m-3] (NaN: not logged)
    units: list[str] | None = None  # flight/uav of the per-flight offsets (default: those present)
    count: np.ndarray = field(init=False)
    uav_index: np.ndarray = field(init=False)
    unit: np.ndarray = field(init=False)
    unit_index: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.count = np.bincount(self.win, minlength=self.ref_speed.size).astype(float)
        self.uav_index = np.searchsorted(self.uavs, self.uav)
        self.unit = np.char.add(np.char.add(self.flight.astype(str), "/"), self.uav.astype(str))
        if self.units is None:
            self.units = sorted(set(self.unit.tolist()))
        self.unit_index = np.searchsorted(self.units, self.unit)
        if self.rho is None:
            self.rho = np.full(self.win.size, np.nan)

    @property
    def has_density(self) -> bool:
        """Whether any block has a logged air density."""
        return bool(np.isfinite(cast(np.ndarray, self.rho)).any())

    @property
    def n(self) -> int:
        return int(self.ref_speed.size)

    # What no fitted offset changes, made once: the fits evaluate the field model's wind
    # (:func:`_wind`) thousands of times.

    @functools.cached_property
    def roll_rad(self) -> np.ndarray:
        """Roll of every block [rad]."""
        return np.radians(self.roll)

    @functools.cached_property
    def attitude_trig(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Cosine and sine of every block's roll and pitch: the offset path (:func:`_attitude_terms`)
        turns the pitch by the angle-sum formulas instead of evaluating them again per block."""
        return attitude_trig(self.roll_rad, np.radians(self.pitch))

    @functools.cached_property
    def tilt_without_offset(self) -> tuple[np.ndarray, np.ndarray]:
        """Tilt and lean direction relative to the nose [rad] of every block, without a pitch offset."""
        # minus 0.0 as in the fitted path (_attitude_terms): a logged -0.0 becomes 0.0 there too
        return tilt_from_attitude(self.roll_rad, np.radians(self.pitch - 0.0))

    @functools.cached_property
    def heading_without_offset(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Heading of every block [rad] with its cosine and sine, without a yaw offset."""
        psi = np.radians(self.yaw - 0.0)  # minus 0.0 as in the offset path of _attitude_terms
        return psi, np.cos(psi), np.sin(psi)

    @functools.cached_property
    def attitude_without_offsets(self) -> tuple[np.ndarray, ...]:
        """:func:`_attitude_terms` without pitch and yaw offsets."""
        return _attitude_terms(self, 0.0, 0.0)

    @functools.cached_property
    def _offset_indices(self) -> dict[tuple[str, ...], tuple[np.ndarray, np.ndarray]]:
        return {}

    def offset_index(self, units: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """Where every block's flight and UAV sits among a model's per-flight offsets.

        Parameters
        ----------
        units : sequence of str
            The model's ``flight/uav`` units (:attr:`FieldModel.units`, sorted).

        Returns
        -------
        index : numpy.ndarray
            Index of each block's unit in ``units`` (int, clipped to the last one).
        known : numpy.ndarray
            Whether the block's unit is among ``units`` (bool): a held-out flight is not.

        Notes
        -----
        Made once per set of units: a string search over every block at each evaluation
        of the fitted wind was a fifth of the field diagnosis' time.
        """
        key = tuple(units)
        if key not in self._offset_indices:
            block_unit = self.unit[self.win]
            known = np.isin(block_unit, key)
            index = np.searchsorted(key, block_unit).clip(0, max(len(key) - 1, 0))
            self._offset_indices[key] = (index, known)
        return self._offset_indices[key]

    def subset(self, mask: np.ndarray) -> FieldData:
        """Windows where ``mask`` is true (UAV list kept, so parameter vectors align)."""
        idx = np.flatnonzero(mask)
        new = -np.ones(self.n, int)
        new[idx] = np.arange(idx.size)
        keep = mask[self.win]
        return FieldData(new[self.win[keep]], self.roll[keep], self.pitch[keep], self.yaw[keep], self.vn[keep],
                         self.ve[keep], self.ref_speed[idx], self.ref_from[idx], self.flight[idx], self.uav[idx],
                         self.uavs, cast(np.ndarray, self.rho)[keep], self.units)


def field_data(blocks: pd.DataFrame, windows: pd.DataFrame, block_s: float = 10.0) -> FieldData:
    """Arrays for the diagnosis from :func:`dronewind.quadrotor.windows.flight_windows` output.

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        1-s blocks and their windows.
    block_s : float
        The 1-s blocks are averaged to this length [s] (yaw as a circular mean) to keep the
        many refits fast; the drag law is nearly linear over the tilt changes within 10 s.

    Returns
    -------
    FieldData

    Raises
    ------
    InputError
        Fewer than 3 windows.
    """
    if len(windows) < 3:
        raise InputError("quadrotor windows", f"{len(windows)} windows; the diagnosis needs at least 3")
    w = windows.reset_index(drop=True)
    keys = pd.Index(w["window_key"].astype(str))
    b = blocks[blocks["window_key"].astype(str).isin(keys)].copy()
    b["win"] = keys.get_indexer(pd.Index(b["window_key"].astype(str)))
    b["k"] = b.groupby("win").cumcount() // max(1, int(round(block_s)))
    b["sy"] = np.sin(np.radians(b["yaw_deg"]))
    b["cy"] = np.cos(np.radians(b["yaw_deg"]))
    if "rho_kgm3" not in b:
        b["rho_kgm3"] = np.nan
    g = b.groupby(["win", "k"], sort=True)[["roll_deg", "pitch_deg", "sy", "cy", "vel_n_ms", "vel_e_ms",
                                            "rho_kgm3"]].mean()
    win = g.index.get_level_values("win").to_numpy()
    uav = w["uav"].astype(str).to_numpy()
    return FieldData(win, g["roll_deg"].to_numpy(), g["pitch_deg"].to_numpy(),
                     np.degrees(np.arctan2(g["sy"].to_numpy(), g["cy"].to_numpy())), g["vel_n_ms"].to_numpy(),
                     g["vel_e_ms"].to_numpy(), w["ref_speed_ms"].to_numpy(float), w["ref_from_deg"].to_numpy(float),
                     w["flight"].astype(str).to_numpy(), uav, sorted(set(uav)), g["rho_kgm3"].to_numpy(float))


def regime_speed(accel_ms2: np.ndarray | float, edges_ms: Sequence[float], b: Sequence[float] | np.ndarray,
                 c: Sequence[float] | np.ndarray) -> np.ndarray:
    r"""Relative air speed from the wind acceleration with one power law per speed range.

    Parameters
    ----------
    accel_ms2 : array_like
        :math:`a = g\sin\gamma` [m s-2] (>= 0).
    edges_ms : sequence of float
        Upper speed edges of the ranges [m s-1] (``len(b) - 1`` values).
    b, c : sequence of float
        Exponent [-] and factor [m s-1 (m s-2)^-b] per range.

    Returns
    -------
    numpy.ndarray
        Speed [m s-1].

    Notes
    -----
    Kistner et al. (2024), Eq. 1 and Table 2: :math:`V = c_k a^{b_k}`; range :math:`k` is the number of
    thresholds :math:`a_j = (e_j/c_j)^{1/b_j}` that :math:`a` exceeds (range :math:`j` ends
    where its own law reaches its upper edge), as in
    :func:`dronewind.quadrotor.drag.body_axis_relative_air`.
    """
    a = np.abs(np.asarray(accel_ms2, float))
    bb = np.asarray(b, float)
    cc = np.asarray(c, float)
    e = np.asarray(edges_ms, float)
    k = np.zeros(a.shape, int)
    if e.size:
        thr = (e / cc[:-1]) ** (1.0 / bb[:-1])
        k = np.sum(a[..., None] > thr, axis=-1)
    return cc[k] * a ** bb[k]


@dataclass
class FieldModel:
    """Which extensions a field model has and its parameter layout."""

    pitch: bool = False
    yaw: bool = False
    regime_edges: tuple[float, ...] | None = None  # None: rayleigh law (Wetz et al. 2021 Eq. 17)
    flight_pitch: bool = False  # one pitch offset per flight and UAV (replaces the per-UAV one)
    density: bool = False  # the logged air density in the drag balance
    units: tuple[str, ...] = ()  # flight/uav of the per-flight offsets

    def offset_names(self, uavs: Sequence[str]) -> list[str]:
        """Names of the pitch-offset parameters (per flight and UAV, per UAV, or none)."""
        if self.flight_pitch:
            return [f"pitch_{u}" for u in self.units]
        return [f"pitch_{u}" for u in uavs] if self.pitch else []

    def speed_names(self, uavs: Sequence[str]) -> list[str]:
        if self.regime_edges is None:
            names = ["cd0a0_m2", "cp_m2_per_rad"]
        else:
            nr = len(self.regime_edges) + 1
            names = [f"b_{k}" for k in range(nr)] + [f"c_{k}" for k in range(nr)]
        return names + self.offset_names(uavs)

    def bounds(self, uavs: Sequence[str]) -> tuple[list[float], list[float]]:
        lo, hi = [], []
        for name in self.speed_names(uavs):
            if name in BOUNDS:
                lo.append(BOUNDS[name][0])
                hi.append(BOUNDS[name][1])
            elif name.startswith("b_"):
                lo.append(0.2)
                hi.append(1.5)
            elif name.startswith("c_"):
                lo.append(1.0)
                hi.append(30.0)
            else:
                lo.append(BOUNDS["pitch_offset_deg"][0])
                hi.append(BOUNDS["pitch_offset_deg"][1])
        return lo, hi

    def start(self, uavs: Sequence[str]) -> np.ndarray:
        if self.regime_edges is None:
            x = [0.03, -0.047]
        else:
            nr = len(self.regime_edges) + 1
            x = [0.6] * nr + [7.0] * nr
        return np.array(x + [0.0] * len(self.offset_names(uavs)), float)


@dataclass
class FieldFit:
    """Fitted field model: speed parameters, yaw offsets (per UAV) and their errors."""

    model: FieldModel
    x: np.ndarray
    se: np.ndarray
    yaw_deg: np.ndarray
    yaw_se: np.ndarray
    converged: bool
    rss: float
    n: int


def _wind(data: FieldData, model: FieldModel, x: np.ndarray, yaw_deg: np.ndarray | None) -> tuple[np.ndarray, ...]:
    """Window-mean (signed) speed and wind vector of a field model."""
    n_off = len(model.offset_names(data.uavs))
    nspeed = len(model.speed_names(data.uavs)) - n_off
    if n_off or (model.yaw and yaw_deg is not None):
        p_off: tuple[np.ndarray, np.ndarray] | float
        if model.flight_pitch:
            # a unit the training never saw (a held-out flight) keeps zero offset
            idx, known = data.offset_index(model.units)
            p_off = (np.append(x[nspeed:], 0.0), np.where(known, idx, x[nspeed:].size))
        else:
            p_off = (x[nspeed:], data.uav_index[data.win]) if model.pitch else 0.0
        y_off = yaw_deg[data.uav_index[data.win]] if (model.yaw and yaw_deg is not None) else 0.0
        terms = _attitude_terms(data, p_off, y_off)
    else:
        terms = data.attitude_without_offsets
    tilt, cos_lean, sin_lean, cos_psi, sin_psi = terms
    if model.regime_edges is None:
        vrel = speed_from_tilt(tilt, x[0], x[1])
    else:
        nr = len(model.regime_edges) + 1
        vrel = regime_speed(GRAVITY_MS2 * np.sin(tilt), model.regime_edges, x[:nr], x[nr:2 * nr])
    if model.density:
        # V scales as rho**-1/2 (Wetz et al. 2021, Eq. 12); blocks without a logged density keep the law's
        rho = cast(np.ndarray, data.rho)
        vrel = vrel * np.sqrt(AIR_DENSITY_KGM3 / np.where(np.isfinite(rho), rho, AIR_DENSITY_KGM3))
    wn = -vrel * cos_lean + data.vn
    we = -vrel * sin_lean + data.ve
    sp = np.hypot(wn, we)
    head = -(wn * cos_psi + we * sin_psi)
    signed = np.where(head < 0, -sp, sp)
    m = data.ref_speed.size

    def mean(v):
        return np.bincount(data.win, weights=v, minlength=m) / np.maximum(data.count, 1)

    return mean(sp), mean(signed), mean(wn), mean(we)


def _attitude_terms(data: FieldData, p_off: tuple[np.ndarray, np.ndarray] | float, y_off: np.ndarray | float
                    ) -> tuple[np.ndarray, ...]:
    r"""Tilt [rad] and the cosines and sines of the lean and heading angles, with the offsets [degree] removed.

    ``p_off`` is 0.0 (no pitch offset) or the offsets of the model's units [degree] with every
    block's index into them.

    Notes
    -----
    The tilt and lean are those of :func:`~dronewind.quadrotor.drag.tilt_from_attitude` at the
    pitch :math:`\theta - p`, made by :func:`~dronewind.quadrotor.drag.lean_from_trig` from the
    blocks' cosines and sines (:attr:`FieldData.attitude_trig`) and those of the few offsets.
    """
    if isinstance(y_off, float) and y_off == 0.0:  # no yaw offset (the speed fits): the heading never changes
        psi, cos_psi, sin_psi = data.heading_without_offset
    else:
        psi = np.radians(data.yaw - y_off)
        cos_psi, sin_psi = np.cos(psi), np.sin(psi)
    if isinstance(p_off, float):  # no pitch offset fitted (0): the tilt and its direction never change
        tilt, lean_rel = data.tilt_without_offset
        lean = psi + lean_rel
        return tilt, np.cos(lean), np.sin(lean), cos_psi, sin_psi
    offsets, index = p_off
    p = np.radians(np.asarray(offsets, dtype=float))
    cos_p, sin_p = np.cos(p)[index], np.sin(p)[index]
    tilt, cos_lean, sin_lean = lean_from_trig(*data.attitude_trig, cos_psi, sin_psi, pitch_offset=(cos_p, sin_p))
    return tilt, cos_lean, sin_lean, cos_psi, sin_psi


def predict_field(data: FieldData, fit: FieldFit) -> tuple[np.ndarray, np.ndarray]:
    """Window speed [m s-1] and wind-from direction [degree] of a fitted field model."""
    sp, _, wn, we = _wind(data, fit.model, fit.x, fit.yaw_deg)
    return sp, _heading(data, fit.yaw_deg if fit.model.yaw else None)


def _heading(data: FieldData, yaw_deg: np.ndarray | None) -> np.ndarray:
    """Window wind direction from the corrected heading (weather vane, Wetz et al. (2021) Sect. 5.4).

    The heading does not depend on the pitch offset or the drag law, so the direction
    metric separates ``yaw_offset`` from the speed candidates.
    """
    off = yaw_deg[data.uav_index[data.win]] if yaw_deg is not None else 0.0
    a = np.radians(data.yaw - off)
    m = data.ref_speed.size
    s = np.bincount(data.win, weights=np.sin(a), minlength=m)
    c = np.bincount(data.win, weights=np.cos(a), minlength=m)
    return np.degrees(np.arctan2(s, c)) % 360.0


def _wrap(d: np.ndarray) -> np.ndarray:
    return (np.asarray(d, float) + 180.0) % 360.0 - 180.0


def fit_field(data: FieldData, model: FieldModel) -> FieldFit:
    """Fit a field model: speed parameters by bounded least squares, yaw offsets in closed form.

    Parameters
    ----------
    data : FieldData
        Training windows.
    model : FieldModel
        Model layout.

    Returns
    -------
    FieldFit

    Notes
    -----
    Speed: ``scipy.optimize.least_squares(method="trf")`` on the signed window speed minus
    the reference (the sign rules out the mirror solution of the tilt, as in
    :func:`dronewind.quadrotor.calibration.calibrate_universal`), with a sparse Jacobian pattern (a
    window depends on the law and on its own UAV's offset only). Yaw: speed-weighted
    circular mean of heading minus reference direction per UAV (Wetz et al. 2021 Sect. 5.4, as
    :func:`dronewind.quadrotor.calibration.calibrate_yaw_offsets`), over windows above
    :data:`MIN_DIRECTION_SPEED_MS`. The window direction is the circular mean of the
    corrected heading (weather vane), as in :func:`dronewind.quadrotor.validation.predict_windows`.
    """
    uavs = data.uavs
    lo, hi = model.bounds(uavs)
    names = model.speed_names(uavs)
    nu = len(uavs)
    nspeed = len(names) - len(model.offset_names(uavs))

    def fun(x):
        return _wind(data, model, x, None)[1] - data.ref_speed

    sparsity = np.ones((data.n, len(names)), dtype=int)
    if model.flight_pitch:
        sparsity[:, nspeed:] = 0
        sparsity[np.arange(data.n), nspeed + np.searchsorted(model.units, data.unit)] = 1
    elif model.pitch:
        sparsity[:, nspeed:] = 0
        w_uav = np.searchsorted(uavs, data.uav)
        sparsity[np.arange(data.n), nspeed + w_uav] = 1
    fits = []
    starts = [model.start(uavs)]
    if model.regime_edges is None:
        alt = model.start(uavs)
        alt[:2] = [0.05, 0.0]
        starts.append(alt)
    for x0 in starts:
        x0 = np.clip(x0, np.asarray(lo) + 1e-9, np.asarray(hi) - 1e-9)
        fits.append(scipy.optimize.least_squares(fun, x0, bounds=(lo, hi), method="trf", x_scale="jac",
                                                 jac_sparsity=scipy.sparse.csr_matrix(sparsity),
                                                 xtol=1e-10, ftol=1e-10, max_nfev=500))
    res = min(fits, key=lambda r: r.cost)
    n_par = res.x.size
    dof = data.n - n_par
    se = np.full(n_par, np.nan)
    if dof > 0:
        jac = res.jac.toarray() if scipy.sparse.issparse(res.jac) else res.jac
        cov = np.linalg.pinv(jac.T @ jac) * (2.0 * res.cost / dof)
        se = np.sqrt(np.clip(np.diag(cov), 0, None))
    yaw = np.zeros(nu)
    yaw_se = np.full(nu, np.nan)
    if model.yaw:
        frm = _heading(data, None)
        for k, u in enumerate(uavs):
            sel = (data.uav == u) & (data.ref_speed >= MIN_DIRECTION_SPEED_MS) & np.isfinite(frm)
            if sel.sum() == 0:
                continue
            d = frm[sel] - data.ref_from[sel]
            wt = data.ref_speed[sel]
            off = np.degrees(np.arctan2(np.sum(wt * np.sin(np.radians(d))), np.sum(wt * np.cos(np.radians(d)))))
            yaw[k] = off
            r = _wrap(d - off)
            yaw_se[k] = float(np.sqrt(np.sum(wt * r**2) / np.sum(wt)) / np.sqrt(sel.sum())) if sel.sum() > 1 \
                else np.nan
    return FieldFit(model, res.x, se, yaw, yaw_se, bool(res.success), float(2.0 * res.cost), data.n)


def _folds(flights: np.ndarray, k_folds: int) -> list[np.ndarray]:
    """Flight groups for k-fold cross-validation (round-robin over sorted flight ids)."""
    ids = sorted(set(flights.tolist()))
    k = min(k_folds, len(ids))
    groups = [ids[j::k] for j in range(k)]
    return [np.isin(flights, g) for g in groups]


@dataclass
class HeldOut:
    """Held-out predictions of one model on every window."""

    speed_err: np.ndarray
    dir_err: np.ndarray

    def rmse(self, metric: str, mask: np.ndarray | None = None) -> float:
        e = self.speed_err if metric == "speed" else self.dir_err
        if mask is not None:
            e = e[mask]
        e = e[np.isfinite(e)]
        return float(np.sqrt(np.mean(e**2))) if e.size else float("nan")


def _within_folds(units: np.ndarray, k_folds: int) -> list[np.ndarray]:
    """Folds of every ``k``-th window of each flight and UAV (each fold keeps windows of every unit to train on)."""
    rank = pd.Series(np.arange(units.size)).groupby(units).cumcount().to_numpy()
    return [rank % k_folds == j for j in range(k_folds)]


def cross_validate(data: FieldData, model: FieldModel, k_folds: int = 5, within_flights: bool = False) -> HeldOut:
    """Held-out speed and direction errors of every window (k-fold over flights, or within flights)."""
    sp_err = np.full(data.n, np.nan)
    dir_err = np.full(data.n, np.nan)
    folds = _within_folds(data.unit, k_folds) if within_flights else _folds(data.flight, k_folds)
    for test in folds:
        train = ~test
        if train.sum() < 3:
            continue
        fit = fit_field(data.subset(train), model)
        sub = data.subset(test)
        # UAVs never seen in training keep zero offsets (the fit's default)
        sp, frm = predict_field(sub, fit)
        sp_err[test] = sp - sub.ref_speed
        d = _wrap(frm - sub.ref_from)
        dir_err[test] = np.where(sub.ref_speed >= MIN_DIRECTION_SPEED_MS, d, np.nan)
    return HeldOut(sp_err, dir_err)


def _paired(ref: np.ndarray, cand: np.ndarray, units: np.ndarray) -> tuple[float, int]:
    """One-sided Wilcoxon signed-rank test that the candidate's squared errors are smaller, per unit.

    Squared errors are averaged per unit first (a UAV log, a gust repetition, a speed step),
    so correlated samples of one unit count once. The rank test does not assume normal
    differences (they are skewed: large at high speed, tiny at low speed).
    """
    ok = np.isfinite(ref) & np.isfinite(cand)
    d = pd.DataFrame({"u": units[ok], "d": ref[ok] ** 2 - cand[ok] ** 2}).groupby("u")["d"].mean().to_numpy()
    d = d[d != 0]
    if d.size < 2:
        return 1.0, int(d.size)
    res = scipy.stats.wilcoxon(d, alternative="greater")
    return (float(res.pvalue) if np.isfinite(res.pvalue) else 1.0), int(d.size)


def _regime_edges(ref_speed: np.ndarray, n_ranges: int = 3, min_windows: int = 4) -> tuple[float, ...]:
    """Speed-range edges at quantiles of the reference speed, rounded to 0.5 m/s."""
    for nr in range(n_ranges, 1, -1):
        edges = np.round(np.quantile(ref_speed, np.arange(1, nr) / nr) * 2) / 2
        edges = np.unique(edges)
        bins = np.searchsorted(edges, ref_speed)
        if edges.size == nr - 1 and np.all(np.bincount(bins, minlength=nr) >= min_windows):
            return tuple(float(e) for e in edges)
    return ()


def _with(model: FieldModel, cand: str, edges: tuple[float, ...], units: Sequence[str]) -> FieldModel:
    """The model extended by one candidate (``flight_pitch_offset`` replaces per-UAV pitch offsets)."""
    flight_pitch = model.flight_pitch or cand == "flight_pitch_offset"
    return FieldModel(pitch=(model.pitch or cand == "pitch_offset") and not flight_pitch,
                      yaw=model.yaw or cand == "yaw_offset",
                      regime_edges=edges if cand == "drag_regime" else model.regime_edges,
                      flight_pitch=flight_pitch, density=model.density or cand == "air_density",
                      units=tuple(units) if flight_pitch else ())


def _available(cand: str, model: FieldModel, data: FieldData, edges: tuple[float, ...], k_folds: int) -> bool:
    """Whether a candidate can extend the model on these data."""
    if cand == "pitch_offset":
        return not (model.pitch or model.flight_pitch)
    if cand == "yaw_offset":
        return not model.yaw
    if cand == "drag_regime":
        return bool(edges) and model.regime_edges is None
    if cand == "flight_pitch_offset":
        return not model.flight_pitch and len(set(data.flight.tolist())) > 1 and data.n >= 2 * k_folds
    return cand == "air_density" and data.has_density and not model.density


def _within(cand: str, model: FieldModel) -> bool:
    """Whether a candidate is held out within flights: per-flight offsets cannot predict a new flight."""
    return cand == "flight_pitch_offset" or model.flight_pitch


def _estimate(fit: FieldFit, cand: str, uavs: Sequence[str]) -> tuple[dict[str, Any], dict[str, Any]]:
    names = fit.model.speed_names(uavs)
    est: dict[str, Any]
    unc: dict[str, Any]
    if cand == "flight_pitch_offset":
        est = {u: float(fit.x[names.index(f"pitch_{u}")]) for u in fit.model.units}
        unc = {u: float(fit.se[names.index(f"pitch_{u}")]) for u in fit.model.units}
    elif cand == "air_density":
        est, unc = {"density": "logged pressure and temperature"}, {}
    elif cand == "pitch_offset" and fit.model.flight_pitch:
        # per-UAV offsets replaced by per-flight ones: each UAV's mean over its flights
        per = {u: [float(fit.x[names.index(f"pitch_{k}")]) for k in fit.model.units if k.endswith(f"/{u}")]
               for u in uavs}
        est = {u: float(np.mean(v)) if v else float("nan") for u, v in per.items()}
        unc = {u: float(np.std(v)) if v else float("nan") for u, v in per.items()}
    elif cand == "pitch_offset":
        est = {u: float(fit.x[names.index(f"pitch_{u}")]) for u in uavs}
        unc = {u: float(fit.se[names.index(f"pitch_{u}")]) for u in uavs}
    elif cand == "yaw_offset":
        est = {u: float(v) for u, v in zip(uavs, fit.yaw_deg, strict=True)}
        unc = {u: float(v) for u, v in zip(uavs, fit.yaw_se, strict=True)}
    else:
        edges = list(fit.model.regime_edges or ())
        nr = len(edges) + 1
        lo = [0.0] + edges
        hi = edges + [None]
        est = {"coefficients": [{"min_speed_ms": lo[k], "max_speed_ms": hi[k], "b": float(fit.x[k]),
                                 "c": float(fit.x[nr + k])} for k in range(nr)]}
        unc = {"coefficients": [{"b": float(fit.se[k]), "c": float(fit.se[nr + k])} for k in range(nr)]}
    return est, unc


def _errors(ho: HeldOut, metric: str) -> np.ndarray:
    return ho.dir_err if metric == "direction" else ho.speed_err


def _ambiguity(top: dict[str, Any], scored: Sequence[dict[str, Any]], data: FieldData, units: np.ndarray,
               k_folds: int) -> list[str]:
    """Significant candidates of a round that the round's best does not beat: its ambiguity set.

    The best candidate's held-out squared errors are tested against each other significant
    candidate's on the same metric with the round's test (one-sided paired Wilcoxon per unit,
    at the round's Bonferroni level), both on one fold scheme (within flights when either is
    held out within flights). A candidate the best does not beat explains the data as well.
    """
    out = []
    for s in scored:
        if s is top or not s["significant"] or s["metric"] != top["metric"]:
            continue
        a, b = top["_ho"], s["_ho"]
        if top["_within"] != s["_within"]:
            a = a if top["_within"] else cross_validate(data, top["_model"], k_folds, within_flights=True)
            b = b if s["_within"] else cross_validate(data, s["_model"], k_folds, within_flights=True)
        metric = top["metric"].removesuffix("_rmse")
        p, _ = _paired(_errors(b, metric), _errors(a, metric), units)
        if p >= top["alpha_bonferroni"]:
            out.append(s["mechanism"])
    return out


def score_field_candidates(data: FieldData, alpha: float = 0.01, min_gain: float = 0.05, k_folds: int = 5,
                           max_causes: int = 3) -> dict[str, Any]:
    """Greedy naming of field causes against the single-law baseline (see module doc).

    Parameters
    ----------
    data : FieldData
        All windows of the campaign.
    alpha : float
        Family-wise false-alarm rate per round (Bonferroni over the candidates of the round).
    min_gain : float
        Smallest held-out gain that names a cause.
    k_folds : int
        Folds of the cross-validation (over flights, or within flights for per-flight offsets).
    max_causes : int
        Largest number of causes named.

    Returns
    -------
    dict
        ``baseline`` (fit and held-out metrics), ``rounds`` (every candidate scored per
        round, each with ``heldout`` (its fold scheme) and ``ambiguous_with``), ``named``
        (candidates named in order), ``extended`` and ``extended_baseline`` (held-out errors of
        the final model and of the baseline on one fold scheme, ``extended_heldout``),
        ``final_fit``, ``final_model``, ``edges``.

    Notes
    -----
    Every candidate of :data:`FIELD_CANDIDATES` that can extend the current model takes part
    in every round, per-flight offsets and the logged density beside the per-UAV causes:
    fitted on training folds, its held-out errors tested against the current model's on the
    same folds (one-sided paired Wilcoxon per flight and UAV, Bonferroni over the round's
    candidates, ``gain >= min_gain``). The folds are over flights, except for per-flight
    offsets (a new flight's offset cannot be known: every ``k``-th window of each flight and
    UAV is held out), and for every candidate once per-flight offsets are in the model. The
    round's best significant candidate (largest gain) is named, with its ambiguity set
    (:func:`_ambiguity`); when the set holds the simpler candidate it extends
    (:data:`NESTED`), the simpler one is named instead. Naming per-flight offsets retires
    the per-UAV ones; naming per-UAV offsets leaves per-flight ones to compete in the next
    round against the per-UAV model.
    """
    edges = _regime_edges(data.ref_speed)
    units = np.char.add(np.char.add(data.flight.astype(str), "/"), data.uav.astype(str))
    flight_units = tuple(data.units or ())
    current = FieldModel()
    base_fit = fit_field(data, current)
    # held-out errors of the current model on each fold scheme (False: over flights, True: within)
    cur: dict[bool, HeldOut] = {False: cross_validate(data, current, k_folds)}
    base_ho = {False: cur[False]}

    def heldout(cache: dict[bool, HeldOut], model: FieldModel, within: bool) -> HeldOut:
        if within not in cache:
            cache[within] = cross_validate(data, model, k_folds, within_flights=within)
        return cache[within]

    rounds: list[list[dict[str, Any]]] = []
    named: list[dict[str, Any]] = []
    remaining = list(FIELD_CANDIDATES)
    while len(named) < max_causes:
        remaining = [c for c in remaining if _available(c, current, data, edges, k_folds)]
        if not remaining:
            break
        scored: list[dict[str, Any]] = []
        ref_fit = fit_field(data, current)
        for cand in remaining:
            model = _with(current, cand, edges, flight_units)
            within = _within(cand, current)
            ref_ho = heldout(cur, current, within)
            ho = cross_validate(data, model, k_folds, within_flights=within)
            metric = "direction" if cand == "yaw_offset" else "speed"
            r0, r1 = ref_ho.rmse(metric), ho.rmse(metric)
            gain = 1.0 - r1 / r0 if r0 > 0 else 0.0
            p, n_units = _paired(_errors(ref_ho, metric), _errors(ho, metric), units)
            fit = fit_field(data, model)
            dp = len(model.speed_names(data.uavs)) - len(current.speed_names(data.uavs)) + \
                (len(data.uavs) if cand == "yaw_offset" else 0)
            f_stat = float("nan")
            if metric == "speed" and dp > 0 and data.n > len(fit.x):
                f_stat = float(((ref_fit.rss - fit.rss) / dp) / (fit.rss / (data.n - len(fit.x))))
            est, unc = _estimate(fit, cand, data.uavs)
            scored.append({"mechanism": cand, "source": "field", "metric": f"{metric}_rmse",
                           "heldout": f"{k_folds}-fold {'within' if within else 'over'} flights",
                           "heldout_rmse_before": r0, "heldout_rmse_after": r1, "gain": float(gain),
                           "p_value": p, "n_units": n_units, "n_parameters": int(dp), "f_statistic": f_stat,
                           "estimate": est, "uncertainty": unc, "converged": fit.converged, "ambiguous_with": [],
                           "_model": model, "_ho": ho, "_within": within})
        level = alpha / len(scored)
        for s in scored:
            s["significant"] = bool(s["p_value"] < level and s["gain"] >= min_gain and s["converged"])
            s["alpha_bonferroni"] = level
        rounds.append(scored)
        best = [s for s in scored if s["significant"]]
        if not best:
            break
        top = max(best, key=lambda s: s["gain"])
        ambiguous = _ambiguity(top, scored, data, units, k_folds)
        simpler = NESTED.get(top["mechanism"])
        if simpler in ambiguous:  # the data cannot tell the two apart: the simpler one is named
            other = top
            top = next(s for s in scored if s["mechanism"] == simpler)
            ambiguous = [other["mechanism"]] + _ambiguity(top, [s for s in scored if s is not other], data, units,
                                                          k_folds)
        top["ambiguous_with"] = ambiguous
        named.append(top)
        current = top["_model"]
        cur = {top["_within"]: top["_ho"]}
        remaining = [c for c in remaining if c != top["mechanism"]]
    final_within = current.flight_pitch
    final_fit = fit_field(data, current)
    return {"baseline": {"fit": base_fit, "heldout": base_ho[False]}, "rounds": rounds, "named": named,
            "extended": heldout(cur, current, final_within),
            "extended_baseline": heldout(base_ho, FieldModel(), final_within),
            "extended_heldout": f"{k_folds}-fold {'within' if final_within else 'over'} flights",
            "final_fit": final_fit, "final_model": current, "edges": edges}
