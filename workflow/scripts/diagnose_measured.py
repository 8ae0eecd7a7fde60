"""Snakemake script: residual features of one processed flight."""

from dronewind.steps import logged
from dronewind.steps.diagnosis import measured_features

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    measured_features(sm.input.sonic, sm.input.ins, sm.input.drone, sm.input.l3, sm.output[0], **sm.params)
