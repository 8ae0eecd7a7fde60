"""Parsing: each raw format read to its L1 (or in-memory log), in rows and bytes per second."""

from __future__ import annotations

from conftest import cpu_round


def _sizes(files) -> int:
    return sum(f.stat().st_size for f in files)


def test_toa5_mast_sonic(benchmark, real_record):
    """Campbell TOA5: the two 15-min CSAT3 files of the fluxpart record (20 Hz) to mast L1."""
    from dronewind.mast import level1

    files = sorted(real_record("fluxpart_csat3_toa5").glob("TOA5_*.dat"))
    ds, cpu = cpu_round(benchmark, level1.mast_l1, files, azimuth_deg=0.0, height_m=7.11, sensor_id="fluxpart",
                        rounds=5)
    n = ds.sizes["time"]
    benchmark.extra_info.update(rows=n, rows_per_cpu_s=round(n / cpu), mb_per_cpu_s=round(_sizes(files) / 1e6 / cpu, 2))


def test_payload_csv(benchmark, flight, setup):
    """Payload sonic and INS CSV of a 20-min hover (32 Hz sonic, 50 Hz INS) to sonic and INS L1."""
    from dronewind.payload.chain import compute_payload_l1

    files = [flight.raw["sonic"], flight.raw["ins"]]
    (sonic, ins), cpu = cpu_round(benchmark, compute_payload_l1, *files, setup["processing"]["despike"])
    n = sonic.sizes["time"] + ins.sizes["time"]
    benchmark.extra_info.update(rows=n, rows_per_cpu_s=round(n / cpu), mb_per_cpu_s=round(_sizes(files) / 1e6 / cpu, 2))


def test_px4_ulog(benchmark, real_record):
    """PX4 ULog: the 4 MB bench log to the quadrotor L1 record."""
    from dronewind.quadrotor.io import read_quadrotor

    path = real_record("px4_ulog") / "sample.ulg"
    ds, cpu = cpu_round(benchmark, read_quadrotor, path, rounds=5)
    benchmark.extra_info.update(rows=ds.sizes["time"], mb_per_cpu_s=round(path.stat().st_size / 1e6 / cpu, 2))


def test_ardupilot_dataflash(benchmark, real_record):
    """ArduPilot DataFlash: the 3.3 MB Finse hover log to the quadrotor L1 record."""
    from dronewind.quadrotor.io import read_quadrotor

    path = real_record("ardupilot_dataflash") / "finse_2023-03-28_0602.bin"
    ds, cpu = cpu_round(benchmark, read_quadrotor, path, {"name": "ardupilot_bin"}, rounds=3)
    benchmark.extra_info.update(rows=ds.sizes["time"], mb_per_cpu_s=round(path.stat().st_size / 1e6 / cpu, 2))
