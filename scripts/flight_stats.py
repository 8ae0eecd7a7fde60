"""Snakemake script: assemble tables/flight_stats.csv from the L4 files."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import flight_stats, logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    flight_stats(list(sm.input), sm.output[0])
