"""Long mast records, and the CF/ACDD compliance check of a product."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import cpu_round

FS_HZ = 20.0
HOURS_PER_FILE = 2.0
N_FILES = 2
SONIC = {"id": "csat3_30m", "height_m": 30.0, "azimuth_deg": 218.0}


def _ar1(rng, n: int, mean: float, sigma: float, tau_s: float) -> np.ndarray:
    import scipy.signal

    phi = float(np.exp(-1.0 / (tau_s * FS_HZ)))
    return mean + scipy.signal.lfilter([1.0], [1.0, -phi], rng.normal(0.0, sigma * np.sqrt(1.0 - phi**2), n))


@pytest.fixture(scope="module")
def long_record_files(tmp_path_factory):
    """Consecutive TOA5 files of synthetic 20 Hz CSAT3 turbulence (AR(1) components; not timed)."""
    from dronewind.simulate.writers import write_toa5

    folder = tmp_path_factory.mktemp("bench_long")
    rng = np.random.default_rng(20230801)
    n = int(HOURS_PER_FILE * 3600 * FS_HZ)
    t0 = np.datetime64("2023-08-01T00:00:00", "ns")
    files = []
    for i in range(N_FILES):
        k = i * n + np.arange(n)
        t = t0 + (k * int(1e9 / FS_HZ)).astype("timedelta64[ns]")
        files.append(write_toa5(folder / f"mast30_{i:02d}.dat", t, k, _ar1(rng, n, -4.0, 0.9, 8.0),
                                _ar1(rng, n, 1.0, 0.7, 8.0), _ar1(rng, n, 0.0, 0.35, 1.0),
                                _ar1(rng, n, 20.0, 0.25, 10.0), np.zeros(n, dtype=np.int64)))
    return files


def test_long_record(benchmark, long_record_files, tmp_path):
    """Files of a long 20 Hz record to L1 per file, 30-min blocks and block_stats.csv, in bounded memory."""
    from dronewind.compare.long_record import process_long_record

    rounds = iter(range(100))
    res, cpu = cpu_round(benchmark, lambda: process_long_record(long_record_files, tmp_path / f"r{next(rounds)}",
                                                                SONIC, {}, record="bench"), rounds=2)
    benchmark.extra_info.update(samples=res.n_samples, blocks=res.n_blocks,
                                samples_per_cpu_s=round(res.n_samples / cpu),
                                record_hours_per_cpu_s=round(res.n_samples / FS_HZ / 3600.0 / cpu, 2))


def test_compliance_of_a_file(benchmark, flight):
    """CF-1.11 and ACDD-1.3 check (IOOS compliance checker, normal criteria) of one flight's L3 file."""
    from compliance_checker.runner import CheckSuite

    from dronewind.core.compliance import check_files

    CheckSuite().load_all_available_checkers()
    path = str(flight.products["l3"])
    found, cpu = cpu_round(benchmark, check_files, ("cf:1.11", "acdd:1.3"), "normal", [path], rounds=3)
    assert found[path][0], found[path][1][-2000:]
    benchmark.extra_info.update(file_mb=round(flight.products["l3"].stat().st_size / 1e6, 2),
                                files_per_cpu_min=round(60.0 / cpu, 1))
