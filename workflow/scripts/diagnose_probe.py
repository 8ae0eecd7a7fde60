"""Snakemake script: one part (the baseline seeds or one mechanism's probes) of a flight's forward-model runs."""

from dronewind.steps import logged
from dronewind.steps.diagnosis import forward_probes

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    forward_probes(sm.input.measured, sm.output[0], mast_l1=sm.input.mast, **sm.params)
