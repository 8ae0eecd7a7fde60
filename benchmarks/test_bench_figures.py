"""A figure of one flight: drone against mast velocity series (PNG and PDF) from its L3 and L4 files."""

from __future__ import annotations

from conftest import FLIGHT, cpu_round


def test_figure_of_a_flight(benchmark, flight, tmp_path):
    from dronewind.figures.timeseries import fig08_timeseries

    p = flight.products
    out, cpu = cpu_round(benchmark, fig08_timeseries, [p["l3"]], [p["l4_drone"], p["l4_mast"]],
                         tmp_path / "fig08", flights=[FLIGHT], rounds=3)
    benchmark.extra_info.update(files=[o.suffix for o in out], figures_per_cpu_min=round(60.0 / cpu, 1))
