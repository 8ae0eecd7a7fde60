"""Snakemake script: assemble tables/flight_stats.csv from the L4 files."""

from dronewind.steps import flight_stats, logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    flight_stats(list(sm.input), sm.output[0])
