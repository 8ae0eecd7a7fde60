"""Snakemake script: simulate one payload flight (sonic, INS and mast TOA5 files)."""

from dronewind.steps import logged, simulate_payload

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    simulate_payload(**sm.params)
