"""dronewind.core.angles gives numpy's conversions and wraps bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from dronewind.core import angles

EDGES = np.array([0.0, -0.0, 1e-300, -1e-300, 5e-324, -5e-324, 180.0, -180.0, 359.99999999999994, 360.0, -360.0,
                  720.0, 1e308, -1e308, np.nan, np.inf, -np.inf, np.nextafter(360.0, 0.0), np.nextafter(0.0, -1.0)])


def _series(rng: np.random.Generator) -> list[np.ndarray]:
    return [rng.normal(0, 5, 10_000), rng.uniform(-720, 720, 10_000), rng.uniform(0, 360, 10_000),
            rng.uniform(-180, 180, 10_000), rng.uniform(-1e-6, 1e-6, 1000), EDGES, np.zeros(0),
            rng.uniform(0, 360, (50, 3)), np.where(rng.random(1000) < 0.5, -0.0, 0.0)]


@pytest.mark.parametrize("seed", [0, 1])
def test_conversions_are_numpys(seed: int) -> None:
    with np.errstate(over="ignore", invalid="ignore"):
        for x in _series(np.random.default_rng(seed)):
            assert angles.deg2rad(x).tobytes() == np.deg2rad(x).tobytes()
            assert angles.rad2deg(x).tobytes() == np.rad2deg(x).tobytes()
            assert angles.deg2rad(x).tobytes() == np.radians(x).tobytes()
            assert angles.rad2deg(x).tobytes() == np.degrees(x).tobytes()
    for v in (12.5, -0.0, 1e-310):
        assert np.float64(angles.deg2rad(v)).tobytes() == np.deg2rad(v).tobytes()
    x32 = np.linspace(-400, 400, 1001, dtype=np.float32)  # other dtypes are numpy's own
    assert angles.deg2rad(x32).dtype == np.float32 and angles.deg2rad(x32).tobytes() == np.deg2rad(x32).tobytes()
    assert angles.rad2deg(np.arange(5)).tobytes() == np.rad2deg(np.arange(5)).tobytes()


@pytest.mark.parametrize("seed", [0, 1])
def test_wraps_are_numpys(seed: int) -> None:
    with np.errstate(invalid="ignore"):
        for x in _series(np.random.default_rng(seed)):
            assert angles.wrap_360(x).tobytes() == np.mod(x, 360.0).tobytes()
            assert angles.wrap_180(x).tobytes() == ((x + 180.0) % 360.0 - 180.0).tobytes()
    x = np.array([10.0, 20.0])
    y = angles.wrap_360(x)
    assert y is not x and not np.shares_memory(x, y)
