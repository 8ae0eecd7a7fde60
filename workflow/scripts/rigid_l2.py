"""Snakemake script: rigid-mount L1 -> L2 (steady segment, lag, motion-corrected east/north/up)."""

from dronewind.steps import logged
from dronewind.steps.payload import rigid_l2

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    rigid_l2(sm.input.l1, sm.output[0], **sm.params)
