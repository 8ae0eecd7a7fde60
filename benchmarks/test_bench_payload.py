"""The payload chain, file to file, per flight-hour: raw CSV and TOA5 to L1, L2, mast L2, L3 and both L4."""

from __future__ import annotations

from conftest import cpu_round, run_chain


def test_payload_chain_per_flight_hour(benchmark, flight, setup, tmp_path):
    """Every file step of one 20-min flight (the workflow's payload_chain and l4 jobs, in one process)."""
    _, cpu = cpu_round(benchmark, run_chain, flight, setup["processing"], tmp_path / "chain", rounds=2)
    hours = flight.hover_s / 3600.0
    benchmark.extra_info.update(flight_hours=round(hours, 3), cpu_s_per_flight_hour=round(cpu / hours, 2),
                                flight_hours_per_cpu_hour=round(hours * 3600.0 / cpu, 1))
