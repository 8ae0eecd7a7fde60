"""Coordinate rotations of sonic records into streamline coordinates.

Single, double and triple rotation (McMillen, 1988; Ghirardelli et al. (2025), Sect. 4.4) per record and
the planar fit (Wilczak et al., 2001) over many records. Input components are a
right-handed earth-fixed triplet with z up (east, north, up for dronewind's L2 data);
outputs are streamline components u (along the mean wind), v (cross-wind, positive to
the left of the mean wind) and w (normal). All angles are in degrees.

Sign conventions of the returned angles (rotations of the coordinate frame):

* ``yaw_deg``: counter-clockwise angle (about z) from x to the mean horizontal wind,
  ``atan2(mean v, mean u)``;
* ``pitch_deg``: angle (about the new y) from the horizontal to the mean wind vector,
  ``atan2(mean w1, mean u1)``;
* ``roll_deg``: angle (about the new x) that zeroes ``cov(v, w)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dronewind.core.angles import rad2deg
from dronewind.errors import InputError, ProcessingError

__all__ = [
    "ROTATION_METHODS",
    "PlanarFit",
    "single_rotation",
    "double_rotation",
    "triple_rotation",
    "roll_angle_rad",
    "planar_fit_tilt",
    "apply_planar_fit",
    "BlockSums",
    "block_sums",
    "merge_block_sums",
    "means_of_block_sums",
    "block_means",
    "planar_fit_attrs",
    "planar_fit_from_attrs",
    "rotate",
]

ROTATION_METHODS = ("none", "single", "double", "triple", "planar_fit")


def _check(u: np.ndarray, v: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    u, v, w = (np.asarray(a, dtype=float) for a in (u, v, w))
    if not (u.shape == v.shape == w.shape) or u.ndim != 1 or u.size < 2:
        raise InputError("u, v, w",
                         f"expected three 1-D arrays of equal length >= 2, got {u.shape}, {v.shape}, {w.shape}")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(v)) and np.all(np.isfinite(w))):
        raise InputError("u, v, w", "rotation needs finite values (fill gaps first)")
    return u, v, w


def single_rotation(u_ms: np.ndarray, v_ms: np.ndarray, w_ms: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, float]]:
    """Rotate about z so that the mean cross-wind component vanishes.

    Parameters
    ----------
    u_ms, v_ms, w_ms : numpy.ndarray
        Components in a right-handed frame with z up [m s-1], shape (n,).

    Returns
    -------
    u, v, w : numpy.ndarray
        Rotated components [m s-1]; mean v = 0, mean u >= 0.
    angles : dict
        ``{"yaw_deg": alpha}``.

    Notes
    -----
    .. math::

        \\alpha = \\operatorname{atan2}(\\bar v, \\bar u), \\quad
        u_1 = u\\cos\\alpha + v\\sin\\alpha, \\quad v_1 = -u\\sin\\alpha + v\\cos\\alpha.

    References
    ----------
    McMillen (1988), Boundary-Layer Meteorol. 43, 231-245; Ghirardelli et al. (2025), Sect. 4.4.
    """
    u, v, w = _check(u_ms, v_ms, w_ms)
    alpha = np.arctan2(v.mean(), u.mean())
    ca, sa = np.cos(alpha), np.sin(alpha)
    return u * ca + v * sa, -u * sa + v * ca, w.copy(), {"yaw_deg": float(rad2deg(alpha))}


def double_rotation(u_ms: np.ndarray, v_ms: np.ndarray, w_ms: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, float]]:
    """Single rotation followed by a pitch rotation so that mean w = 0.

    Parameters
    ----------
    u_ms, v_ms, w_ms : numpy.ndarray
        Components in a right-handed frame with z up [m s-1].

    Returns
    -------
    u, v, w : numpy.ndarray
        Rotated components [m s-1]; mean v = mean w = 0.
    angles : dict
        ``{"yaw_deg", "pitch_deg"}``.

    Notes
    -----
    .. math::

        \\beta = \\operatorname{atan2}(\\bar w_1, \\bar u_1), \\quad
        u_2 = u_1\\cos\\beta + w_1\\sin\\beta, \\quad w_2 = -u_1\\sin\\beta + w_1\\cos\\beta.

    References
    ----------
    McMillen (1988); Ghirardelli et al. (2025), Sect. 4.4 (the method used for all its statistics).
    """
    u1, v1, w1, angles = single_rotation(u_ms, v_ms, w_ms)
    beta = np.arctan2(w1.mean(), u1.mean())
    cb, sb = np.cos(beta), np.sin(beta)
    angles["pitch_deg"] = float(rad2deg(beta))
    return u1 * cb + w1 * sb, v1, -u1 * sb + w1 * cb, angles


def roll_angle_rad(vw_m2s2: float, vv_m2s2: float, ww_m2s2: float) -> float:
    """Roll angle of the third rotation that zeroes v'w' (McMillen 1988), within +/-45 degrees.

    Parameters
    ----------
    vw_m2s2 : float
        Covariance :math:`\\overline{v'w'}` after the double rotation [m2 s-2].
    vv_m2s2, ww_m2s2 : float
        Variances :math:`\\overline{v'^2}`, :math:`\\overline{w'^2}` [m2 s-2].

    Returns
    -------
    float
        :math:`\\gamma` [rad] with :math:`\\tan 2\\gamma = 2\\overline{v'w'}/(\\overline{v'^2} -
        \\overline{w'^2})` and :math:`|\\gamma| \\le \\pi/4`; :math:`\\pm\\pi/4` when the variances are
        equal, 0 when the covariance is zero too.
    """
    gamma = 0.5 * np.arctan2(2.0 * vw_m2s2, vv_m2s2 - ww_m2s2)  # in (-pi/2, pi/2]
    if gamma > np.pi / 4:
        gamma -= np.pi / 2
    elif gamma < -np.pi / 4:
        gamma += np.pi / 2
    return float(gamma)


def triple_rotation(u_ms: np.ndarray, v_ms: np.ndarray, w_ms: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, float]]:
    """Double rotation followed by a roll rotation so that cov(v, w) = 0.

    Parameters
    ----------
    u_ms, v_ms, w_ms : numpy.ndarray
        Components in a right-handed frame with z up [m s-1].

    Returns
    -------
    u, v, w : numpy.ndarray
        Rotated components [m s-1]; mean v = mean w = 0 and v'w' = 0.
    angles : dict
        ``{"yaw_deg", "pitch_deg", "roll_deg"}``.

    Notes
    -----
    .. math::

        \\tan 2\\gamma = \\frac{2\\overline{v_2'w_2'}}{\\overline{v_2'^2} - \\overline{w_2'^2}},
        \\quad |\\gamma| \\le 45^\\circ, \\quad
        v_3 = v_2\\cos\\gamma + w_2\\sin\\gamma, \\quad w_3 = -v_2\\sin\\gamma + w_2\\cos\\gamma .

    Both roots of :math:`\\tan 2\\gamma` (90 degrees apart) make :math:`\\overline{v_3'w_3'} = 0`;
    McMillen (1988) takes the one with :math:`|\\gamma| \\le 45^\\circ`
    (:func:`roll_angle_rad`). The other root exchanges v and w: with
    :math:`\\sigma_w > \\sigma_v` the full-range ``atan2`` would pick it and turn the
    vertical component into the crosswind one. The means stay zero because the roll mixes
    only v and w, both of zero mean.

    References
    ----------
    McMillen (1988); Ghirardelli et al. (2025), Sect. 4.4.
    """
    u2, v2, w2, angles = double_rotation(u_ms, v_ms, w_ms)
    vp, wp = v2 - v2.mean(), w2 - w2.mean()
    gamma = roll_angle_rad(float(np.mean(vp * wp)), float(np.mean(vp * vp)), float(np.mean(wp * wp)))
    cg, sg = np.cos(gamma), np.sin(gamma)
    angles["roll_deg"] = float(rad2deg(gamma))
    return u2, v2 * cg + w2 * sg, -v2 * sg + w2 * cg, angles


@dataclass(frozen=True)
class PlanarFit:
    """Result of a planar fit (Wilczak et al., 2001, Eq. 39-45).

    Attributes
    ----------
    b0_ms : float
        Offset of the fitted plane, the instrument's w offset [m s-1].
    b1, b2 : float
        Plane slopes: :math:`\\bar w = b_0 + b_1 \\bar u + b_2 \\bar v` [-].
    normal : numpy.ndarray
        Unit normal of the plane (x, y, z), z > 0.
    tilt_deg : float
        Angle between the plane normal and the instrument z axis [degree].
    tilt_azimuth_deg : float
        Direction (counter-clockwise from +x) towards which the plane rises fastest [degree].
    pitch_deg, roll_deg : float
        Wilczak's angles: pitch about y, then roll about x, so that z becomes the normal.
    n_blocks : int
        Number of block means used.
    rms_residual_ms : float
        RMS of the fit residual of the block-mean w [m s-1].
    """

    b0_ms: float
    b1: float
    b2: float
    normal: np.ndarray
    tilt_deg: float
    tilt_azimuth_deg: float
    pitch_deg: float
    roll_deg: float
    n_blocks: int
    rms_residual_ms: float

    def matrix(self) -> np.ndarray:
        """(3, 3) rotation whose rows are the tilt-corrected axes (x_p, y_p, normal)."""
        k = self.normal
        # x_p: the instrument x axis projected onto the plane (pitch first, then roll).
        x_p = np.array([k[2], 0.0, -k[0]]) / np.hypot(k[0], k[2])
        y_p = np.cross(k, x_p)
        return np.vstack([x_p, y_p, k])


def planar_fit_tilt(u_mean_ms: np.ndarray, v_mean_ms: np.ndarray, w_mean_ms: np.ndarray) -> PlanarFit:
    """Fit the tilt plane of a sonic from many block means (Wilczak et al., 2001).

    Parameters
    ----------
    u_mean_ms, v_mean_ms, w_mean_ms : numpy.ndarray
        Block-mean (e.g. 30-min) components in the instrument's frame [m s-1], one per
        block; blocks with non-finite means are ignored (counted in ``n_blocks``). The
        mean wind directions should cover a wide sector for a well-posed fit.

    Returns
    -------
    PlanarFit
        The plane, its unit normal and the tilt angles.

    Notes
    -----
    Least squares over the blocks (Wilczak et al., 2001, Eq. 39):

    .. math::

        \\bar w = b_0 + b_1 \\bar u + b_2 \\bar v, \\qquad
        \\mathbf k = \\frac{(-b_1, -b_2, 1)}{\\sqrt{1 + b_1^2 + b_2^2}},

    with pitch :math:`\\sin\\alpha = -b_1/\\sqrt{1+b_1^2+b_2^2}` and roll
    :math:`\\sin\\beta = b_2/\\sqrt{1+b_2^2}` (Eq. 42-44).

    References
    ----------
    Wilczak, Oncley and Stage (2001), Boundary-Layer Meteorol. 99, 127-150.
    """
    u, v, w = (np.asarray(a, dtype=float).ravel() for a in (u_mean_ms, v_mean_ms, w_mean_ms))
    if not (u.shape == v.shape == w.shape):
        raise InputError("planar_fit_tilt", "u, v and w block means must have equal length")
    ok = np.isfinite(u) & np.isfinite(v) & np.isfinite(w)
    n = int(ok.sum())
    if n < 3:
        raise InputError("planar_fit_tilt", f"need at least 3 finite block means, got {n}")
    a = np.column_stack([np.ones(n), u[ok], v[ok]])
    coef, _, rank, _ = np.linalg.lstsq(a, w[ok], rcond=None)
    if rank < 3:
        raise ProcessingError("planar fit is ill-posed: the block-mean winds do not span a plane "
                              "(all from one direction?)")
    b0, b1, b2 = (float(c) for c in coef)
    resid = w[ok] - a @ coef
    norm = np.sqrt(1.0 + b1 * b1 + b2 * b2)
    k = np.array([-b1, -b2, 1.0]) / norm
    return PlanarFit(
        b0_ms=b0, b1=b1, b2=b2, normal=k,
        tilt_deg=float(rad2deg(np.arccos(k[2]))),
        tilt_azimuth_deg=float(rad2deg(np.arctan2(b2, b1)) % 360.0),
        pitch_deg=float(rad2deg(np.arcsin(-b1 / norm))),
        roll_deg=float(rad2deg(np.arcsin(b2 / np.sqrt(1.0 + b2 * b2)))),
        n_blocks=n,
        rms_residual_ms=float(np.sqrt(np.mean(resid ** 2))),
    )


@dataclass(frozen=True)
class BlockSums:
    """Valid-sample counts and component sums per UTC block: the mergeable part of :func:`block_means`.

    Sums of pieces of a record (one file at a time) merge exactly (:func:`merge_block_sums`),
    so the planar fit of a long record needs only one piece in memory.

    Attributes
    ----------
    index : numpy.ndarray
        Block numbers, ``floor(t / block_s)`` of the UTC time since 1970, increasing (int64).
    n_valid : numpy.ndarray
        Samples with finite u, v and w per block.
    sums : numpy.ndarray
        (3, n_blocks) sums of u, v, w over the valid samples [m s-1].
    """

    index: np.ndarray
    n_valid: np.ndarray
    sums: np.ndarray


def block_sums(time: np.ndarray, u_ms: np.ndarray, v_ms: np.ndarray, w_ms: np.ndarray,
               block_s: float = 1800.0) -> BlockSums:
    """Valid-sample counts and sums of u, v, w per block of ``block_s`` aligned to UTC.

    Parameters
    ----------
    time : numpy.ndarray
        datetime64 time stamps (UTC); gaps and breaks allowed.
    u_ms, v_ms, w_ms : numpy.ndarray
        Components, NaN where flagged [m s-1].
    block_s : float
        Block length [s]; blocks start at multiples of ``block_s`` since 1970-01-01T00Z.

    Returns
    -------
    BlockSums
    """
    t_ns = np.asarray(time).astype("datetime64[ns]").astype(np.int64)
    u, v, w = (np.asarray(a, dtype=float) for a in (u_ms, v_ms, w_ms))
    block = t_ns // int(round(block_s * 1e9))
    ok = np.isfinite(u) & np.isfinite(v) & np.isfinite(w)
    index, inverse = np.unique(block, return_inverse=True)
    n_valid = np.bincount(inverse, weights=ok.astype(float), minlength=index.size)
    sums = np.stack([np.bincount(inverse, weights=np.where(ok, a, 0.0), minlength=index.size) for a in (u, v, w)])
    return BlockSums(index.astype(np.int64), n_valid, sums)


def merge_block_sums(parts: list[BlockSums]) -> BlockSums:
    """Merge the block sums of pieces of one record (a block split between pieces is summed).

    Parameters
    ----------
    parts : list of BlockSums
        From :func:`block_sums` with the same ``block_s``.

    Returns
    -------
    BlockSums
    """
    if not parts:
        return BlockSums(np.empty(0, np.int64), np.empty(0), np.empty((3, 0)))
    index, inverse = np.unique(np.concatenate([p.index for p in parts]), return_inverse=True)
    n_valid = np.bincount(inverse, weights=np.concatenate([p.n_valid for p in parts]), minlength=index.size)
    stacked = np.concatenate([p.sums for p in parts], axis=1)
    sums = np.stack([np.bincount(inverse, weights=row, minlength=index.size) for row in stacked])
    return BlockSums(index.astype(np.int64), n_valid, sums)


def means_of_block_sums(sums: BlockSums, fs_hz: float, block_s: float = 1800.0, min_valid_fraction: float = 0.5
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Block means of the blocks with at least ``min_valid_fraction`` valid samples.

    Parameters
    ----------
    sums : BlockSums
        From :func:`block_sums` or :func:`merge_block_sums`.
    fs_hz : float
        Sampling rate [Hz].
    block_s : float
        Block length [s] of ``sums``.
    min_valid_fraction : float
        A block counts when at least this fraction of its ``block_s * fs_hz`` samples is valid [1].

    Returns
    -------
    u, v, w : numpy.ndarray
        Block means of the usable blocks [m s-1].
    """
    usable = sums.n_valid >= min_valid_fraction * block_s * fs_hz
    u, v, w = (row[usable] / sums.n_valid[usable] for row in sums.sums)
    return u, v, w


def block_means(time: np.ndarray, u_ms: np.ndarray, v_ms: np.ndarray, w_ms: np.ndarray,
                block_s: float = 1800.0, min_valid_fraction: float = 0.5, fs_hz: float | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Block means of a long record for the planar fit (Wilczak et al., 2001).

    Parameters
    ----------
    time : numpy.ndarray
        datetime64 time stamps (UTC), increasing; gaps and breaks allowed.
    u_ms, v_ms, w_ms : numpy.ndarray
        Components in the instrument's (or the east/north/up) frame, NaN where flagged [m s-1].
    block_s : float
        Block length [s], aligned to multiples of ``block_s`` of UTC (30 min by default).
    min_valid_fraction : float
        A block counts when at least this fraction of its samples is valid [1].
    fs_hz : float, optional
        Sampling rate [Hz]; by default from the median time step.

    Returns
    -------
    u, v, w : numpy.ndarray
        Block means of the usable blocks [m s-1] (:func:`block_sums`, :func:`means_of_block_sums`).
    """
    if fs_hz is None:
        t_ns = np.asarray(time).astype("datetime64[ns]").astype(np.int64)
        fs_hz = 1e9 / float(np.median(np.diff(t_ns)))
    return means_of_block_sums(block_sums(time, u_ms, v_ms, w_ms, block_s), fs_hz, block_s, min_valid_fraction)


def planar_fit_attrs(fit: PlanarFit | None, note: str = "") -> dict[str, float | int | str]:
    """NetCDF attributes holding a planar fit (or why there is none)."""
    if fit is None:
        return {"planar_fit_note": note or "not computed"}
    return {"planar_fit_b0_ms": fit.b0_ms, "planar_fit_b1": fit.b1, "planar_fit_b2": fit.b2,
            "planar_fit_n_blocks": int(fit.n_blocks), "planar_fit_tilt_deg": fit.tilt_deg,
            "planar_fit_rms_residual_ms": fit.rms_residual_ms,
            "planar_fit_note": note or "Wilczak et al. (2001) over the 30-min block means of this record"}


def planar_fit_from_attrs(attrs: dict) -> PlanarFit | None:
    """Rebuild a planar fit stored by :func:`planar_fit_attrs` (None when there is none)."""
    if "planar_fit_b1" not in attrs:
        return None
    b0, b1, b2 = (float(attrs[k]) for k in ("planar_fit_b0_ms", "planar_fit_b1", "planar_fit_b2"))
    norm = np.sqrt(1.0 + b1 * b1 + b2 * b2)
    k = np.array([-b1, -b2, 1.0]) / norm
    return PlanarFit(b0_ms=b0, b1=b1, b2=b2, normal=k, tilt_deg=float(rad2deg(np.arccos(k[2]))),
                     tilt_azimuth_deg=float(rad2deg(np.arctan2(b2, b1)) % 360.0),
                     pitch_deg=float(rad2deg(np.arcsin(-b1 / norm))),
                     roll_deg=float(rad2deg(np.arcsin(b2 / np.sqrt(1.0 + b2 * b2)))),
                     n_blocks=int(attrs.get("planar_fit_n_blocks", 0)),
                     rms_residual_ms=float(attrs.get("planar_fit_rms_residual_ms", np.nan)))


def apply_planar_fit(u_ms: np.ndarray, v_ms: np.ndarray, w_ms: np.ndarray, fit: PlanarFit,
                     yaw: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, float]]:
    """Remove the planar-fit tilt (and optionally rotate into the mean wind).

    Parameters
    ----------
    u_ms, v_ms, w_ms : numpy.ndarray
        One record in the instrument's frame [m s-1].
    fit : PlanarFit
        From :func:`planar_fit_tilt` over many records of the same instrument.
    yaw : bool
        If True (default), follow with a rotation about the plane normal so that mean
        v = 0 (Wilczak et al., 2001, Eq. 45).

    Returns
    -------
    u, v, w : numpy.ndarray
        Components in the plane frame [m s-1]; w is relative to the plane, i.e. the offset
        b0 is removed (mean w is not forced to zero).
    angles : dict
        ``{"yaw_deg", "pitch_deg", "roll_deg", "tilt_deg"}`` (pitch/roll of the plane).

    References
    ----------
    Wilczak, Oncley and Stage (2001), Eq. 45.
    """
    u, v, w = _check(u_ms, v_ms, w_ms)
    p = fit.matrix()
    x = np.stack([u, v, w - fit.b0_ms])
    up, vp, wp = p @ x
    angles = {"pitch_deg": fit.pitch_deg, "roll_deg": fit.roll_deg, "tilt_deg": fit.tilt_deg, "yaw_deg": 0.0}
    if yaw:
        up, vp, wp, yaw_angles = single_rotation(up, vp, wp)
        angles["yaw_deg"] = yaw_angles["yaw_deg"]
    return up, vp, wp, angles


def rotate(u_ms: np.ndarray, v_ms: np.ndarray, w_ms: np.ndarray, method: str = "double",
           planar_fit: PlanarFit | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, float]]:
    """Rotate one record into streamline coordinates with a method chosen by name.

    Parameters
    ----------
    u_ms, v_ms, w_ms : numpy.ndarray
        Components in a right-handed frame with z up [m s-1].
    method : {"none", "single", "double", "triple", "planar_fit"}
        Rotation method; "double" is the choice of Ghirardelli et al. (2025), Sect. 4.4.
    planar_fit : PlanarFit, optional
        Required for ``method="planar_fit"``.

    Returns
    -------
    u, v, w : numpy.ndarray
        Rotated components [m s-1].
    angles : dict
        Angles of the rotation [degree] (keys yaw_deg, pitch_deg, roll_deg; missing
        angles are 0).

    References
    ----------
    McMillen (1988); Wilczak et al. (2001); Ghirardelli et al. (2025), Sect. 4.4.
    """
    out: tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, float]]
    if method == "none":
        u, v, w = _check(u_ms, v_ms, w_ms)
        out = (u.copy(), v.copy(), w.copy(), {})
    elif method == "single":
        out = single_rotation(u_ms, v_ms, w_ms)
    elif method == "double":
        out = double_rotation(u_ms, v_ms, w_ms)
    elif method == "triple":
        out = triple_rotation(u_ms, v_ms, w_ms)
    elif method == "planar_fit":
        if planar_fit is None:
            raise InputError("rotation", "method 'planar_fit' needs a PlanarFit from planar_fit_tilt over many records")
        out = apply_planar_fit(u_ms, v_ms, w_ms, planar_fit)
    else:
        raise InputError("rotation", f"unknown rotation method {method!r}; expected one of {ROTATION_METHODS}")
    angles = {"yaw_deg": 0.0, "pitch_deg": 0.0, "roll_deg": 0.0}
    angles.update(out[3])
    return out[0], out[1], out[2], angles
