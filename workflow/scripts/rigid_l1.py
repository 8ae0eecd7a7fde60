"""Snakemake script: rigid-mount record L0 -> L1 (sonic and platform on one time axis, QC)."""

from dronewind.steps import logged
from dronewind.steps.payload import rigid_l1

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    rigid_l1(sm.input.record, sm.output[0], **sm.params)
