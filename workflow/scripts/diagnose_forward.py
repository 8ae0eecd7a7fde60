"""Snakemake script: the other two thirds of a flight's baseline seeds, joined with its probes' job."""

from dronewind.steps import logged
from dronewind.steps.diagnosis import forward_probes

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    forward_probes(sm.input.measured, sm.output[0], mast_l1=sm.input.mast, joined_with=[sm.input.probes], **sm.params)
