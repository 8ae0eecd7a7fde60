"""Snakemake script: simulate one payload flight (sonic, INS and mast TOA5 files)."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import logged, simulate_payload

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    simulate_payload(**sm.params)
