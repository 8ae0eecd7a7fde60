"""Wind of the independent world: a Mann turbulence box advected past the mast and the payload.

One box per flight holds both sensors (Taylor's frozen-turbulence hypothesis: the box moves
with the mean wind at the reference height, so an along-wind separation becomes a time
shift, a crosswind or vertical one a place in the box). The box comes from hipersim
(Mann 1994, 1998, the DTU implementation), not from a generator written here. The mean wind
is a Monin-Obukhov log profile with the Högström (1988) stability functions, which the
forward model of the diagnosis does not use (its own similarity choices live in
``dronewind.simulate``).

References
----------
Mann, J. (1994): The spatial structure of neutral atmospheric surface-layer turbulence.
J. Fluid Mech. 273, 141-168 (L = 0.59 z and Gamma = 3.9 fitted near the ground).
Mann, J. (1998): Wind field simulation. Probab. Eng. Mech. 13, 269-282.
Högström, U. (1988): Non-dimensional wind and temperature profiles in the atmospheric
surface layer: a re-evaluation. Boundary-Layer Meteorol. 42, 55-78 (phi_m = (1 - 19.3 zeta)^(-1/4)
unstable, 1 + 6 zeta stable).
Panofsky, H. A., Tennekes, H., Lenschow, D. H., Wyngaard, J. C. (1977): The characteristics
of turbulent velocity components in the surface layer under convective conditions.
Boundary-Layer Meteorol. 11, 355-361 (sigma_u / u* = (12 - 0.5 z_i / L)^(1/3)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import map_coordinates

KAPPA = 0.4
GRAVITY_MS2 = 9.81


def psi_m(zeta: float | np.ndarray) -> np.ndarray:
    """Integrated stability function for momentum, Högström (1988) coefficients.

    Unstable (zeta < 0): Paulson's integral of phi_m = (1 - 19.3 zeta)^(-1/4); stable:
    -6 zeta (phi_m = 1 + 6 zeta).
    """
    z = np.asarray(zeta, dtype=float)
    x = np.power(np.clip(1.0 - 19.3 * np.minimum(z, 0.0), 1.0, None), 0.25)
    unstable = 2 * np.log((1 + x) / 2) + np.log((1 + x * x) / 2) - 2 * np.arctan(x) + math.pi / 2
    return np.where(z < 0, unstable, -6.0 * z)


def friction_velocity_ms(speed_ms: float, z_m: float, z0_m: float, obukhov_m: float) -> float:
    """u* of a log profile through ``speed_ms`` at ``z_m`` (roughness ``z0_m``, Obukhov length)."""
    return float(KAPPA * speed_ms / (math.log(z_m / z0_m) - psi_m(z_m / obukhov_m) + psi_m(z0_m / obukhov_m)))


def profile_speed_ms(z_m: np.ndarray, ustar_ms: float, z0_m: float, obukhov_m: float) -> np.ndarray:
    """Mean wind speed of the Monin-Obukhov log profile at heights ``z_m``."""
    z = np.maximum(np.asarray(z_m, dtype=float), 2 * z0_m)
    return ustar_ms / KAPPA * (np.log(z / z0_m) - psi_m(z / obukhov_m) + psi_m(z0_m / obukhov_m))


def sigma_u_ms(ustar_ms: float, obukhov_m: float, zi_m: float = 1000.0) -> float:
    """Streamwise standard deviation: Panofsky et al. (1977) in unstable air, its neutral
    limit 12^(1/3) = 2.29 u* otherwise."""
    conv = -0.5 * zi_m / obukhov_m if obukhov_m < 0 else 0.0
    return float(ustar_ms * (12.0 + conv) ** (1.0 / 3.0))


def mann_length_m(z_m: float, zeta: float) -> float:
    """Mann length scale: 0.59 z (Mann 1994, neutral), longer in unstable and shorter in
    stable air (the world's own choice, after the trends of Peña et al. 2010, Boundary-Layer
    Meteorol. 134, 243-262)."""
    factor = (1.0 - 2.0 * zeta) ** 0.25 if zeta < 0 else 1.0 / (1.0 + 2.0 * zeta)
    return 0.59 * z_m * factor


@dataclass
class WindField:
    """A Mann box carried by a mean wind past fixed and moving points (east, north, up from the mast foot).

    Across and up the wind the field is taken at the grid node nearest the place asked
    for (callers ask at a sensor's nominal place, so its node does not change): linear
    interpolation between nodes 4 m apart would average partly incoherent turbulence and take
    small-scale energy from a sensor between nodes (measured: three quarters of the 1.5-3 Hz
    power halfway between nodes), but none from one on a node. Along the wind (0.2-0.6 m
    spacing) it is linear.

    The box's coarse crosswind grid holds little of the inertial subrange above about 1 Hz at
    the sensors (its 30 m spectra fall with slopes of -2.2 to -2.5 over 1-3 Hz); with ``topup``
    each sensor's record gets, on top, an independent series with the spectrum the box lacks
    there (:func:`inertial_deficit`, :meth:`topup_enu`): eddies that small are incoherent over
    the drone-mast separation.

    Attributes
    ----------
    uvw : numpy.ndarray
        (3, nx, ny, nz) turbulence [m s-1]: along the initial mean wind, to its left, up.
    dxyz_m : tuple of float
        Box spacing [m].
    z_bottom_m : float
        Height of the box's first vertical level [m].
    y_centre_m : float
        Crosswind box coordinate of the mast [m].
    x_offset_m : float
        Box coordinate of the mast at t = 0 [m].
    speed_ms, wind_from_deg : float
        Mean wind at ``z_ref_m`` at t = 0 (speed; direction it blows from, clockwise from north).
    z_ref_m, ustar_ms, z0_m, obukhov_m : float
        Reference height and the log profile.
    speed_trend_ms_per_s, direction_trend_deg_per_s : float
        Linear trends of the mean wind (0: stationary).
    theta_k : float
        Mean potential temperature [K].
    heat_w_gain_k_per_ms, heat_v_gain_k_per_ms : float
        Temperature fluctuation theta' = a w' + b v' (a sets the heat flux of the Obukhov
        length; the v' part, uncorrelated with w' in the Mann model, the rest of its variance).
    """

    uvw: np.ndarray
    dxyz_m: tuple[float, float, float]
    z_bottom_m: float
    y_centre_m: float
    x_offset_m: float
    speed_ms: float
    wind_from_deg: float
    z_ref_m: float
    ustar_ms: float
    z0_m: float
    obukhov_m: float
    speed_trend_ms_per_s: float = 0.0
    direction_trend_deg_per_s: float = 0.0
    theta_k: float = 293.0
    heat_w_gain_k_per_ms: float = 0.0
    heat_v_gain_k_per_ms: float = 0.0
    #: inertial-subrange top-up (:func:`inertial_deficit`): wavenumbers [rad m-1] and the
    #: spectra the box lacks there (3, nk) [m3 s-2]; None: the box alone
    topup: tuple[np.ndarray, np.ndarray] | None = None

    def _axes(self, wind_from_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unit vectors (east, north) along the wind (towards) and to its left."""
        a = np.radians(wind_from_deg)
        ex = np.stack([-np.sin(a), -np.cos(a)], axis=-1)
        ey = np.stack([np.cos(a), -np.sin(a)], axis=-1)
        return ex, ey

    def turbulence(self, t_s: np.ndarray, east_m: np.ndarray, north_m: np.ndarray, up_m: np.ndarray
                   ) -> np.ndarray:
        """Box turbulence (u along, v left, w up) at times and places, trilinear in the box. (n, 3)."""
        ex, ey = self._axes(np.array(self.wind_from_deg))
        along = east_m * ex[0] + north_m * ex[1]
        cross = east_m * ey[0] + north_m * ey[1]
        dx, dy, dz = self.dxyz_m
        coords = np.stack([(self.x_offset_m + self.speed_ms * t_s - along) / dx,
                           np.round((self.y_centre_m + cross) / dy),
                           np.round((np.asarray(up_m) - self.z_bottom_m) / dz)])
        return np.stack([map_coordinates(self.uvw[c], coords, order=1, mode="grid-wrap") for c in range(3)],
                        axis=-1)

    def topup_enu(self, rng: np.random.Generator, n: int, fs_hz: float) -> np.ndarray:
        r"""The inertial-subrange top-up of one sensor's record (east, north, up) [m s-1], (n, 3); zeros without it.

        Each component is Gaussian with the one-sided frequency spectrum
        :math:`S(f) = D(k_1)\,2\pi/U` at :math:`k_1 = 2\pi f/U` (Taylor), :math:`D` the box's
        deficit (:func:`inertial_deficit`), synthesised with random phases over the record.
        """
        out = np.zeros((n, 3))
        if self.topup is None or n < 4:
            return out
        k_grid, deficit = self.topup
        f_hz = np.fft.rfftfreq(n, 1.0 / fs_hz)
        k = 2 * np.pi * f_hz / self.speed_ms
        df = fs_hz / n
        turb = np.empty((n, 3))
        for c in range(3):
            s = np.interp(k, k_grid, deficit[c], right=0.0) * 2 * np.pi / self.speed_ms
            s[0] = 0.0
            if n % 2 == 0:
                s[-1] = 0.0
            coef = n * np.sqrt(s * df / 4.0) * (rng.standard_normal(k.size) + 1j * rng.standard_normal(k.size))
            turb[:, c] = np.fft.irfft(coef, n)
        ex, ey = self._axes(np.array(self.wind_from_deg))
        out[:, 0] = turb[:, 0] * ex[0] + turb[:, 1] * ey[0]
        out[:, 1] = turb[:, 0] * ex[1] + turb[:, 1] * ey[1]
        out[:, 2] = turb[:, 2]
        return out

    def sample(self, t_s: np.ndarray, east_m: np.ndarray, north_m: np.ndarray, up_m: np.ndarray,
               turbulence_at: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
        """Wind (east, north, up) [m s-1] and potential temperature [K] at times and places.

        The mean wind follows the log profile at each height, scaled by the speed trend and
        turned by the direction trend; the turbulence turns with the mean wind. It is taken
        at ``turbulence_at`` (east, north, up) when given (a moving sensor's place along the
        wind with its nominal crosswind and vertical place), else at the places.
        """
        t_s, east_m, north_m, up_m = np.broadcast_arrays(*(np.asarray(a, dtype=float)
                                                           for a in (t_s, east_m, north_m, up_m)))
        where = (east_m, north_m, up_m) if turbulence_at is None else \
            tuple(np.broadcast_to(np.asarray(a, dtype=float), t_s.shape) for a in turbulence_at)
        turb = self.turbulence(t_s, *where)
        scale = 1.0 + self.speed_trend_ms_per_s * t_s / self.speed_ms
        mean = profile_speed_ms(up_m, self.ustar_ms, self.z0_m, self.obukhov_m) * scale
        direction = self.wind_from_deg + self.direction_trend_deg_per_s * t_s
        ex, ey = self._axes(direction)
        u = mean + turb[:, 0]
        wind = np.empty(turb.shape)
        wind[:, 0] = u * ex[..., 0] + turb[:, 1] * ey[..., 0]
        wind[:, 1] = u * ex[..., 1] + turb[:, 1] * ey[..., 1]
        wind[:, 2] = turb[:, 2]
        theta = self.theta_k + self.heat_w_gain_k_per_ms * turb[:, 2] + self.heat_v_gain_k_per_ms * turb[:, 1]
        return wind, theta


def mann_box(length_scale_m: float, gamma: float, sigma_u_ms: float, nxyz: tuple[int, int, int],
             dxyz_m: tuple[float, float, float], seed: int) -> np.ndarray:
    """A Mann turbulence box (hipersim) scaled to a streamwise standard deviation.

    hipersim's alphaepsilon scales the variance linearly; the box is generated at 1 and
    scaled so that its u variance over the whole box is ``sigma_u_ms`` squared (v and w keep
    the Mann model's ratios for this ``gamma``). Periodic in all three directions (no
    doubling), which the crosswind width of 16 spacings keeps well beyond the length scale.
    High-frequency compensation (hipersim's fast method) restores the variance the coarse
    crosswind grid would lose.

    Returns
    -------
    numpy.ndarray
        (3, nx, ny, nz) float32.
    """
    from hipersim import MannTurbulenceField

    field = MannTurbulenceField.generate(alphaepsilon=1.0, L=float(length_scale_m), Gamma=float(gamma),
                                         Nxyz=tuple(int(n) for n in nxyz), dxyz=tuple(float(d) for d in dxyz_m),
                                         seed=int(seed) % (2**31 - 1), HighFreqComp=1,
                                         double_xyz=(False, False, False), n_cpu=1)
    uvw = np.asarray(field.uvw, dtype=np.float32)
    uvw -= uvw.mean(axis=(1, 2, 3), keepdims=True)
    return uvw * np.float32(sigma_u_ms / float(uvw[0].std()))


def box_spectra(uvw: np.ndarray, dx_m: float) -> tuple[np.ndarray, np.ndarray]:
    """One-sided along-wind wavenumber spectra of a box's u, v, w, averaged over its lines.

    Returns
    -------
    k_rad_m : numpy.ndarray
        Wavenumbers [rad m-1], (nk,).
    spectra : numpy.ndarray
        (3, nk) [m3 s-2]: each component's variance is their sum times the wavenumber step.
    """
    n = uvw.shape[1]
    dk = 2 * np.pi / (n * dx_m)
    power = np.zeros((3, n // 2 + 1))
    for c in range(3):  # one component at a time: the transform of the box is large
        power[c] = np.mean(np.abs(np.fft.rfft(uvw[c].astype(float), axis=0)) ** 2, axis=(1, 2))
    spectra = 2.0 * power / (n * n * dk)
    spectra[:, 0] = 0.0
    return np.arange(n // 2 + 1) * dk, spectra


#: Wavenumbers [rad m-1] where the box is in the inertial subrange and resolved (4 m crosswind
#: spacing: crosswind wavelengths down to 8 m), where its level is read (:func:`inertial_deficit`).
INERTIAL_FIT_RAD_M = (0.3, 0.8)


def inertial_deficit(k_rad_m: np.ndarray, spectra: np.ndarray,
                     fit_rad_m: tuple[float, float] = INERTIAL_FIT_RAD_M, k_max_rad_m: float = 200.0
                     ) -> tuple[np.ndarray, np.ndarray]:
    r"""What a box lacks of the inertial subrange above its resolved band, per component.

    The level :math:`C` of :math:`F(k_1) = C k_1^{-5/3}` (Kolmogorov) is the median of
    :math:`F k_1^{5/3}` over ``fit_rad_m``; above that band the deficit is
    :math:`\max(0, C k_1^{-5/3} - F)`, and beyond the box's Nyquist wavenumber all of
    :math:`C k_1^{-5/3}` (up to ``k_max_rad_m``).

    Returns
    -------
    k_rad_m : numpy.ndarray
        Wavenumbers [rad m-1] (the box's, then a logarithmic extension).
    deficit : numpy.ndarray
        (3, nk) [m3 s-2].
    """
    band = (k_rad_m >= fit_rad_m[0]) & (k_rad_m <= fit_rad_m[1])
    level = np.median(spectra[:, band] * k_rad_m[band] ** (5.0 / 3.0), axis=1)
    extra = np.geomspace(k_rad_m[-1] * 1.01, k_max_rad_m, 200)
    k = np.concatenate([k_rad_m, extra])
    box = np.concatenate([spectra, np.zeros((3, extra.size))], axis=1)
    law = level[:, None] * np.where(k > 0, k, np.inf) ** (-5.0 / 3.0)
    deficit = np.where(k[None, :] > fit_rad_m[1], np.maximum(law - box, 0.0), 0.0)
    return k, deficit


def heat_gains(ustar_ms: float, obukhov_m: float, theta_k: float, sigma_w_ms: float, sigma_v_ms: float
               ) -> tuple[float, float]:
    """Gains a, b of theta' = a w' + b v' giving the kinematic heat flux of the Obukhov length,
    w'theta' = -u*^3 theta / (kappa g L), with w'-theta' correlation 1/sqrt(2)."""
    flux = 0.0 if math.isinf(obukhov_m) else -ustar_ms**3 * theta_k / (KAPPA * GRAVITY_MS2 * obukhov_m)
    a = flux / max(sigma_w_ms**2, 1e-6)
    return a, abs(a) * sigma_w_ms / max(sigma_v_ms, 1e-6)
