"""The INS of the independent world: an aided inertial navigation system's errors.

* attitude: per axis a gyro bias (a residual left by the filter's estimate, then a random
  walk), integrated into an attitude error that the aiding (gravity for roll and pitch, the
  dual-antenna GNSS heading for yaw) pulls back with a time constant (a first-order
  complementary filter), plus white noise;

Sizes: the SBG Ellipse-D of the SAMURAI-S payload (Ghirardelli et al. 2025, Table 3: roll
and pitch 0.05 degree, heading 0.4 degree, velocity 0.03 m/s, position 0.01 m horizontal
and 0.02 m vertical with RTK); the residual biases times the aiding time constants give
those attitude errors.
* velocity: first-order Gauss-Markov errors of the GNSS-aided filter (Gelb 1974, Applied
  Optimal Estimation, Sect. 3.8), horizontal and vertical;
* position: a Gauss-Markov error (GNSS multipath and atmosphere) plus white noise;
* GNSS time: invalid at start-up, blinking valid for a moment, then valid for good
  (docs/data-contract.md, "Payload INS"); the filter valid after its own start-up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter


@dataclass(frozen=True)
class InsErrors:
    """Error settings (SI units and degrees)."""

    residual_bias_deg_per_s: tuple[float, float, float] = (0.0025, 0.0025, 0.0067)
    gyro_bias_walk_deg_per_s15: float = 2e-5
    roll_pitch_aiding_s: float = 20.0
    yaw_aiding_s: float = 60.0
    attitude_noise_deg: float = 0.01
    velocity_sigma_h_ms: float = 0.03
    velocity_sigma_v_ms: float = 0.03
    velocity_tau_s: float = 15.0
    position_sigma_h_m: float = 0.01
    position_sigma_v_m: float = 0.02
    position_tau_s: float = 120.0
    position_noise_m: float = 0.005


def gauss_markov(rng: np.random.Generator, n: int, dt_s: float, sigma: float, tau_s: float) -> np.ndarray:
    """A stationary first-order Gauss-Markov sequence (exact discretisation, AR(1))."""
    a = math.exp(-dt_s / tau_s)
    x = lfilter([sigma * math.sqrt(1 - a * a)], [1.0, -a], rng.standard_normal(n))
    # start in the stationary state: add the decaying response to a stationary initial value
    return x + sigma * rng.standard_normal() * a ** np.arange(1, n + 1)


def attitude_errors_deg(rng: np.random.Generator, n: int, dt_s: float, errors: InsErrors) -> np.ndarray:
    """Roll, pitch, yaw errors [degree], (n, 3): e' = b - e / tau with b a random walk."""
    out = np.empty((n, 3))
    for k, tau in enumerate((errors.roll_pitch_aiding_s, errors.roll_pitch_aiding_s, errors.yaw_aiding_s)):
        bias = errors.residual_bias_deg_per_s[k] * rng.standard_normal() + \
            np.cumsum(errors.gyro_bias_walk_deg_per_s15 * math.sqrt(dt_s) * rng.standard_normal(n))
        a = math.exp(-dt_s / tau)
        # e' = b - e / tau, started at its steady state b tau
        out[:, k] = lfilter([dt_s], [1.0, -a], bias, zi=[a * bias[0] * tau])[0] + \
            errors.attitude_noise_deg * rng.standard_normal(n)
    return out


def velocity_errors_ms(rng: np.random.Generator, n: int, dt_s: float, errors: InsErrors) -> np.ndarray:
    """North, east, down velocity errors [m s-1], (n, 3)."""
    return np.stack([gauss_markov(rng, n, dt_s, s, errors.velocity_tau_s)
                     for s in (errors.velocity_sigma_h_ms, errors.velocity_sigma_h_ms, errors.velocity_sigma_v_ms)],
                    axis=1)


def position_errors_m(rng: np.random.Generator, n: int, dt_s: float, errors: InsErrors) -> np.ndarray:
    """East, north, up position errors [m], (n, 3)."""
    return np.stack([gauss_markov(rng, n, dt_s, s, errors.position_tau_s)
                     + errors.position_noise_m * rng.standard_normal(n)
                     for s in (errors.position_sigma_h_m, errors.position_sigma_h_m, errors.position_sigma_v_m)],
                    axis=1)


def gnss_time_valid(t_s: np.ndarray, valid_from_s: float, blink_s: tuple[float, float]) -> np.ndarray:
    """``time_valid``: 0 before ``valid_from_s`` except during the blink (start, end), then 1."""
    valid = t_s >= valid_from_s
    valid |= (t_s >= blink_s[0]) & (t_s < blink_s[1])
    return valid.astype(np.int8)
